"""Measured tables of the documentation, generated from the committed records of the commands that measured them.

Each function here reads one record (``docs/records/*.json``, written by a tool's ``--record PATH`` or by
``bumpmap record``; ``docs/fpga/resources.json`` and ``docs/exhaustive/*.json`` predate that folder) and
returns Markdown: the table, then the command that measured it and the machine it ran on. A missing record gives a
line saying which command writes it, never a stale figure.
"""

from __future__ import annotations

import datetime
import json
import re
import statistics
from pathlib import Path

from fxmodel.core.paths import ROOT

from .fpga_report import describe_path, flow_caption
from .record import RECORDS, read

__all__ = ["provenance", "quickstart", "timed_commands", "scene_results", "triangle_results", "scenes_stress",
           "depth", "precision", "exhaustive_rcp32", "exhaustive_throughput", "fpga_resources", "bench", "raster_guard",
           "recip_errors", "rop_throughput", "records_index", "misses_tables"]

DOCS = ROOT / "docs"


def _rel(path: Path) -> str:
    """``path`` relative to ``docs/`` (links in the pages are relative to it)."""
    return path.resolve().relative_to(DOCS).as_posix()


def provenance(record: dict, path: Path) -> str:
    """One line: the command, the machine (processors, load average, date, commit) and a link to the record."""
    m = record.get("machine") or {}
    load = m.get("load_average")
    parts = [f"{m['nproc']} processors" if m.get("nproc") else None,
             f"load average {' / '.join(f'{x:g}' for x in load)}" if load else None,
             m.get("date"), f"commit `{m['commit']}`" if m.get("commit") else None]
    where = ", ".join(p for p in parts if p)
    return (f"*Measured by `{record['command']}`" + (f" ({where})" if where else "")
            + f"; record: [`{_rel(path)}`]({_rel(path)}).*\n")


def missing_record(path: Path, command: str) -> str:
    """The line a generated table shows while its record does not exist: the command that writes it."""
    return f"*No record yet: `{command}` writes `{_rel(path)}`.*\n"


def load_record(name: str):
    """``(record, path)`` of ``docs/records/<name>.json``; ``(None, path)`` while it does not exist."""
    path = RECORDS / f"{name}.json"
    return (read(path), path) if path.is_file() else (None, path)


def md_table(header, rows, align=None) -> str:
    """A Markdown table of ``header`` and ``rows`` (``align``: :func:`col_align`'s markers; default the first
    column left, the others right)."""
    align = align or ["---"] + ["---:"] * (len(header) - 1)
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _db(x) -> str:
    return "∞" if x is None or x == float("inf") else f"{x:.1f} dB"


def _lsb(x) -> str:
    return f"{x} LSB"


# -- transcripts of the quick start ----------------------------------------------------------------------------
def quickstart(name: str, head: int = 40, tail: int = 0, keep: str | None = None) -> str:
    """A fenced block: ``$ command`` and the lines it printed (the first ``head`` and, after ``…``, the last
    ``tail`` lines; or, with the regular expression ``keep``, the matching lines, ``…`` for each gap), from the
    transcript record ``name`` (:func:`tools.record.transcript`)."""
    record, path = load_record(name)
    if record is None:
        return "```text\n" + missing_record(path, f"bumpmap record {name} -- COMMAND") + "```\n"
    lines = record["result"]["stdout"]
    if keep is not None:
        shown, last = [], -1
        for i, line in enumerate(lines):
            if re.search(keep, line):
                shown += (["…"] if i > last + 1 else []) + [line]
                last = i
        shown += ["…"] if last < len(lines) - 1 else []
    else:
        shown = lines if len(lines) <= head + tail else lines[:head] + ["…"] + (lines[-tail:] if tail else [])
    return "```text\n$ " + record["command"] + "\n" + "\n".join(shown) + "\n```\n"


