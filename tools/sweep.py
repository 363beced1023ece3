r"""Design-space sweep: speed against error of the reciprocal, the other units' widths and the pipeline.

``bumpmap sweep [--no-fpga] [--fpga-points N] [--unit-fpga-points N] [--unit-samples K] [--no-units]
[--only UNIT] [--no-pipeline] [--jobs J] [--scheduler ADDRESS] [--docs]`` (second phase of ``make bench``) measures
the reciprocal grid below, the
unit-width families and pipeline points of :mod:`tools.sweep_units` (perspective, cube, reflection and bump units:
error against exact math, cost, latency, throughput, ECP5 results for each unit's default preset and the cheapest
point of its front; pipeline presets rendered through the bit-exact model: PSNR and largest error against the float
reference, ``fit``'s hardware estimate), with one progress bar over all points.

Reciprocal: a grid of about 45 configurations that spans cheap to precise: table index bits ``m``, table
word bits ``b``, Taylor terms ``t`` (1 to 4), output precision ``p`` and table mode (``round``, the paper's
``round(1/w_h)``, against ``midpoint``, the expansion about each interval's centre; ``fxmodel/units/recip.py``). The
grid
(:func:`default_grid`) holds

* the presets ``default``, ``small`` and ``rcp24``, and the paper's configuration (``paper``: 128 entries
  (``m = 8``), ``t = 3``, ``round`` table, no centring constant, ``p = 17`` on the 24-bit input, ``b = 17``,
  ``guard = 2``);
* ``faithful`` points: for ``t`` in 1 to 4, ``m`` in 5 to 8 (``t = 1``: 6 to 12) and both modes, the widest
  ``p <= 24`` whose documented bound (``error_bound_ulp``) is below one ulp, with ``b = p + 3``, ``guard = 4``;
* ``p17`` points: ``p = 17``, ``b = 20``, ``guard = 4`` for ``t`` in 2 to 4, ``m`` in 6 and 8, both modes (the
  error a fixed output width gets from each table and term count, faithful or not).

Every point but ``rcp24`` has the 24-bit input ``s8.16`` (``small``: ``s4.12``). For each point the bit-exact model
(:meth:`RecipParams.compute`) runs over **every** input when the input space is at most ``--exhaustive-limit``
(default ``2**24``), else over ``--samples`` uniform random inputs plus the unit's hard cases; the error of each
output against the exact ``1/w`` comes from :func:`fxmodel.units.exact.recip_error_ulp` (exact integers). Recorded:
worst and mean error in ulps of the result, correct bits ``p - 1 - log2(error)`` (relative error of a mantissa in
``[1, 2)``; worst and mean), the documented bound, table bits, multipliers, estimated MULT18X18D blocks
(:func:`fxmodel.core.cost.estimate`, the one cost model), latency, model throughput (one timing of the whole
``compute`` call, one core), and, for at
most ``--fpga-points`` points (the four named ones first, then Pareto points spread evenly inside the front), the
ECP5 results of :func:`tools.fpga.run_designs` (LUT4, FF, DSP, block RAM, Fmax; cached under ``build/fpga``).

Cost and Pareto front. Without place and route for every point, the cost is a proxy:
``table_bits + dsp_weight * dsp`` (``--dsp-weight``, default 1024 ROM bits per 18x18 multiplier block), both from
:func:`fxmodel.core.cost.estimate` (its MULT18X18D count equals the synthesized one of every preset,
``docs/fpga/resources.json``).
A point is on the front when no other point has at least as many worst-case correct bits at no more cost
(and is better in one). Published anchors on the plot: NVIDIA's SFU reciprocal (Oberman & Siu 2005: 128 entries
of quadratic-interpolation coefficients, about 6.5 Kbit, two multipliers, at most 1 ulp at 24 bits, drawn at 23
correct bits) and the paper's configuration (measured here).

Writes ``build/bench/speed_vs_error.json`` (``points``: every unit's records with ``unit``; ``pareto``: each unit's
front; ``pipeline``), ``build/bench/speed_vs_error.md`` (a table per unit and one of the pipeline points),
``build/bench/pareto.png`` (the reciprocal) and ``build/bench/units.png`` (correct bits against cost per unit, PSNR
against cost for the pipeline); with ``--docs`` also both pictures in ``docs/img/``.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import ROOT, build_dir
from fxmodel.core.unit import preset
from fxmodel.units.exact import recip_error_ulp
from fxmodel.units.recip import RecipParams
from host.atomic import atomic_json, atomic_write_text
from tools.record import add_record_option, machine, write_if_asked

from .sweep_plots import ANCHORS, plot, plot_units
from .sweep_plots import declutter as _declutter  # noqa: F401  (tests/tools/test_sweep.py)
from .sweep_plots import unit_points as _points
from .sweep_units import unique_points

__all__ = ["PAPER", "ANCHORS", "faithful_p", "default_grid",
           "measure_point", "pareto_front", "sweep", "markdown", "plot", "plot_units", "write_outputs", "add_arguments",
           "run"]

OUT = build_dir("bench")
DOCS_IMG = ROOT / "docs" / "img"

#: Input format of the sweep (the default preset's 24-bit ``s8.16``).
IN24 = Fmt(True, 8, 16)

#: The paper's configuration (section 4.1): 128 entries, three terms, ``round(1/w_h)``, no centring constant.
PAPER = RecipParams(in_fmt=IN24, m=8, b=17, t=3, p=17, guard=2, table="round", center=False)

#: Chunk of inputs measured at once (bounds the memory of the exact error arithmetic).
CHUNK = 1 << 22


def _params(m, t, p, table, b=None, guard=4, in_fmt=IN24):
    try:
        return RecipParams(in_fmt=in_fmt, m=m, b=p + 3 if b is None else b, t=t, p=p, guard=guard, table=table)
    except ValueError:
        return None


def faithful_p(m: int, t: int, table: str, p_max: int = 24, in_fmt: Fmt = IN24) -> RecipParams | None:
    """The configuration with the widest ``p <= p_max`` whose documented bound is below one ulp (``b = p + 3``,
    ``guard = 4``), by bisection (the bound in ulps grows with ``p``); ``None`` if no ``p >= 4`` is faithful."""
    def ok(p):
        P = _params(m, t, p, table, in_fmt=in_fmt)
        return P is not None and P.error_bound_ulp < 1

    lo = next((p for p in range(4, p_max + 1) if _params(m, t, p, table, in_fmt=in_fmt)), None)
    if lo is None or not ok(lo):
        return None
    if ok(p_max):
        return _params(m, t, p_max, table, in_fmt=in_fmt)
    hi = p_max
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return _params(m, t, lo, table, in_fmt=in_fmt)


def default_grid() -> list[tuple[str, str, RecipParams]]:
    """``(name, family, params)`` of the sweep (module docstring), duplicates removed (first name kept)."""
    grid = [(f"preset {n}", "preset", preset("recip", n)) for n in ("default", "small", "rcp24")]
    grid.append(("paper", "paper", PAPER))
    for m in (6, 8, 10, 12):
        P = faithful_p(m, 1, "round")
        if P is not None:
            grid.append((f"t1 m{m} round p{P.p}", "faithful", P))
    for t in (2, 3, 4):
        for m in (5, 6, 7, 8):
            for table in ("round", "midpoint"):
                P = faithful_p(m, t, table)
                if P is not None:
                    grid.append((f"t{t} m{m} {table} p{P.p}", "faithful", P))
    for t in (2, 3, 4):
        for m in (6, 8):
            for table in ("round", "midpoint"):
                P = _params(m, t, 17, table, b=20)
                if P is not None:
                    grid.append((f"t{t} m{m} {table} p17", "p17", P))
    return unique_points(grid)


def _inputs(params: RecipParams, exhaustive_limit: int, samples: int, rng) -> tuple[np.ndarray, bool]:
    if params.input_space() <= exhaustive_limit:
        return params.all_inputs()[:, 0], True
    w = np.concatenate([params.random_inputs(rng, samples)[:, 0], params.hard_cases()[:, 0]])
    return w, False


def measure_point(name: str, family: str, params: RecipParams, *, exhaustive_limit: int = 1 << 24,
                  samples: int = 10 ** 6, dsp_weight: float = 1024.0, seed: int = 1) -> dict:
    """Error, cost and model throughput of one configuration (one JSON record; fields in the module docstring)."""
    rng = np.random.default_rng(seed)
    w, exhaustive = _inputs(params, exhaustive_limit, samples, rng)
    params.compute(w[:1000, None])                     # tables and cached formats outside the timing
    t0 = time.perf_counter()
    out = params.compute(w[:, None])
    rate = len(w) / (time.perf_counter() - t0)
    worst, worst_w, total = Fraction(0), None, 0.0
    for lo in range(0, len(w), CHUNK):
        num, den = recip_error_ulp(w[lo:lo + CHUNK], out[lo:lo + CHUNK, 0], out[lo:lo + CHUNK, 1],
                                   params.in_fmt.frac_bits, params.fo)
        err = np.asarray(num, dtype=np.float64) / np.asarray(den, dtype=np.float64)
        total += float(err.sum())
        i = int(np.argmax(err))
        cand = Fraction(int(num[i]), int(den[i]))       # exact worst of the chunk (float argmax, exact value)
        if cand > worst:
            worst, worst_w = cand, int(w[lo + i])
    mean = total / len(w)
    bound = params.error_bound_ulp
    est = params.cost()
    dsp = est["dsp"]

    def bits(e):
        return round(params.p - 1 - math.log2(e), 3) if e > 0 else None

    return {
        "name": name, "family": family, "unit": "recip",
        "params": {"in_fmt": str(params.in_fmt), "m": params.m, "b": params.b, "t": params.t, "p": params.p,
                   "guard": params.guard, "table": params.table, "center": params.center},
        "entries": params.entries, "table_bits": est["table_bits"], "multipliers": est["multipliers"],
        "dsp_blocks_est": dsp, "latency": params.latency,
        "bound_ulp": float(bound), "worst_ulp": float(worst), "mean_ulp": mean,
        "worst_input_code": worst_w, "within_bound": bool(worst <= bound), "faithful": bool(worst < 1),
        "correct_bits_worst": bits(float(worst)), "correct_bits_mean": bits(mean),
        "vectors": int(len(w)), "exhaustive": exhaustive, "model_per_second": rate,
        "cost": est["table_bits"] + dsp_weight * dsp, "fpga": None,
    }


def _db(psnr) -> str:
    """A PSNR for a table: ``exact`` for an exact match (``None``: infinite, written as JSON ``null``)."""
    return "exact" if psnr is None else f"{psnr:.2f}"


def pareto_front(records, cost_key: str = "cost", bits_key: str = "correct_bits_worst") -> list[int]:
    """Indices of the non-dominated records: no other record has ``>=`` bits at ``<=`` cost, better in one."""
    pts = [(r[cost_key], r[bits_key] if r[bits_key] is not None else math.inf) for r in records]
    front = []
    for i, (c, b) in enumerate(pts):
        if not any((c2 <= c and b2 >= b) and (c2 < c or b2 > b) for j, (c2, b2) in enumerate(pts) if j != i):
            front.append(i)
    return sorted(front, key=lambda i: pts[i][0])


def _fpga_subset(records, front, limit: int) -> list[int]:
    """The named points (presets, paper), then interior Pareto points spread evenly by cost, ``limit`` in all."""
    chosen = [i for i, r in enumerate(records) if r["family"] in ("preset", "paper")][:limit]
    rest = [i for i in front if i not in chosen]
    k = limit - len(chosen)
    if k > 0 and rest:
        picks = sorted({rest[round((j + 1) * (len(rest) - 1) / (k + 1))] for j in range(min(k, len(rest)))})
        chosen += picks
    return chosen


def _unit_fpga_subset(records, front, limit: int) -> list[int]:
    """A unit's default preset, then the cheapest point of its front (the narrow end), then the middle of the
    front, ``limit`` in all (the other presets are in ``make fpga``'s report)."""
    chosen = [i for i, r in enumerate(records) if r["family"] == "preset" and r["name"].endswith("default")][:1]
    for i in (front[:1] + front[len(front) // 2:len(front) // 2 + 1]) if front else []:
        if i not in chosen:
            chosen.append(i)
    return chosen[:limit]


def _run_fpga(records, grid, idx, jobs: int, progress: bool, scheduler: str | None = None) -> None:
    try:
        from tools.fpga import run_designs  # router1: on unit designs faster than router2 (tools.fpga.Flow)
        results = run_designs([({"unit": records[i]["unit"], "preset": records[i]["name"]}, grid[i][2]) for i in idx],
                              jobs=jobs, progress=progress, scheduler=scheduler)
    except Exception as exc:                       # a broken tool or RTL must not lose the model results
        print(f"sweep: FPGA flow failed: {exc!r}", file=sys.stderr)
        for i in idx:
            records[i]["fpga"] = {"error": repr(exc)}
        return
    for i, res in zip(idx, results):
        records[i]["fpga"] = {k: res.get(k) for k in ("LUT4", "FF", "DSP", "BRAM", "fmax_mhz", "target_mhz",
                                                      "met", "cached", "run", "error") if k in res}


@dataclass(frozen=True)
class SweepPoint:
    """One Dask task of the sweep: a unit point (``kind`` ``recip`` or ``unit``: name, family, parameter object) or
    a pipeline point (``pipeline``: name, units, knob changes), with the measurement's keyword arguments."""

    kind: str
    args: tuple
    kwargs: tuple = ()

    def describe(self) -> str:
        return f"sweep point {self.args[0]} ({self.kind})"


def measure_sweep_point(point: SweepPoint) -> dict:
    """The record of one sweep point (runs on a Dask worker)."""
    from . import sweep_units as su

    fn = {"recip": measure_point, "unit": su.measure_unit_point, "pipeline": su.measure_pipeline_point,
          "raster": su.measure_raster_point}[point.kind]
    return fn(*point.args, **dict(point.kwargs))


def _groups(records) -> dict:
    """Record indices by unit, in order of first appearance."""
    out = {}
    for i, r in enumerate(records):
        out.setdefault(r["unit"], []).append(i)
    return out


def sweep(grid=None, *, pipeline=None, scene=None, scene_size: int | None = None, exhaustive_limit: int = 1 << 24,
          samples: int = 10 ** 6, unit_samples: int | None = None, dsp_weight: float = 1024.0,
          fpga_points: int = 0, unit_fpga_points: int = 0, jobs: int = 1, progress: bool = True,
          scheduler: str | None = None) -> dict:
    """Measure every ``(name, family, params)`` of ``grid`` and render every pipeline point.

    ``grid``: reciprocal and other unit points (``None``: :func:`default_grid` and
    :func:`tools.sweep_units.default_unit_grid`). ``pipeline``: ``(name, preset name or knob changes)`` pairs
    (:data:`tools.sweep_units.PIPELINE_POINTS` when ``None`` and ``grid`` is ``None``, else none), rendered from
    ``scene`` (default :data:`tools.sweep_units.SCENE`) at ``scene_size`` (default: the scene's own size).
    ``unit_samples``: random vectors of the non-reciprocal units (default ``samples``).

    Returns ``{"meta", "points", "pareto", "pipeline"}``: ``points`` one record per grid point
    (:func:`measure_point`, :func:`tools.sweep_units.measure_unit_point`; ``unit`` names the unit, ``pareto`` true
    on its unit's front, ``fpga`` filled for at most ``fpga_points`` reciprocal and ``unit_fpga_points`` points of
    every other unit), ``pareto`` each unit's front (names by cost), ``pipeline`` ``{"scene", "points", "pareto"}``
    (:func:`tools.sweep_units.measure_pipeline_point`; front of PSNR against reference (a) over cost).

    Every point, then every place-and-route run, is a Dask
    task (:mod:`tools.jobs`): ``jobs`` at once on a local cluster, or on the cluster at ``scheduler``. (The model
    throughput of a point is then measured beside the other workers.)
    """
    from . import jobs as jobrunner
    from . import sweep_units as su

    t0 = time.perf_counter()
    full = grid is None
    grid = default_grid() + su.default_unit_grid() if full else list(grid)
    pipe = su.pipeline_grid(None if pipeline is None else pipeline) if (pipeline is not None or full) else []
    if not grid and not pipe:
        raise ValueError("sweep: the grid is empty")
    scene = scene or su.SCENE
    unit_samples = samples if unit_samples is None else unit_samples
    points = []
    for name, family, params in grid:
        if params.NAME == "recip":
            points.append(SweepPoint("recip", (name, family, params), (
                ("exhaustive_limit", exhaustive_limit), ("samples", samples), ("dsp_weight", dsp_weight))))
        elif params.NAME == "raster":
            points.append(SweepPoint("raster", (name, family, params), (("dsp_weight", dsp_weight),)))
        else:
            points.append(SweepPoint("unit", (name, family, params), (
                ("samples", unit_samples), ("dsp_weight", dsp_weight), ("exhaustive_limit", exhaustive_limit))))
    points += [SweepPoint("pipeline", (name, units, changes),
                          (("scene", scene), ("size", scene_size), ("dsp_weight", dsp_weight)))
               for name, units, changes in pipe]
    out = jobrunner.run_pieces(measure_sweep_point, points, jobs=jobs, scheduler=scheduler, desc="sweep",
                               describe=SweepPoint.describe, progress=progress)
    records, prec = out[:len(grid)], out[len(grid):]
    fronts, fpga_idx = {}, []
    for unit, idx in _groups(records).items():
        sub = [records[i] for i in idx]
        front = [idx[j] for j in pareto_front(sub)]
        fronts[unit] = [records[i]["name"] for i in front]
        for i in idx:
            records[i]["pareto"] = i in front
        limit = fpga_points if unit == "recip" else unit_fpga_points
        if limit > 0:
            pick = _fpga_subset if unit == "recip" else _unit_fpga_subset
            fpga_idx += [idx[j] for j in pick(sub, [idx.index(i) for i in front], min(limit, len(sub)))]
    if fpga_idx:
        _run_fpga(records, grid, fpga_idx, jobs, progress, scheduler)
    drawn = [i for i, r in enumerate(prec) if not r.get("refused")]      # a refused preset is never on the front
    pfront = [drawn[j] for j in pareto_front([prec[i] for i in drawn], bits_key="psnr_db_vs_float")] if drawn else []
    for i, r in enumerate(prec):
        r["pareto"] = i in pfront
    meta = {"machine": platform.platform(), "python": platform.python_version(), "dsp_weight": dsp_weight,
            "exhaustive_limit": exhaustive_limit, "samples": samples, "unit_samples": unit_samples,
            "seconds": round(time.perf_counter() - t0, 1),
            "cost": "table_bits + dsp_weight * dsp_blocks_est (fxmodel.core.cost.estimate; pipeline: hardware.dsp, "
                    "sampler blends included)",
            "unit_errors": {u: {"error": e["what"], "ulp": e["ulp_name"]} for u, e in su.UNIT_ERRORS.items()},
            "anchors": [{"name": a, "table_bits": tb, "multipliers": mu, "correct_bits": cb}
                        for a, tb, mu, cb in ANCHORS]}
    return {"meta": meta, "points": records, "pareto": fronts,
            "pipeline": {"scene": str(scene), "points": prec, "pareto": [prec[i]["name"] for i in pfront]}}


def _fmt(v, spec):
    return "" if v is None else format(v, spec)


def _recip_table(result: dict) -> list[str]:
    lines = ["| point | mode | m | entries | b | t | p | table bits | mult. (DSP est.) | latency | bound ulp "
             "| worst ulp | mean ulp | correct bits worst / mean | model M/s | LUT4 | DSP | Fmax MHz |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(_points(result, "recip"), key=lambda r: (r["cost"], r["name"])):
        P, f = r["params"], r["fpga"] or {}
        name = f"**{r['name']}**" if r.get("pareto") else r["name"]
        mode = P["table"] + ("" if P["center"] else ", no centring")
        ex = "" if r["exhaustive"] else "*"
        lines.append(
            f"| {name} | {mode} | {P['m']} | {r['entries']} | {P['b']} | {P['t']} | {P['p']} | {r['table_bits']} "
            f"| {r['multipliers']} ({r['dsp_blocks_est']}) | {r['latency']} | {r['bound_ulp']:.3f} "
            f"| {r['worst_ulp']:.3f}{ex} | {r['mean_ulp']:.3f} | {_fmt(r['correct_bits_worst'], '.2f')} / "
            f"{_fmt(r['correct_bits_mean'], '.2f')} | {r['model_per_second'] / 1e6:.0f} | {_fmt(f.get('LUT4'), 'd')} "
            f"| {_fmt(f.get('DSP'), 'd')} | {_fmt(f.get('fmax_mhz'), '.1f')} |")
    meta = result["meta"]
    lines += ["", f"Bold: Pareto front of worst-case correct bits against cost = table bits + {meta['dsp_weight']:g} "
              "× estimated MULT18X18D blocks. Errors over every input (24-bit `s8.16` input; `small`: `s4.12`); "
              f"`*`: {meta['samples']:,} random inputs plus the hard cases. FPGA: ECP5-85 speed 8 (`tools.fpga`)."]
    return lines


def _unit_table(result: dict, unit: str) -> list[str]:
    from .sweep_units import UNIT_ERRORS
    spec = UNIT_ERRORS[unit]
    lines = [f"Error: {spec['what']}; in real units (radians for reflect) and in {spec['ulp_name']}.", "",
             "| point | widths | table bits | mult. (DSP est.) | latency | bound | worst | mean | worst / bound ulp "
             "| correct bits worst / mean | vectors | model M/s | LUT4 | DSP | Fmax MHz |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(_points(result, unit), key=lambda r: (r["cost"], -(r["correct_bits_worst"] or 0), r["name"])):
        f = r["fpga"] or {}
        name = f"**{r['name']}**" if r.get("pareto") else r["name"]
        flag = "" if r["within_bound"] else " (above bound!)"
        lines.append(
            f"| {name} | {r['knobs']} | {r['table_bits']} | {r['multipliers']} ({r['dsp_blocks_est']}) "
            f"| {r['latency']} | {r['bound']:.3g} | {r['worst']:.3g}{flag} | {r['mean']:.3g} "
            f"| {r['worst_ulp']:.2f} / {r['bound_ulp']:.2f} | {_fmt(r['correct_bits_worst'], '.2f')} / "
            f"{_fmt(r['correct_bits_mean'], '.2f')} | {r['vectors']:,} | {r['model_per_second'] / 1e6:.1f} "
            f"| {_fmt(f.get('LUT4'), 'd')} | {_fmt(f.get('DSP'), 'd')} | {_fmt(f.get('fmax_mhz'), '.1f')} |")
    return lines


def _pipeline_table(result: dict) -> list[str]:
    pipe = result.get("pipeline") or {}
    lines = ["| point | changes from default | max LSB / PSNR dB vs float (a) | vs ideal (b) | table bits "
             "| multipliers | DSP est. | DP16KD est. | multiplier bit products | cube edge | memory bits | cost "
             "| model Mpixel/s |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in sorted(pipe.get("points", []), key=lambda r: (r["cost"], r["name"])):
        hw = r["hardware"]
        name = f"**{r['name']}**" if r.get("pareto") else r["name"]
        ch = ", ".join(f"{k} {a}→{b}" for k, (a, b) in r["changes"].items()) or (r["preset"] or "")
        if r.get("refused"):
            ch += f" (**refused**, drawn clamped: {r['refused']})"
        rate = r["model_pixels_per_second"]
        lines.append(
            f"| {name} | {ch} | {r['max_lsb_vs_float']} / {_db(r['psnr_db_vs_float'])} "
            f"| {r['max_lsb_vs_ideal']} / {_db(r['psnr_db_vs_ideal'])} | {hw['table_bits']} | {hw['multipliers']} "
            f"| {hw['dsp']} | {hw['bram']} | {hw['multiplier_bit_products']} | {r.get('cube_size', '')} "
            f"| {hw.get('memory_bits', '')} "
            f"| {r['cost']:.0f} | {_fmt(rate and rate / 1e6, '.2f')} |")
    return lines


def markdown(result: dict) -> str:
    """The sweep as Markdown: one table per unit (front points in bold names, sorted by cost), then the
    pipeline points."""
    meta = result["meta"]
    lines = ["## Reciprocal", ""] + _recip_table(result)
    units = [u for u in dict.fromkeys(r.get("unit", "recip") for r in result["points"]) if u != "recip"]
    for unit in units:
        lines += ["", f"## {unit}", ""] + _unit_table(result, unit)
    if units:
        lines += ["", f"Unit points: {meta.get('unit_samples', meta['samples']):,} random inputs plus the hard "
                  "cases (`vectors`: those in the measured domain). Bold: Pareto front of worst-case correct bits "
                  f"(−log2 of the worst error) against cost = table bits + {meta['dsp_weight']:g} × estimated "
                  "MULT18X18D blocks."]
    pipe = result.get("pipeline") or {}
    if pipe.get("points"):
        p0 = pipe["points"][0]
        lines += ["", f"## Pipeline ({p0['scene']}, {p0['width']}×{p0['height']}, bit-exact model)", ""]
        lines += _pipeline_table(result)
        lines += ["", "Bold: Pareto front of PSNR against reference (a) over cost = table bits + "
                  f"{meta['dsp_weight']:g} × estimated MULT18X18D blocks (`fxmodel.core.cost`, the sampler blends "
                  "included). Memory bits: maps, texture and "
                  "reflectance cubes."]
    return "\n".join(lines)


def write_outputs(result: dict, out: Path = OUT, docs: bool = False) -> list[Path]:
    """Write the JSON, Markdown and PNGs (``pareto.png``; ``units.png`` when there are unit or pipeline points)
    under ``out``, and with ``docs`` the PNGs also to ``docs/img/``."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "speed_vs_error.json", out / "speed_vs_error.md"]
    atomic_json(paths[0], result, indent=2)
    atomic_write_text(paths[1], "# Design-space sweep, `bumpmap sweep`\n\n" + markdown(result) + "\n")
    pictures = []
    if _points(result, "recip"):
        pictures.append(("pareto.png", plot))
    if any(r.get("unit", "recip") != "recip" for r in result["points"]) or (result.get("pipeline") or {}).get("points"):
        pictures.append(("units.png", plot_units))
    for name, fn in pictures:
        fn(result, out / name)
        paths.append(out / name)
        if docs:
            fn(result, DOCS_IMG / name)
            paths.append(DOCS_IMG / name)
    return paths


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap sweep``, :mod:`tools.main`)."""
    ap.add_argument("--no-fpga", action="store_true", help="skip the ECP5 flow")
    ap.add_argument("--fpga-points", type=int, default=6,
                    help="reciprocal points placed and routed (cached; at most 6, default %(default)s)")
    ap.add_argument("--unit-fpga-points", type=int, default=2,
                    help="points placed and routed per other unit: its default preset, the cheapest and the middle "
                         "point of its front (cached; 0 to 3, default %(default)s)")
    from . import jobs as jobrunner
    jobrunner.add_arguments(ap, jobs=2, what="sweep points, then FPGA designs,")
    ap.add_argument("--exhaustive-limit", type=int, default=1 << 24,
                    help="measure every input when the input space is at most this (default 2**24)")
    ap.add_argument("--samples", type=int, default=10 ** 6, help="random inputs otherwise (plus the hard cases)")
    ap.add_argument("--unit-samples", type=int,
                    help="random inputs of the other units (default: --samples; fewer for a quick look)")
    ap.add_argument("--no-units", action="store_true", help="only the reciprocal and the pipeline points")
    ap.add_argument("--only", action="append", metavar="UNIT", help="only this unit's points (repeatable: recip, "
                    "persp, cube, reflect, bump, raster); with --no-pipeline e.g. the scan converter's guard bits "
                    "alone")
    ap.add_argument("--no-pipeline", action="store_true", help="no pipeline points (no scene renders)")
    ap.add_argument("--scene", help="scene of the pipeline points (default: scenes/tin-plane.toml)")
    ap.add_argument("--scene-size", type=int, help="render the pipeline points at this square size "
                    "(default: the scene's own)")
    ap.add_argument("--dsp-weight", type=float, default=1024.0, help="ROM bits per multiplier block in the cost")
    ap.add_argument("--out", default=str(OUT), help="output folder (default: build/bench)")
    ap.add_argument("--docs", action="store_true", help="also write docs/img/pareto.png and docs/img/units.png")

    add_record_option(ap, "the sweep")


def run(args: argparse.Namespace) -> int:
    before = machine()
    if not 0 <= args.fpga_points <= 6 or not 0 <= args.unit_fpga_points <= 3:
        print("error: --fpga-points must be 0 to 6 and --unit-fpga-points 0 to 3 (each new design takes 1-2 "
              "minutes)", file=sys.stderr)
        return 2
    if (args.samples < 1 or args.exhaustive_limit < 1 or args.dsp_weight < 0
            or (args.unit_samples is not None and args.unit_samples < 1)):
        print("error: --samples, --unit-samples and --exhaustive-limit must be positive, --dsp-weight >= 0",
              file=sys.stderr)
        return 2
    from . import sweep_units as su
    grid = default_grid() + ([] if args.no_units else su.default_unit_grid())
    if args.only:
        grid = [g for g in grid if g[2].NAME in args.only]
    result = sweep(grid, pipeline=[] if args.no_pipeline else su.PIPELINE_POINTS, scene=args.scene,
                   scene_size=args.scene_size, exhaustive_limit=args.exhaustive_limit, samples=args.samples,
                   unit_samples=args.unit_samples, dsp_weight=args.dsp_weight,
                   fpga_points=0 if args.no_fpga else args.fpga_points,
                   unit_fpga_points=0 if args.no_fpga else args.unit_fpga_points, jobs=args.jobs,
                   scheduler=args.scheduler)
    paths = write_outputs(result, Path(args.out), docs=args.docs)
    print(markdown(result))
    for unit, names in result["pareto"].items():
        print(f"\nPareto front, {unit}: {', '.join(names)}")
    print(f"({result['meta']['seconds']} s; written to {', '.join(str(p) for p in paths)})")
    write_if_asked(args, result, before)
    bad = [r["name"] for r in result["points"] if not r["within_bound"]]
    if bad:
        print(f"error: measured error above the documented bound: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0
