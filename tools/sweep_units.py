r"""Design-space sweep of the other units' datapath widths, and pipeline points.

The unit and pipeline points of ``bumpmap sweep`` (:mod:`tools.sweep` measures, records, draws and writes
them with the reciprocal's points, one progress bar over all). Each family changes one width (and what follows from
it) from the unit's ``default`` preset; the unit's presets are points too.

=======  ==========================================================  =================================================
unit     families (:func:`default_unit_grid`)                        error against exact math
(:mod:`fxmodel.units.exact`)
=======  ==========================================================  =================================================
persp    ``p, t=4`` / ``p, t=3``: reciprocal precision ``p`` 12 to   ``|s - U/W|`` on the unit circle (the repeat),
         24, ``coord_bits = p`` (23 at ``p = 24``: the scaled        ``s`` and ``t``, for ``|U/W| <= 16``
         product must fit 62 bits); ``c``: ``coord_bits`` alone      (:func:`~fxmodel.units.exact.measure_persp`)
cube     ``p, t=3`` / ``p, t=2``: divider precision ``p`` 8 to 20,   ``|s - s_exact|``, ``|t - t_exact|`` on the
         input word ``s1.p``                                         exact face
         (:func:`~fxmodel.units.exact.measure_cube`)
reflect  ``word``: ``N``, ``E`` in ``s2.(w - 2)``, ``r_bits = w``,   angle between the exact ``R`` and the output
         ``w`` 8 to 20 (the exact ``R`` must fit 62 bits)            (:func:`~fxmodel.units.exact.measure_reflect`)
bump     ``out``: ``N'`` in ``s2.f``, ``f`` 6 to 16                  ``|N'_i - (N + du A0 + dv A1)_i|``, unsaturated
                                                                     (:func:`~fxmodel.units.exact.measure_bump`)
raster   ``guard``: the interpolators' guard bits ``g`` (``extra_      distance of each output code from the exact
         guard`` 0 to 3 beyond the proof's minimum) and the          rational plane, in output ulps, over triangles
         ``small`` preset                                            spanning the whole ``max_size`` viewport
                                                                     (:func:`fxmodel.units.raster_errors.measure`)
=======  ==========================================================  =================================================

The reciprocal of ``persp`` and ``cube`` is the smallest faithful table at that ``p``: the fewest index bits ``m``
whose documented bound is below one ulp with ``b = p + 3`` (:func:`smallest_faithful`); the cube unit needs it (its
no-overflow proof), the perspective unit's error is ``|s|`` times it. Widths that only quantize a unit's inputs (the
bump map's ``d_fmt``, the shading unit's cube channels) leave the unit's own error against exact math unchanged
(``shade`` is always within half an output step): they show only in the rendered frame, as pipeline points.

Inputs: ``--unit-samples`` (default ``--samples``, ``10**6``) random vectors plus the unit's hard cases; ``persp``
draws ``W`` uniformly over its non-zero codes and ``U``, ``V`` uniformly within ``|U/W| <= 16`` (the documented
bound's domain), ``bump`` twice as many (about half of uniform inputs saturate, and only unsaturated outputs have a
bound). Correct bits: ``-log2`` of the worst error (real units; radians for ``reflect``).

Cost, as for the reciprocal: table bits + ``dsp_weight`` x estimated MULT18X18D blocks (the unit's
:meth:`~fxmodel.core.unit.Unit.cost`, :mod:`fxmodel.core.cost`; the estimate equals the synthesized ECP5 count of
every unit preset, ``docs/fpga/resources.json``). Placed and routed (cached): each unit's default preset
and the cheapest point of its front (``--unit-fpga-points 3``: also the middle of the front).

Pipeline points (:data:`PIPELINE_POINTS`): the ``default`` preset, the fitted ``presets/tin-plane-fit.toml`` and
variants of ``default`` that narrow one unit's widths (:func:`tools.fit.units_of`: the knobs of ``python -m
fxmodel fit``). Each renders a shipped scene (``scenes/tin-plane.toml`` at its own 256 x 256) through the bit-exact
model only, as ``fit`` evaluates a candidate (:func:`host.render.prepare` with a preset name or a units dict,
then :func:`host.render.render`), and records PSNR and the largest per-channel difference against the float
reference (a) and the ideal Phong reference (b), and the hardware estimate (:func:`tools.fit.hardware`: the
pipeline's :mod:`fxmodel.core.cost` estimate, sampler blends included: table bits, multipliers, MULT18X18D and DP16KD
blocks, memory bits); cost = table bits + ``dsp_weight`` x MULT18X18D blocks.
"""