def timed_commands(names=("quickstart-sim", "sim-verilator", "quickstart-test", "quickstart-render")) -> str:
    """Wall time and exit status of the quick-start commands, one row per transcript record."""
    rows, notes = [], []
    for name in names:
        record, path = load_record(name)
        if record is None:
            notes.append(missing_record(path, f"bumpmap record {name} -- COMMAND"))
            continue
        r, m = record["result"], record["machine"]
        rows.append((f"`{record['command']}`", r["returncode"], f"{r['seconds']:.1f} s", m.get("nproc"),
                     " / ".join(f"{x:g}" for x in m.get("load_average") or []), m.get("date"),
                     f"[`{_rel(path)}`]({_rel(path)})"))
    head = ("command", "exit status", "wall time", "processors", "load average at the end", "date", "record")
    return (md_table(head, rows, ["---"] + ["---:"] * 4 + ["---", "---"]) + "\n" if rows else "") + "".join(notes)


# -- results ---------------------------------------------------------------------------------------------------
def scene_results() -> str:
    """The shipped scenes through the bit-exact model from fragments, against references (a), (b) and (c)."""
    record, path = load_record("figures")
    if record is None:
        return missing_record(path, "bumpmap figures build/figures --record docs/records/figures.json")
    rows = []
    for s, r in record["result"].items():
        c = r.get("vs_truth", {}).get("model")
        rows.append((f"`{s}`", f"{r['pixels']:,}", _db(r["psnr_db_vs_float"]), _lsb(r["max_lsb_vs_float"]),
                     _db(r["psnr_db_vs_ideal"]), _lsb(r["max_lsb_vs_ideal"]),
                     _db(c["psnr_db"]) if c else "not measured", f"{c['flip_mean']:.4f}" if c else "",
                     _lsb(round(c["p99_lsb"])) if c else ""))
    head = ("scene", "pixels", "PSNR vs (a)", "max vs (a)", "PSNR vs (b)", "max vs (b)", "PSNR vs (c)",
            "FLIP vs (c)", "p99 vs (c)")
    return md_table(head, rows) + "\n\n(c): the true image, " + _truth_note(record) + "\n\n" + provenance(record, path)


def _truth_note(record) -> str:
    """How reference (c) was sampled in ``record`` (the samples per pixel; fully covered pixels only)."""
    k = {r["vs_truth"]["samples"] for r in record["result"].values() if "vs_truth" in r}
    if not k:
        return "not in this record."
    return f"{' / '.join(f'{v} x {v}' for v in sorted(k))} samples per pixel (host/truth.py), on the fully " \
        "covered pixels; FLIP is the mean over them, p99 the 99th-percentile difference."


def triangle_results() -> str:
    """The shipped scenes drawn from triangles (set-up, scan converter, interpolators) by the bit-exact model."""
    record, path = load_record("figures")
    if record is None:
        return missing_record(path, "bumpmap figures build/figures --record docs/records/figures.json")
    rows = []
    for s, r in record["result"].items():
        t = r.get("triangles")
        if t:
            rows.append((f"`{s}`", t["triangles"], f"{t['fragments']:,}", f"{t['clocks_per_covered_pixel']:.4f}",
                         _db(t["psnr_db_vs_float"]), _lsb(t["max_lsb_vs_float"]), _lsb(t["max_lsb_vs_ideal"]),
                         _lsb(t["vs_fragments"]["max_lsb_vs_fragments"])))
    head = ("scene", "triangles", "fragments", "clocks per covered pixel", "PSNR vs (a)", "max vs (a)", "max vs (b)",
            "max vs the frame from fragments")
    return md_table(head, rows) + "\n" + provenance(record, path)


