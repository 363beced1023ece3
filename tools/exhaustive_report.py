"""The records of the exhaustive runs (:mod:`tools.exhaustive`): shard records merged into one per unit, preset and
simulator (:func:`merge_records`, :func:`merge_shards`), entered in the report (:func:`update_report`), printed
(:func:`table`, :func:`failures`).
"""

from __future__ import annotations

import fcntl
import json
import re
from pathlib import Path

from fxmodel.core.paths import build_dir

__all__ = ["OUT", "REPORT", "SHARDS", "KEEP", "EXACT", "merge_records", "merge_shards", "update_report", "table",
           "failures"]

OUT = build_dir("exhaustive")
REPORT = OUT / "report.json"
SHARDS = OUT / "shards"
#: Mismatch records kept in a merged record.
KEEP = 8
#: The model against exact math (tools.prove), beside the HDL simulators.
EXACT = "exact"


def merge_records(recs: list[dict], partial: bool = False) -> dict:
    """One record from the records of all shards of a run (see the module docstring); ``partial``: of a
    contiguous run of shards ``a..b`` of ``N`` (``pieces`` in the record), not necessarily all."""
    recs = sorted(recs, key=lambda r: r["range"][0])
    n = recs[0]["shard"][1]
    numbers = [r["shard"][0] for r in recs]
    first_shard = numbers[0] if partial else 1
    if numbers != list(range(first_shard, first_shard + (len(recs) if partial else n))):
        raise ValueError(f"{recs[0]['unit']}:{recs[0]['preset']} on {recs[0]['simulator']}: shards "
                         f"{numbers} are not exactly {first_shard}..{numbers[-1] if partial else n}")
    for a, b in zip(recs, recs[1:]):
        if a["range"][1] != b["range"][0] or a["space"] != b["space"]:
            raise ValueError(f"{a['unit']}:{a['preset']}: shard ranges {a['range']} and {b['range']} do not join "
                             "(different spaces or shard counts)")
    total = {k: sum(r[k] for r in recs) for k in ("vectors", "mismatches", "valid_errors", "missing",
                                                     "expected_vectors")}
    seconds = sum(r.get("process_seconds", r["seconds"]) for r in recs)
    first = sorted((f for r in recs for f in r["first"]), key=lambda f: f["index"])[:KEEP]
    started, finished = min(r["started"] for r in recs), max(r["finished"] for r in recs)
    return {"unit": recs[0]["unit"], "preset": recs[0]["preset"], "simulator": recs[0]["simulator"],
            "vectors": total["vectors"], "mismatches": total["mismatches"], "seconds": round(seconds, 3),
            "vectors_per_second": total["vectors"] / seconds if seconds else 0.0,
            "process_seconds": round(seconds, 3),
            "ok": all(r["ok"] for r in recs), "valid_errors": total["valid_errors"], "missing": total["missing"],
            "expected_vectors": total["expected_vectors"], "space": recs[0]["space"],
            "range": [recs[0]["range"][0], recs[-1]["range"][1]], "first": first,
            **({"subset": recs[0]["subset"]} if "subset" in recs[0] else {}),
            "build_seconds": max(r["build_seconds"] for r in recs),
            "sim_cpu_seconds": round(sum(r.get("sim_cpu_seconds", 0.0) for r in recs), 3),
            "started": started, "finished": finished,
            "wall_seconds": round(finished - started, 3), "shards": n, **_merge_exact(recs),
            **({"cpu_seconds": round(sum(r["cpu_seconds"] for r in recs), 3)}
               if all("cpu_seconds" in r for r in recs) else {}),
            **({"pieces": [numbers[0], numbers[-1]]} if partial else {})}


def _merge_exact(recs: list[dict]) -> dict:
    """The model-against-exact-math fields of merged records: the worst error and where, unfaithful outputs."""
    if not all("max_error_ulp" in r for r in recs):
        return {}
    worst = max(recs, key=lambda r: r["max_error_ulp"])
    return {"max_error_ulp": worst["max_error_ulp"], "worst_index": worst["worst_index"],
            "unfaithful": sum(r["unfaithful"] for r in recs), "bound_ulp": worst["bound_ulp"]}


