"""``make exhaustive``: exhaustive (or documented large) RTL equivalence runs on the streaming co-simulation.

Every target of :data:`TARGETS` is streamed through its RTL on each simulator of ``--sim`` and compared with the
golden model, bit for bit, by :func:`cosim.stream.run_stream`. Prints vectors, mismatches, seconds and vectors/s
per unit and simulator, and writes ``build/exhaustive/report.json``: a list of records with ``unit``, ``preset``,
``simulator``, ``vectors``, ``mismatches``, ``seconds``, ``vectors_per_second`` (and ``space``, ``valid_errors``,
``missing``, ``first`` mismatches, ``shards``, ``wall_seconds``, ``build_seconds``, ``ok``). A record replaces
the earlier one of the same unit, preset and simulator; the others stay.

Sharding
--------
``--shard i/N`` checks only the ``i``-th of ``N`` contiguous index ranges of every selected target (1-based) and
writes ``build/exhaustive/shards/<unit>-<preset>-<sim>-<i>of<N>.json``; once all ``N`` shard files of a run are
present (copy them there from other machines of a batch system), the shards are merged into the report
automatically, or by ``--merge``. ``--jobs N`` runs ``N`` shards of each target at once on this machine. Merged
records sum ``vectors`` and ``mismatches``.

``seconds`` is the time the check took. For a run on one machine (``--jobs N`` included) that is the wall time; for
shards merged from their files (``--shard``, perhaps run on several machines at different times) it is the sum of
the shards' times, what one process would have taken. ``process_seconds`` is always that sum and
``wall_seconds`` the span from the first start to the last finish; ``vectors_per_second = vectors / seconds``.

Examples::

    python -m tools.exhaustive --sim icarus,verilator --jobs 2     # what `make exhaustive` runs
    python -m tools.exhaustive --sim verilator --only recip:default --shard 3/8
    python -m tools.exhaustive --merge
    python -m tools.exhaustive --list

Exit status: 0 when every record is bit-exact, 1 on any mismatch or valid-protocol error, 2 on a usage error.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import re
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from fxmodel.unit import preset

from cosim.harness import ROOT, simulator
from cosim.stream import Space, full_space, grid_space, parse_shard, run_stream

__all__ = ["Target", "TARGETS", "target", "run_target", "merge_shards", "update_report", "REPORT", "SHARDS"]

OUT = ROOT / "build" / "exhaustive"
REPORT = OUT / "report.json"
SHARDS = OUT / "shards"
#: Mismatch records kept in a merged record.
KEEP = 8
#: Largest input space a target may check whole without naming a subset (``--full`` overrides).
FULL_LIMIT = 1 << 32


@dataclass(frozen=True)
class Target:
    """One exhaustive run: a unit's preset and the input space it covers.

    ``space`` maps the parameter object to a :class:`~cosim.stream.Space`; ``None`` means every input.
    ``why`` documents a subset in the report.
    """

    unit: str
    preset: str = "default"
    space: Callable | None = None
    why: str = ""

    @property
    def name(self) -> str:
        return f"{self.unit}:{self.preset}"

    def params(self):
        return preset(self.unit, self.preset)

    def make_space(self, full: bool = False) -> Space:
        params = self.params()
        if self.space is None or full:
            if params.input_space() > FULL_LIMIT and not full:
                raise ValueError(f"{self.name}: {params.input_space()} inputs is too many to check whole: give the "
                                 "target a documented subset (e.g. grid_space)")
            return full_space(params)
        return self.space(params)


#: The runs of ``make exhaustive``. Adding a unit is one line.
TARGETS: tuple[Target, ...] = (
    Target("recip", "default"),                                        # all 2**24 inputs
    Target("recip", "small"),                                          # all 2**16 inputs
    # all 2**16 denominators x 133 numerators (every 512th code and the edge codes) + the hard cases: 8.8M vectors;
    # `--full` checks all 2**32 (about an hour on Verilator with --jobs 2).
    Target("divide", "default", lambda p: grid_space(p, 7, full=("d",)),
           "all d, n on every 512th code and the edge codes, plus the hard cases"),
    # Target("cube", "default", lambda p: grid_space(p, 7), "x, y, z on every 2048th code and the edge codes"),
)


def target(name: str) -> Target:
    """The target ``unit`` or ``unit:preset`` of :data:`TARGETS` (or a full-space run of any registered preset)."""
    unit, _, pre = name.partition(":")
    for t in TARGETS:
        if t.unit == unit and t.preset == (pre or "default"):
            return t
    preset(unit, pre or "default")                    # ValueError naming the unknown unit or preset
    return Target(unit, pre or "default")


def _shard_file(t: Target, sim: str, i: int, n: int) -> Path:
    return SHARDS / f"{t.unit}-{t.preset}-{sim}-{i}of{n}.json"


def _record(t: Target, result: dict, shard: tuple[int, int] | None, full: bool = False) -> dict:
    rec = {"unit": t.unit, "preset": t.preset, "simulator": result["simulator"], "vectors": result["vectors"],
           "mismatches": result["mismatches"], "seconds": result["seconds"],
           "vectors_per_second": result["vectors_per_second"], "process_seconds": result["seconds"],
           "ok": result.ok,
           "valid_errors": result["valid_errors"], "missing": result["missing"],
           "expected_vectors": result["expected_vectors"], "space": result["space"], "range": result["range"],
           "first": result["first"], "build_seconds": result["build_seconds"],
           "sim_cpu_seconds": result["sim_cpu_seconds"],
           "started": result["started"], "finished": result["finished"],
           "wall_seconds": round(result["finished"] - result["started"], 3)}
    if t.why and not full:
        rec["subset"] = t.why
    if shard:
        rec["shard"] = list(shard)
    return rec


def run_target(t: Target, sim: str, *, shard: tuple[int, int] | None = None, full: bool = False,
               progress=None, chunk: int | None = None) -> dict:
    """Run one target (or one shard of it) on ``sim``; a shard is also written to its shard file."""
    kwargs = {"chunk": chunk} if chunk else {}
    result = run_stream(t.params(), t.make_space(full), sim=sim, shard=shard, progress=progress, **kwargs)
    rec = _record(t, result, shard, full)
    if shard:
        SHARDS.mkdir(parents=True, exist_ok=True)
        _shard_file(t, sim, *shard).write_text(json.dumps(rec, indent=1))
    return rec


def merge_records(recs: list[dict]) -> dict:
    """One record from the records of all shards of a run (see the module docstring)."""
    recs = sorted(recs, key=lambda r: r["range"][0])
    n = recs[0]["shard"][1]
    if sorted(r["shard"][0] for r in recs) != list(range(1, n + 1)):
        raise ValueError(f"{recs[0]['unit']}:{recs[0]['preset']} on {recs[0]['simulator']}: shards "
                         f"{sorted(r['shard'][0] for r in recs)} are not exactly 1..{n}")
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
            "wall_seconds": round(finished - started, 3), "shards": n}


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
    for (unit, pre, sim, n), files in sorted(groups.items()):
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
    with open(path.with_suffix(".lock"), "w") as lock:
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
    head = ("unit", "preset", "simulator", "vectors", "mismatches", "seconds", "vectors/s", "wall s", "result")
    rows = [(r["unit"], r["preset"], r["simulator"], f"{r['vectors']:,}", f"{r['mismatches']:,}",
             f"{r['seconds']:.1f}", f"{r['vectors_per_second']:,.0f}", f"{r['wall_seconds']:.1f}",
             "bit-exact" if r["ok"] else "FAIL") for r in records]
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    fmt = lambda row: "  ".join(str(x).rjust(w) if i >= 3 else str(x).ljust(w)  # noqa: E731
                                for i, (x, w) in enumerate(zip(row, widths)))
    return "\n".join([fmt(head), fmt(["-" * w for w in widths])] + [fmt(r) for r in rows])


def _failures(records: list[dict]) -> str:
    out = []
    for r in records:
        if r["ok"]:
            continue
        out.append(f"{r['unit']}:{r['preset']} on {r['simulator']}: {r['mismatches']} mismatches, "
                   f"{r['valid_errors']} valid-protocol errors, {r['missing']} missing outputs, "
                   f"{r['vectors']} of {r['expected_vectors']} vectors compared")
        out += [f"  index {f['index']}: inputs {f['inputs']} rtl {f['rtl']} model {f['model']}" for f in r["first"]]
    return "\n".join(out)


def _run_jobs(t: Target, sim: str, jobs: int, full: bool, chunk: int | None) -> dict:
    """Run ``jobs`` shards of a target at once (threads; each drives its own simulator process) and merge."""
    from tqdm import tqdm

    space = t.make_space(full)
    bar = tqdm(total=len(space), desc=f"{t.name} {sim}", unit="vec", unit_scale=True, smoothing=0.1)
    if jobs == 1:
        try:
            return run_target(t, sim, full=full, progress=bar, chunk=chunk)
        finally:
            bar.close()
    recs, errors = [None] * jobs, []

    def one(i):
        try:
            recs[i - 1] = run_target(t, sim, shard=(i, jobs), full=full, progress=bar, chunk=chunk)
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=one, args=(i,)) for i in range(1, jobs + 1)]
    for th in threads:
        th.start()
        time.sleep(0.2)                                  # the first takes the build lock
    for th in threads:
        th.join()
    bar.close()
    if errors:
        raise errors[0]
    for i in range(1, jobs + 1):
        _shard_file(t, sim, i, jobs).unlink(missing_ok=True)
    rec = merge_records(recs)
    # the shards ran side by side here: the run took the wall time
    rec["seconds"] = rec["wall_seconds"]
    rec["vectors_per_second"] = rec["vectors"] / rec["seconds"] if rec["seconds"] else 0.0
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.exhaustive", description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__[__doc__.index("Sharding"):])
    ap.add_argument("--sim", default="icarus,verilator", help="comma-separated simulators (default: %(default)s)")
    ap.add_argument("--only", default="", help="comma-separated targets UNIT[:PRESET] (default: all of TARGETS)")
    ap.add_argument("--shard", help="run only shard i of N (1-based) of each target, e.g. 2/8")
    ap.add_argument("--jobs", type=int, default=1, help="shards run at once on this machine (default: 1)")
    ap.add_argument("--merge", action="store_true", help="only merge complete sets of shard files into the report")
    ap.add_argument("--full", action="store_true", help="every input of every target, not a documented subset")
    ap.add_argument("--chunk", type=int, help="vectors per $readmemh chunk (default: cosim.stream.CHUNK)")
    ap.add_argument("--list", action="store_true", help="list the targets and their input spaces")
    args = ap.parse_args(argv)
    try:
        targets = [target(x.strip()) for x in args.only.split(",") if x.strip()] or list(TARGETS)
        if args.list:
            for t in targets:
                print(f"{t.name:<16} {t.make_space(args.full).describe()}")
            return 0
        shard = parse_shard(args.shard) if args.shard else None
        if args.jobs < 1:
            raise ValueError(f"--jobs {args.jobs}: must be >= 1")
        if shard and args.jobs > 1:
            raise ValueError("--shard and --jobs > 1 do not combine: give each process its own --shard")
        sims = [] if args.merge else [simulator(s.strip()) for s in args.sim.split(",") if s.strip()]
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.merge:
        records = merge_shards()
        if not records:
            print(f"no complete set of shard files in {SHARDS}", file=sys.stderr)
            return 2
    else:
        records = []
        for t in targets:
            for sim in sims:
                if shard:
                    print(f"{t.name} on {sim}: shard {shard[0]}/{shard[1]}", flush=True)
                    run_target(t, sim, shard=shard, full=args.full, progress=True, chunk=args.chunk)
                else:
                    records.append(_run_jobs(t, sim, args.jobs, args.full, args.chunk))
        if shard:
            records = merge_shards()
            if not records:
                print(f"shard {shard[0]}/{shard[1]} written to {SHARDS}; the report is merged once all "
                      f"{shard[1]} shards are there (or run --merge)")
                return 0
    update_report(records)
    print(table(records))
    print(f"(report: {REPORT})")
    bad = _failures(records)
    if bad:
        print(bad, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