def scenes_stress(sizes=(32, 64)) -> str:
    """Random valid scenes (``tools.scenes_stress``): drawn, refused, within the bound, ill-conditioned pixels."""
    rows, notes = [], []
    for size in sizes:
        record, path = load_record(f"scenes-stress-{size}")
        if record is None:
            notes.append(missing_record(path, f"bumpmap scenes-stress --size {size} --record {_rel(path)}"))
            continue
        s = record["result"]
        why = ", ".join(f"`{k}` {v}" for k, v in sorted(s["refused_because"].items()))
        rows.append((f"{size} × {size}", s["scenes"], s["drawn"], f"{s['refused']} ({why})", s["empty"],
                     s["drawn_within_1_lsb_well_conditioned"], s["drawn_within_bound"],
                     _lsb(s["worst_lsb_well_conditioned"]),
                     f"{s['ill_conditioned_pixels']} ({s['frames_with_ill_conditioned_pixels']})",
                     _lsb(s["worst_lsb_ill_conditioned"]), f"{s['seconds_per_scene']:.2f} s"))
        notes.append(provenance(record, path))
    head = ("size", "scenes", "drawn", "refused (inputs named)", "no fragment", "within 1 LSB of (a), well-conditioned",
            "within the bound", "worst, well-conditioned", "ill-conditioned pixels (frames)", "worst, ill-conditioned",
            "time a scene")
    return (md_table(head, rows) + "\n" if rows else "") + "\n".join(notes)


def depth() -> str:
    """Overdraw, early depth, depth disagreements and frame-buffer traffic of the shipped scenes."""
    record, path = load_record("depth")
    if record is None:
        return missing_record(path, "bumpmap depth --record docs/records/depth.json")
    from .depth import table
    return table(record["result"]) + "\n\n" + provenance(record, path)


def precision() -> str:
    """Where the fixed-point error goes against the true image, unit by unit, and a wider diffuse factor."""
    record, path = load_record("precision")
    if record is None:
        return missing_record(path, "bumpmap precision --diffuse-frac 11 12 13 --extra-frac 0 2 3 --record "
                                  "docs/records/precision.json")
    from .precision import table
    return table(record["result"]) + "\n\n" + provenance(record, path)


# -- exhaustive proofs and their throughput (records predating docs/records/) -------------------------------------
RCP32 = DOCS / "exhaustive" / "rcp32.json"
THROUGHPUT = DOCS / "exhaustive" / "throughput.json"


def _date(ts) -> str:
    return datetime.datetime.fromtimestamp(ts, datetime.UTC).strftime("%Y-%m-%dT%H:%MZ") if ts else "?"


def exhaustive_rcp32() -> str:
    """The 2^32-input runs of ``recip`` ``rcp32``: model against exact math, RTL against model."""
    runs = json.loads(RCP32.read_text(encoding="utf-8"))
    rows = []
    for r in sorted(runs, key=lambda r: r["simulator"] != "exact"):
        what = "model vs exact math" if r["simulator"] == "exact" else f"RTL vs model ({r['simulator']})"
        if r["simulator"] == "exact":
            result = (f"worst {r['max_error_ulp']:.4f} ulp (bound {r['bound_ulp']:.4f}), "
                      f"{r['unfaithful']} unfaithful")
        else:
            result = f"{r['mismatches']} mismatches, {r['missing']} lost, {r['valid_errors']} protocol errors"
        p = r.get("projection") or {}
        rows.append((what, f"{r['vectors']:,}", result, f"{r['wall_seconds'] / 60:.1f} min",
                     f"{r['cpu_seconds'] / 60:.1f} min", r["workers"], p.get("load_average", "?"),
                     p.get("ratio", "?"), _date(r.get("started"))))
    head = ("check", "inputs", "result", "wall", "CPU", "workers", "load average (first pieces)",
            "time / projection", "started")
    return (md_table(head, rows, ["---", "---:", "---"] + ["---:"] * 6)
            + "\n*Measured by `bumpmap exhaustive --sim exact|verilator --only recip:rcp32 --jobs 2 --record "
              "docs/exhaustive/rcp32.json` on a 2-processor machine; record: "
              f"[`{_rel(RCP32)}`]({_rel(RCP32)}).*\n")