from __future__ import annotations

import math
import time
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units import exact
from fxmodel.units.cube import CubeParams, cube_divider
from fxmodel.units.recip import RecipParams

__all__ = ["unique_points", "S_ABS", "UNIT_ERRORS", "PIPELINE_POINTS", "SCENE", "smallest_faithful", "knobs",
           "default_unit_grid", "unit_inputs", "measure_unit_point", "pipeline_grid", "measure_pipeline_point",
           "RASTER_TRIANGLES", "raster_grid", "measure_raster_point"]

#: Largest ``|U/W|`` of the perspective unit's measured domain (its documented bound's ``s_abs``).
S_ABS = 16

#: Per unit: what the error is, the key of its worst / mean / bound in the ``fxmodel.units.exact`` measure, and the
#: output ulp (real units) the error is also given in.
UNIT_ERRORS = {
    "persp": {"what": f"|s - U/W| mod 1 (s and t), |U/W| <= {S_ABS}", "worst": "max_error", "mean": "mean_error",
              "bound": "bound", "ulp": lambda P: Fraction(1, 1 << P.coord_bits), "ulp_name": "2^-coord_bits"},
    "cube": {"what": "|s - s_exact|, |t - t_exact| (exact face)", "worst": "max_error", "mean": "mean_error",
             "bound": "bound", "ulp": lambda P: P.st_fmt.ulp, "ulp_name": "ulp of s, t"},
    "reflect": {"what": "angle between exact R and the output (rad)", "worst": "max_direction_error_rad",
                "mean": "mean_direction_error_rad", "bound": "bound_rad", "ulp": lambda P: P.r_fmt.ulp,
                "ulp_name": "ulp of R (rad per ulp)"},
    "bump": {"what": "|N'_i - (N + du A0 + dv A1)_i|, unsaturated", "worst": "max_error", "mean": "mean_error",
             "bound": "bound", "ulp": lambda P: P.out_fmt.ulp, "ulp_name": "ulp of N'"},
    "raster": {"what": "|output code - exact plane| over full-viewport triangles, output ulps (the 'mean' column: "
                       "the accumulators' worst, before the output rounding)",
               "ulp_name": "output ulps (each attribute's own)"},
}

#: Triangles spanning the whole viewport that measure each scan-converter point
#: (:func:`fxmodel.units.raster_errors.measure`).
RASTER_TRIANGLES = 2

#: The scene of the pipeline points.
SCENE = "scenes/tin-plane.toml"

#: ``(name, preset name or knob changes from default)``: knobs as in :data:`tools.fit.KNOB_STEPS`.
PIPELINE_POINTS = [
    ("default", "default"),
    ("tin-plane-fit", "tin-plane-fit"),
    ("persp p16 c14", {"coord_bits": 14, "persp_p": 16, "persp_b": 17}),
    ("word 12", {"word": 12}),                          # N' (bump out), reflect N and R, cube input
    ("cube p10", {"cube_p": 10, "cube_b": 12, "cube_m": 5}),
    ("bump map d s1.7", {"d_frac": 7}),
    ("shade D u2.6 S u8.1", {"diffuse_frac": 6, "specular_frac": 1}),
]


def unique_points(grid) -> list[tuple[str, str, object]]:
    """``grid`` of ``(name, family, params)`` without repeated parameter objects (the first name kept)."""
    seen, out = set(), []
    for name, family, P in grid:
        if P not in seen:
            seen.add(P)
            out.append((name, family, P))
    return out