_SHARD_RE = re.compile(r"^(?P<unit>.+)-(?P<preset>[^-]+)-(?P<sim>[^-]+)-(?P<i>\d+)of(?P<n>\d+)\.json$")


def merge_shards(folder: Path = SHARDS, remove: bool = True) -> list[dict]:
    """Merge every complete set of shard files in ``folder`` (removing them if ``remove``); return the records.

    Incomplete sets stay for later. A set is one unit, preset, simulator and shard count ``N``."""
    groups: dict[tuple, dict[int, Path]] = {}
    for path in sorted(Path(folder).glob("*.json")):
        m = _SHARD_RE.match(path.name)
        if m:
            groups.setdefault((m["unit"], m["preset"], m["sim"], int(m["n"])), {})[int(m["i"])] = path
    merged = []
    for (_, _, _, n), files in sorted(groups.items()):
        if sorted(files) != list(range(1, n + 1)):
            continue
        merged.append(merge_records([json.loads(p.read_text()) for p in files.values()]))
        if remove:
            for p in files.values():
                p.unlink(missing_ok=True)
    return merged


def update_report(records: list[dict], path: Path = REPORT) -> list[dict]:
    """Enter ``records`` in the report (replacing those of the same unit, preset and simulator); return it all."""
    path.parent.mkdir(parents=True, exist_ok=True)
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / f"{path.stem}.lock", "w") as lock:                 # (not beside a committed record file)
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            old = json.loads(path.read_text()) if path.exists() else []
        except json.JSONDecodeError:
            old = []
        key = lambda r: (r["unit"], r["preset"], r["simulator"])  # noqa: E731
        new = {key(r): r for r in records}
        report = [r for r in old if key(r) not in new] + list(new.values())
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(report, indent=1))
        tmp.replace(path)
    return report


def table(records: list[dict]) -> str:
    """The report as a text table, one row a record."""
    head = ("unit", "preset", "simulator", "vectors", "mismatches", "seconds", "vectors/s", "wall s", "cpu s",
            "result")

    def result(r):
        verdict = ("within bound" if r["simulator"] == EXACT else "bit-exact") if r["ok"] else "FAIL"
        if "pieces" in r:
            verdict += (f" (partial: pieces {r['pieces'][0]}..{r['pieces'][1]} of {r['shards']}, "
                        f"{100 * r.get('fraction', 0):.1f} % of the space)")
        return verdict

    rows = [(r["unit"], r["preset"], r["simulator"], f"{r['vectors']:,}", f"{r['mismatches']:,}",
             f"{r['seconds']:.1f}", f"{r['vectors_per_second']:,.0f}", f"{r['wall_seconds']:.1f}",
             f"{r['cpu_seconds']:.1f}" if "cpu_seconds" in r else "-", result(r)) for r in records]
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    fmt = lambda row: "  ".join(str(x).rjust(w) if i >= 3 else str(x).ljust(w)  # noqa: E731
                                for i, (x, w) in enumerate(zip(row, widths)))
    return "\n".join([fmt(head), fmt(["-" * w for w in widths])] + [fmt(r) for r in rows])


def failures(records: list[dict]) -> str:
    """What went wrong in the failed ``records``: counts and the first mismatches, a line each."""
    out = []
    for r in records:
        if r["ok"]:
            continue
        out.append(f"{r['unit']}:{r['preset']} on {r['simulator']}: {r['mismatches']} mismatches, "
                   f"{r['valid_errors']} valid-protocol errors, {r['missing']} missing outputs, "
                   f"{r['vectors']} of {r['expected_vectors']} vectors compared")
        out += [f"  index {f['index']}: inputs {f['inputs']} model {f['model']} error {f['error_ulp']:.6f} ulp "
                f"> bound {f['bound_ulp']:.6f}" if "error_ulp" in f else
                f"  index {f['index']}: inputs {f['inputs']} rtl {f['rtl']} model {f['model']}" for f in r["first"]]
    return "\n".join(out)