def exhaustive_throughput() -> str:
    """Speed-up of the exhaustive runs' Dask workers: the same pieces on 1 and on 2 workers, rounds repeated."""
    data = json.loads(THROUGHPUT.read_text(encoding="utf-8"))[0]
    by_workers: dict[int, list] = {}
    for r in data["runs"]:
        by_workers.setdefault(r["workers"], []).append(r)
    one = {r["round"]: r["vectors_per_second"] for r in by_workers.get(1, [])}
    rows = []
    for w, runs in sorted(by_workers.items()):
        ratios = [r["vectors_per_second"] / one[r["round"]] for r in runs if r["round"] in one]
        loads = [r["load_average"] for r in runs]
        rows.append((w, f"{statistics.median(r['vectors_per_second'] for r in runs):,.0f}",
                     f"{statistics.median(ratios):.2f}" if ratios else "",
                     f"{statistics.median(r['per_cpu_second'] for r in runs):,.0f}",
                     f"{min(loads):g} – {max(loads):g}"))
    head = ("workers", "vectors/s (median)", "speed-up (median of the rounds' ratios)",
            "vectors per CPU second (median)", "load average")
    return (md_table(head, rows)
            + f"\n*Measured by `bumpmap exhaustive --sim {data['simulator']} --only "
              f"{data['unit']}:{data['preset']} --throughput {data['runs'][0]['vectors']} --repeat {data['repeat']} "
              f"--record docs/exhaustive/throughput.json` ({data['pieces']} pieces a round); record: "
              f"[`{_rel(THROUGHPUT)}`]({_rel(THROUGHPUT)}).*\n")


# -- FPGA ------------------------------------------------------------------------------------------------------
RESOURCES = DOCS / "fpga" / "resources.json"


def fpga_resources() -> str:
    """Synthesized MULT18X18D and DP16KD blocks of every design against the cost model's estimate."""
    data = json.loads(RESOURCES.read_text(encoding="utf-8"))
    rows = []
    for d in data["designs"]:
        name = f"`{d['unit']}` {d['preset']}" + (f", {d['scene']} tables" if d.get("scene") else "")
        e = d["estimate"]
        rows.append((name, d["DSP"], e["DSP"], d["BRAM"], e["BRAM"], d.get("reason") or ""))
    head = ("design", "MULT18X18D", "estimate", "DP16KD", "estimate", "why they differ")
    return (md_table(head, rows, ["---"] + ["---:"] * 4 + ["---"])
            + f"\n*Synthesized by `{data['command']}` ({data['tools']}); record: "
              f"[`{_rel(RESOURCES)}`]({_rel(RESOURCES)}).*\n")


def misses_tables(m: dict) -> str:
    """The endpoints of a clock that missed its period (``bumpmap bitstream --misses``, ``bumpmap fpga
    --misses``): how many, by unit, by kind, and the worst, one per register; none, one sentence."""
    if not m["endpoints"]:
        return (f"No endpoint of `{m['clock']}` arrives later than its period, {m['period_ns']:g} ns (nextpnr's "
                "per-net timing; a register's setup time is not in it).\n")
    units = md_table(["unit", "endpoints"], [[f"`{u}`", n] for u, n in m["by_unit"].items()], col_align("lr"))
    kinds = md_table(["endpoint", "endpoints"], [[k, n] for k, n in m["by_kind"].items()], col_align("lr"))
    worst = md_table(["arrival (ns)", "unit", "register", "pin"],
                   [[w["ns"], f"`{w['unit']}`", f"`{w['register']}`", w["pin"]] for w in m["worst"]], col_align("rlll"))
    return (f"{m['endpoints']} endpoints of `{m['clock']}` arrive later than its period, {m['period_ns']:g} ns "
            "(nextpnr's per-net timing; a register's setup time is not in it, so the count is a floor).\n\n"
            + units + "\n" + kinds + "\n" + worst)