def smallest_faithful(in_fmt: Fmt, p: int, t: int, guard: int = 4, table: str = "round") -> RecipParams | None:
    """The reciprocal with the fewest index bits ``m`` (2 to 12) whose documented bound is below one ulp at
    precision ``p`` (``b = p + 3``), or ``None``."""
    for m in range(2, 13):
        try:
            P = RecipParams(in_fmt=in_fmt, m=m, b=p + 3, t=t, p=p, guard=guard, table=table)
        except ValueError:
            continue
        if P.error_bound_ulp < 1:
            return P
    return None


def knobs(params) -> str:
    """The swept widths of a unit point, as a short string for the tables."""
    name = params.NAME
    if name == "persp":
        r = params.recip
        return f"U,V {params.uv_fmt}, W {r.in_fmt}, p={r.p} m={r.m} b={r.b} t={r.t}, coord {params.coord_bits}"
    if name == "cube":
        r = params.divide.recip
        return f"in {params.in_fmt}, p={r.p} m={r.m} b={r.b} t={r.t}, s/t {params.st_fmt}"
    if name == "reflect":
        return f"N {params.n_fmt}, E {params.e_fmt}, R {params.r_fmt}"
    if name == "bump":
        return f"N {params.n_fmt}, d {params.d_fmt}, A {params.a_fmt}, N' {params.out_fmt}"
    return repr(params)


def default_unit_grid() -> list[tuple[str, str, object]]:
    """``(name, family, params)`` of the unit families (module docstring) and presets, duplicates removed."""
    grid = [(f"{u} preset {n}", "preset", preset(u, n)) for u in UNIT_ERRORS for n in ("default", "small")]
    base = preset("persp")
    w_fmt = base.recip.in_fmt
    for t, ps in ((4, (12, 14, 16, 18, 20, 22, 24)), (3, (14, 18, 22))):
        for p in ps:
            r = smallest_faithful(w_fmt, p, t)
            for c in range(p, p - 4, -1):          # coord_bits = p where the scaled product fits 62 bits
                try:
                    grid.append((f"persp t{t} p{p} m{r.m} c{c}", f"p, t={t}", base.replace(recip=r, coord_bits=c)))
                    break
                except (ValueError, AttributeError):
                    continue
    r22 = smallest_faithful(w_fmt, 22, 4)
    for c in (14, 17):
        grid.append((f"persp t4 p22 m{r22.m} c{c}", "c", base.replace(recip=r22, coord_bits=c)))
    for t, ps in ((3, (8, 10, 12, 14, 17, 20)), (2, (10, 14))):
        for p in ps:
            in_fmt = Fmt(True, 1, p)
            r = smallest_faithful(in_fmt, p, t, guard=5)
            if r is not None:
                d = cube_divider(in_fmt, m=r.m, b=r.b, t=t, p=p, guard=r.guard)
                grid.append((f"cube t{t} p{p} m{r.m}", f"p, t={t}", CubeParams(divide=d)))
    refl = preset("reflect")
    for w in (8, 10, 12, 14, 16, 18, 20):
        f = Fmt(True, 2, w - 2)
        grid.append((f"reflect word {w}", "word", refl.replace(n_fmt=f, e_fmt=f, r_bits=w)))
    bump = preset("bump")
    for f in (6, 8, 10, 12, 14, 16):
        grid.append((f"bump out s2.{f}", "out", bump.replace(out_fmt=Fmt(True, 2, f))))
    return unique_points(grid + raster_grid())


def raster_grid() -> list[tuple[str, str, object]]:
    """The scan converter's points: its presets, and the default with 0 to 3 guard bits beyond the proof's
    minimum (``extra_guard``)."""
    import dataclasses

    from fxmodel.units.raster import RasterParams
    base = RasterParams.PRESETS["default"]
    grid = [(f"raster preset {n}", "preset", P) for n, P in RasterParams.PRESETS.items()]
    grid += [(f"raster g{dataclasses.replace(base, extra_guard=g).guard_bits}", "guard",
              dataclasses.replace(base, extra_guard=g)) for g in range(4)]
    return grid