def fpga_placement(name: str = "placement", design: str = "--unit engine --scene SCENE --preset PRESET "
                                                           "--router router2") -> str:
    """Placed and routed designs (``bumpmap fpga ... --placement-record docs/fpga/<name>.json``): Fmax against
    the target, resources and the critical path nextpnr names; ``design`` the options the missing record's
    command names. A design placed alone (``--no-route``) shows nextpnr's estimate, said so."""
    path = DOCS / "fpga" / f"{name}.json"
    if not path.is_file():
        return missing_record(path, f"bumpmap fpga {design} --placement-record docs/fpga/{name}.json")
    record = read(path)
    r = record["result"]
    rows = []
    for d in r["designs"]:
        label = (f"`{d['unit']}` {d['preset']}" + (f", {d['scene']} tables" if d.get("scene") else "")
                 + (", maps behind the texel cache" if d.get("textures") else ""))
        if "error" in d:
            rows.append((label, d.get("target_mhz", ""), f"failed: {d['error']}", "", "", "", "", "", ""))
            continue
        placed = d.get("routed") is False                   # bumpmap fpga --no-route: the placer's estimate
        fmax = f"{d['fmax_mhz']} MHz" + (" (estimated after placement; not routed)" if placed else " (routed)")
        met = "yes" if d["met"] else "**no**"
        if placed:
            met = ("estimate at or above it" if d["met"] else "**no**, estimate below") + "; not routed"
        rows.append((label, f"{d['target_mhz']} MHz", fmax, met,
                     d.get("LUT4", ""), d.get("FF", ""), d.get("DSP", ""), d.get("BRAM", ""),
                     describe_path(d["critical_path"]) if d.get("critical_path") else ""))
    head = ("design", "target", "Fmax", "met", "LUT4", "FF", "MULT18X18D", "DP16KD", "critical path")
    flow = r.get("flow", {})
    misses = "".join(f"\n{misses_tables(d['misses'])}" for d in r["designs"] if d.get("misses"))
    return (md_table(head, rows, ["---"] + ["---:"] * 2 + ["---"] + ["---:"] * 4 + ["---"])
            + f"\n*{flow_caption(flow)}.* " + provenance(record, path) + misses)


# -- speed and design space ------------------------------------------------------------------------------------
def bench(name: str = "bench") -> str:
    """Throughput rows of ``tools.bench`` (model, fixed-point core, co-simulation), medians of its repeats."""
    record, path = load_record(name)
    if record is None:
        return missing_record(path, f"bumpmap bench --no-sweep --record docs/{_rel(path)}")
    rows = []
    for r in record["result"]["results"]:
        cpu = f"{r['per_cpu_second']:,.0f}" if "per_cpu_second" in r else ""
        rows.append((r["what"], r["workload"], f"{r['per_second']:,.0f}", cpu))
    head = ("measurement", "workload", "per second", "per CPU second")
    return md_table(head, rows, ["---", "---", "---:", "---:"]) + "\n" + provenance(record, path)


def raster_guard() -> str:
    """The scan converter's guard bits: worst interpolation error against its bound, and the cost."""
    record, path = load_record("sweep-raster")
    if record is None:
        return missing_record(path, "bumpmap sweep --only raster --no-pipeline --no-fpga --record "
                              "docs/records/sweep-raster.json")
    points = [p for p in record["result"]["points"] if p.get("unit") == "raster" and p["family"] == "guard"]
    rows = []
    for p in sorted(points, key=lambda p: p["measure"]["guard_bits"]):
        m = p["measure"]
        rows.append((m["guard_bits"], f"{m['accumulator_worst_ulp']:.3f} / {m['accumulator_bound_ulp']:.3f}",
                     f"{p['worst_ulp']:.3f} / {p['bound_ulp']:.3f}", p["dsp_blocks_est"], f"{m['register_bits']:,}",
                     f"{p['vectors']:,}"))
    head = ("guard bits `g`", "accumulators: worst / bound (output ulp)", "output codes: worst / bound",
            "MULT18X18D (est.)", "record + accumulator bits", "fragments measured")
    return md_table(head, rows) + "\n" + provenance(record, path)


def recip_errors(presets=("default", "small", "rcp24")) -> str:
    """The reciprocal presets' measured error over every input against exact math (``fxmodel errors recip``)."""
    rows, notes = [], []
    for name in presets:
        record, path = load_record(f"errors-recip-{name}")
        if record is None:
            notes.append(missing_record(path, f"bumpmap record errors-recip-{name} -- bumpmap errors "
                                        f"recip --preset {name}"))
            continue
        r = json.loads("\n".join(record["result"]["stdout"]))
        rows.append((f"`{name}`", r["coverage"], f"{r['vectors']:,}", f"{r['max_error_ulp']:.3f} ulp",
                     f"{r['mean_error_ulp']:.3f} ulp", f"{r['bound_ulp']:.3f} ulp",
                     "yes" if r["faithful"] else "**no**", "yes" if r["monotone"]["monotone"] else "**no**"))
        notes.append(provenance(record, path))
    head = ("preset", "inputs", "vectors", "worst error", "mean error", "documented bound", "faithful", "monotone")
    return (md_table(head, rows, ["---", "---"] + ["---:"] * 4 + ["---", "---"]) + "\n" if rows else "") \
        + "\n".join(notes)


def rop_throughput() -> str:
    """The raster-operations unit's fragments per clock against slots and added memory latency
    (``bumpmap rop-throughput``: its table pivoted, slots down, latency across)."""
    record, path = load_record("rop-throughput")
    if record is None:
        return missing_record(path, "bumpmap record rop-throughput -- bumpmap rop-throughput")
    cells: dict[int, dict[int, str]] = {}
    for line in record["result"]["stdout"]:
        parts = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(parts) == 3 and parts[0].isdigit() and parts[1].isdigit():
            cells.setdefault(int(parts[0]), {})[int(parts[1])] = parts[2]
    latencies = sorted({lat for row in cells.values() for lat in row})
    rows = [(slots, *(row.get(lat, "") for lat in latencies)) for slots, row in sorted(cells.items())]
    return md_table(("slots", *(f"L = {lat}" for lat in latencies)), rows) + "\n" + provenance(record, path)


def records_index() -> str:
    """Every record under ``docs/records/``: its command and machine."""
    rows = []
    for path in sorted(RECORDS.glob("*.json")):
        r = read(path)
        m = r["machine"]
        rows.append((f"[`{path.name}`]({_rel(path)})", f"`{r['command']}`", m.get("nproc"),
                     " / ".join(f"{x:g}" for x in m.get("load_average") or []), m.get("date"),
                     f"`{m.get('commit')}`"))
    head = ("record", "command", "processors", "load average", "date", "commit")
    return md_table(head, rows, ["---", "---", "---:", "---", "---", "---"]) if rows else "*No records yet.*\n"


# -- texel cache and filtering (issues of the third round) ----------------------------------------------------------
def texcache(name: str = "texcache") -> str:
    """The chosen texel cache and what it leaves on the memory per scene (``bumpmap cache-sweep``)."""
    record, path = load_record(name)
    if record is None:
        return missing_record(path, f"bumpmap cache-sweep --record docs/records/{name}.json")
    from .cache_sweep import table
    return table(json.loads(path.read_text(encoding="utf-8"))) + "\n\n" + provenance(record, path)


def texcache_rate(name: str = "texcache-rate") -> str:
    """The texture fetch's fragments per clock under memory latency (``bumpmap cache-rate``)."""
    record, path = load_record(name)
    if record is None:
        return missing_record(path, f"bumpmap cache-rate --record docs/records/{name}.json")
    from .cache_rate import table
    return table(record) + "\n" + provenance(record, path)


def texcache_engine(name: str = "texcache-engine") -> str:
    """The engine from triangles with its maps in external memory: clocks per fragment under memory latency
    (``bumpmap engine-rate``)."""
    record, path = load_record(name)
    if record is None:
        return missing_record(path, f"bumpmap engine-rate --record docs/records/{name}.json")
    from .engine_rate import table
    return table(record) + "\n" + provenance(record, path)