def measure_raster_point(name: str, family: str, params, *, dsp_weight: float = 1024.0,
                         triangles: int = RASTER_TRIANGLES, seed: int = 1, **_) -> dict:
    """The scan converter's worst interpolation error against the exact planes
    (:func:`fxmodel.units.raster_errors.measure`: triangles spanning the whole ``max_size`` viewport, output ulps of
    each attribute) beside its bound and cost (:func:`fxmodel.core.cost.estimate`; its registers: the record's and the
    accumulators' bits), one JSON record in the form of :func:`measure_unit_point`'s."""
    from fxmodel.units.raster_errors import measure
    t0 = time.perf_counter()
    m = measure(params, triangles, seed)
    rate = m["fragments"] / (time.perf_counter() - t0)
    est = params.cost()
    worst, bound = m["output_worst_ulp"], m["output_bound_ulp"]
    regs = sum(p.fmt.width for p in params.record) + sum(params.acc_fmt(n).width for n in params.names)
    return {
        "name": name, "family": family, "unit": "raster",
        "knobs": f"g={params.guard_bits} (extra {params.extra_guard}), max_size {params.max_size}, "
                 f"{regs} record + accumulator bits",
        "params": params.info()["params"], "table_bits": 0, "multipliers": est["multipliers"],
        "dsp_blocks_est": est["dsp"], "latency": params.latency, "error": UNIT_ERRORS["raster"]["what"],
        "bound": bound, "worst": worst, "mean": m["accumulator_worst_ulp"], "ulp": 1.0, "bound_ulp": bound,
        "worst_ulp": worst, "mean_ulp": m["accumulator_worst_ulp"], "worst_input_codes": None,
        "within_bound": worst <= bound, "correct_bits_worst": round(-math.log2(worst), 3) if worst > 0 else None,
        "correct_bits_mean": None, "vectors": m["fragments"], "drawn": m["fragments"], "exhaustive": False,
        "model_per_second": rate, "cost": dsp_weight * est["dsp"], "fpga": None,
        "measure": {"accumulator_worst_ulp": m["accumulator_worst_ulp"],
                    "accumulator_bound_ulp": m["accumulator_bound_ulp"], "guard_bits": m["guard_bits"],
                    "register_bits": regs, "triangles": triangles},
    }


def unit_inputs(params, samples: int, rng, exhaustive_limit: int = 1 << 24) -> tuple[np.ndarray, bool]:
    """``(input codes, exhaustive)``: every input if the space is at most ``exhaustive_limit``, else ``samples``
    random vectors (``persp``: within ``|U/W| <= S_ABS``; ``bump``: ``2 samples``) plus the hard cases."""
    if params.input_space() <= exhaustive_limit:
        return params.all_inputs(), True
    if params.NAME == "persp":
        wf, uf = params.recip.in_fmt, params.uv_fmt
        W = rng.integers(wf.min_code, wf.max_code, size=samples, endpoint=True, dtype=np.int64)
        W[W == 0] = 1
        # |U| <= S_ABS |W| 2**(uf - wf): the largest code within the domain, capped by the format
        lim = np.minimum((S_ABS * np.abs(W)) << uf.frac_bits >> wf.frac_bits, uf.max_code)
        cols = [np.clip(rng.integers(-lim, lim, endpoint=True), uf.min_code, uf.max_code)
                for _ in params.numerators]
        rnd = np.stack(cols + [W], axis=1)
    else:
        rnd = params.random_inputs(rng, samples * (2 if params.NAME == "bump" else 1))
    return np.concatenate([rnd, params.hard_cases()]), False


def measure_unit_point(name: str, family: str, params, *, samples: int = 10 ** 6, dsp_weight: float = 1024.0,
                       exhaustive_limit: int = 1 << 24, seed: int = 1) -> dict:
    """Error against exact math, cost and model throughput of one unit configuration (one JSON record)."""
    unit = params.NAME
    spec = UNIT_ERRORS[unit]
    rng = np.random.default_rng(seed)
    x, exhaustive = unit_inputs(params, samples, rng, exhaustive_limit)
    params.compute(x[:1000])                            # tables and cached formats outside the timing
    t0 = time.perf_counter()
    out = params.compute(x)
    rate = len(x) / (time.perf_counter() - t0)
    m = exact.MEASURES[unit](params, x, out)
    worst, mean, bound = m[spec["worst"]], m[spec["mean"]], m[spec["bound"]]
    ulp = float(spec["ulp"](params))
    est = params.cost()
    table_bits, mults, dsp = est["table_bits"], est["multipliers"], est["dsp"]

    def bits(e):
        return round(-math.log2(e), 3) if e > 0 else None

    extra = {k: v for k, v in m.items() if k not in (spec["worst"], spec["mean"], spec["bound"], "within_bound",
                                                      "vectors", "worst_input_codes")}
    return {
        "name": name, "family": family, "unit": unit, "knobs": knobs(params), "params": params.info()["params"],
        "table_bits": table_bits, "multipliers": mults, "dsp_blocks_est": dsp, "latency": params.latency,
        "error": spec["what"], "bound": bound, "worst": worst, "mean": mean,
        "ulp": ulp, "bound_ulp": bound / ulp, "worst_ulp": worst / ulp, "mean_ulp": mean / ulp,
        "worst_input_codes": m.get("worst_input_codes"), "within_bound": bool(m["within_bound"]),
        "correct_bits_worst": bits(worst), "correct_bits_mean": bits(mean),
        "vectors": int(m["vectors"]), "drawn": int(len(x)), "exhaustive": exhaustive, "model_per_second": rate,
        "cost": table_bits + dsp_weight * dsp, "fpga": None, "measure": extra,
    }


# -- pipeline points ------------------------------------------------------------------------------------------
def pipeline_grid(points=None) -> list[tuple[str, object, dict]]:
    """``(name, preset name or units dict, knob changes)`` of :data:`PIPELINE_POINTS` (or ``points``)."""
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS
    from tools.fit import knobs_of, units_of

    base = BUILTIN_PRESET_UNITS["default"]
    k0 = knobs_of(base)
    out = []
    for name, spec in (PIPELINE_POINTS if points is None else points):
        if isinstance(spec, str):
            out.append((name, spec, {}))
        else:
            out.append((name, units_of({**k0, **spec}, base), {kn: [k0[kn], v] for kn, v in spec.items()}))
    return out


def measure_pipeline_point(name: str, units, changes: dict, *, scene=SCENE, size: int | None = None,
                           cube_size: int | None = None, dsp_weight: float = 1024.0) -> dict:
    """Render ``scene`` with the bit-exact model for one pipeline preset (name or units dict); PSNR and the
    largest per-channel difference against references (a) and (b), and the hardware estimate.
    ``cube_size``: reflectance-cube face edge (``None``: ``prepare``'s default, the preset's own).

    A preset that cannot draw the scene (what :func:`host.render.prepare` refuses without ``allow_clamp``:
    inputs outside its formats, or texture addresses it cannot resolve) is a point too: ``refused`` holds the
    refusal's findings (``Frame.stats["refused"]``, joined), and the frame is drawn with the inputs clamped, so
    its error and cost are on record; it is never on the front (:func:`tools.sweep.sweep`). ``refused`` is
    ``None`` for a preset that draws the scene."""
    from fxmodel.pipeline.presets import preset_units
    from host.render import prepare, render
    from host.scene import scene_at
    from tools.fit import hardware

    sc = scene_at(scene, (size, size) if size else None)
    t0 = time.perf_counter()
    frame = prepare(sc, preset=units, allow_clamp=True, **({} if cube_size is None else {"cube_size": cube_size}))
    rep = render(frame)
    rep.pop("_model_bytes", None)
    hw = hardware(preset_units(units), frame.params)
    return {
        "name": name, "preset": units if isinstance(units, str) else None, "changes": changes,
        "scene": sc.name, "width": sc.width, "height": sc.height, "pixels": rep["pixels"],
        "cube_size": frame.stats["cube_size"],
        **{k: rep[k] for k in ("psnr_db_vs_float", "max_lsb_vs_float", "psnr_db_vs_ideal", "max_lsb_vs_ideal")},
        "clamped_fragment_inputs": sum(rep["clamped_fragment_inputs"].values()),
        "flags": rep["flags"], "hardware": hw, "refused": "; ".join(frame.stats["refused"]) or None,
        "cost": hw["table_bits"] + dsp_weight * hw["dsp"],
        "model_pixels_per_second": rep["model_pixels_per_second"], "seconds": round(time.perf_counter() - t0, 2),
    }