def col_align(spec: str) -> list[str]:
    """Column alignments of :func:`md_table` from letters: ``l`` left, ``r`` right."""
    return ["---" if c == "l" else "---:" for c in spec]


def _cells(m: dict) -> list:
    psnr = "exact" if m.get("psnr_db") is None else f"{m['psnr_db']:.2f} dB"
    return [psnr, f"{m['flip_mean']:.4f}", f"{m['p99_lsb']:g}", f"{m['max_lsb']}"]


def filtering_scenes() -> str:
    """Every shipped scene against reference (c), the true image: today's bit-exact frame, float (a), and the float
    filtering study's chosen design (fully covered pixels; edge pixels apart)."""
    record, path = load_record("filtering")
    if record is None:
        return missing_record(path, "bumpmap filtering --record docs/records/filtering.json")
    r = record["result"]
    rows = []
    for scene, s in r["scenes"].items():
        for key, label in (("model", "bit-exact model (no filtering)"), ("float_a", "float (a)"),
                           ("filtered", "chosen filter (float study)")):
            rows.append([f"`{scene}`" if key == "model" else "", label, *_cells(s[key]["full"]),
                         s[key]["edge"]["pixels"], *_cells(s[key]["edge"])[:2]])
    head = ["scene", "frame", "PSNR vs (c)", "mean FLIP", "p99 (LSB)", "max (LSB)", "edge pixels", "edge PSNR",
            "edge FLIP"]
    text = md_table(head, rows, col_align("llrrrrrrr"))
    return (f"{text}\n\nReference (c): {r['samples']} x {r['samples']} samples per pixel, {r['sample_pattern']}."
            f"\n\nChosen filter: {r['chosen']}.\n\n" + provenance(record, path))


def filtering_study() -> str:
    """Each filtering choice of the float study against (c) on the grazing floor and the tin plane, the level of
    detail's worst error against its bound, and the flicker of a slow pan."""
    record, path = load_record("filtering")
    if record is None:
        return missing_record(path, "bumpmap filtering --record docs/records/filtering.json")
    r = record["result"]
    out = []
    for scene, st in r["study"].items():
        rows = [[row["choice"] + (" (chosen)" if row.get("chosen") else ""), *_cells(row["full"]),
                 f"{row['full_vs_16x16']['psnr_db']:.2f} dB"] for row in st["rows"]]
        out += [f"**{scene}**", "", md_table(["choice", "PSNR vs (c)", "mean FLIP", "p99 (LSB)", "max (LSB)",
                                            "PSNR vs (c) at 16 x 16"], rows, col_align("lrrrrr")), ""]
    lod_rows = [[f"`{scene}`", m, f"{v['bound_levels']:.4f}", f"{v['max_error_vs_exact_levels']:.4f}",
                 "yes" if v["within_bound"] else "**no**"]
                for scene, maps in r["lod"].items() for m, v in maps.items() if isinstance(v, dict)]
    out += ["Level of detail in fixed point against exact arithmetic, every fragment:", "",
            md_table(["scene", "map", "bound (levels)", "worst (levels)", "within"], lod_rows, col_align("llrrl")), ""]
    f = r["flicker"]
    out += [f"Flicker on a pan of {f['frames']} frames, {f['degrees_per_frame']} degrees a frame (RMS of each "
            "frame-to-frame change less the truth's own):", "",
            md_table(["no filtering", "trilinear color", "chosen", "reduction (chosen)", "reduction (trilinear)"],
                   [[f["flicker_none"], f["flicker_trilinear"], f["flicker_ours"], f"{f['reduction']}x",
                     f"{f['reduction_trilinear']}x"]], col_align("rrrrr")), "", provenance(record, path)]
    return "\n".join(out)


def filtering_mip() -> str:
    """The bit-exact pipeline with MIP mapping against (c) on every shipped scene (``bumpmap mip``)."""
    record, path = load_record("mip")
    if record is None:
        return missing_record(path, "bumpmap mip --record docs/records/mip.json")
    from .mip import table
    return table(record["result"]) + "\n\n" + provenance(record, path)
