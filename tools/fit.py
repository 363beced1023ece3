"""Scene-driven word lengths: ``bumpmap fit`` writes a pipeline preset fitted to a scene.

:func:`fit` measures the ranges a scene produces and searches, by greedy coordinate descent from ``default``,
the smallest formats and table sizes (:data:`KNOB_STEPS`) for which the bit-exact frame stays within
``max_lsb`` of the float reference (a) on every well-conditioned pixel, first widening a preset that cannot draw
the scene (:func:`widen`; candidates go to ``prepare`` as units dicts, nothing
is registered globally); it writes the result as a preset file that ``prepare(..., preset=NAME)``,
``bumpmap render --preset NAME``, ``make sim PRESET=NAME`` and, with a scene, ``make verilog`` and
``make fpga`` accept, and reports a hardware estimate (:func:`hardware`, the one cost model :mod:`fxmodel.core.cost`)
against ``default``.

The preset files themselves (reading, writing, the built-in ``default``) are :mod:`fxmodel.pipeline.presets`.
"""

from __future__ import annotations

import dataclasses

from fxmodel.core.fixed import Fmt
from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS, UNIT_KEYS, check_preset_name, top_value, write_preset
from fxmodel.units.cube import cube_divider
from fxmodel.units.raster import ATTRIBUTE_FORMATS

__all__ = ["KNOB_STEPS", "KNOB_MIN", "FitError", "knobs_of", "units_of", "measure_ranges", "hardware", "fit"]


class FitError(ValueError):
    """No preset within the search's limits brings the scene within ``max_lsb`` of reference (a) (``bumpmap fit``
    exits 1). The message gives the best bound reached and the knobs of the preset that reaches it.

    Attributes
    ----------
    bound : int or None
        The smallest largest-difference from reference (a) (well-conditioned pixels, at every size) reached
        (``None``: no preset drew the scene without refusals).
    knobs : dict
        The knobs of the preset that reaches it (:func:`knobs_of`).
    """

    def __init__(self, message: str, bound: int, knobs: dict):
        super().__init__(message)
        self.bound, self.knobs = bound, knobs


def changed_knobs(k: dict, start: dict) -> str:
    """``"word=14, uv_frac=12"``: the knobs of ``k`` that differ from ``start`` (``"none"`` if none)."""
    return ", ".join(f"{n}={v}" for n, v in k.items() if start.get(n) != v) or "none"

# -- scene-driven word lengths: ``bumpmap fit`` ---------------------------------------------------
#: The knobs the search reduces, in search order (widest savings first), with the starting step in bits.
KNOB_STEPS = {
    "cube_size": 16, "word": 2, "cube_p": 2, "cube_b": 2, "cube_guard": 1, "cube_m": 1, "cube_t": 1,
    "coord_bits": 2, "persp_p": 2, "persp_b": 2, "persp_guard": 1, "persp_m": 1, "persp_t": 1,
    "uv_frac": 2, "w_frac": 2, "n_frac": 2, "a_frac": 2, "e_frac": 2, "d_frac": 1,
    "weight_bits": 1, "diffuse_frac": 1, "specular_frac": 1,
    "uv_int": 1, "a_int": 1, "e_int": 1, "raster_guard": 1,
}
#: Smallest value tried for each knob (the parameter objects reject what does not work anyway).
KNOB_MIN = {"cube_size": 2, "cube_t": 1, "persp_t": 1, "cube_m": 2, "persp_m": 2, "weight_bits": 1, "word": 4,
            "uv_int": 1, "a_int": 1, "e_int": 1, "raster_guard": 0}


def knobs_of(units: dict) -> dict:
    """The flat integer knobs of a pipeline preset's units (see :data:`KNOB_STEPS`)."""
    persp, bump, reflect, cube, shade = (units[k] for k in UNIT_KEYS)
    pr, cr = persp.recip, cube.divide.recip
    return {"cube_size": top_value(units, "cube_size"), "word": bump.out_fmt.width, "cube_p": cr.p, "cube_b": cr.b,
            "cube_guard": cr.guard, "cube_m": cr.m, "cube_t": cr.t, "coord_bits": persp.coord_bits, "persp_p": pr.p,
            "persp_b": pr.b,
            "persp_guard": pr.guard, "persp_m": pr.m, "persp_t": pr.t, "uv_frac": persp.uv_fmt.frac_bits,
            "w_frac": pr.in_fmt.frac_bits, "n_frac": bump.n_fmt.frac_bits, "a_frac": bump.a_fmt.frac_bits,
            "e_frac": reflect.e_fmt.frac_bits, "d_frac": bump.d_fmt.frac_bits,
            "weight_bits": top_value(units, "weight_bits"), "diffuse_frac": shade.diffuse_fmt.frac_bits,
            "specular_frac": shade.specular_fmt.frac_bits, "uv_int": persp.uv_fmt.int_bits,
            "a_int": bump.a_fmt.int_bits, "e_int": reflect.e_fmt.int_bits,
            "raster_guard": top_value(units, "raster_guard")}


def units_of(k: dict, base: dict) -> dict:
    """Units from knobs ``k`` on top of ``base`` (the default preset's units).

    Raises
    ------
    ValueError, TypeError
        If the knobs make an invalid unit (the search treats that as "not allowed").
    """
    persp, bump, reflect, cube, shade = (base[key] for key in UNIT_KEYS)
    pr = persp.recip
    word = k["word"]
    n_prime = Fmt(True, bump.out_fmt.int_bits, word - bump.out_fmt.int_bits)
    recip = dataclasses.replace(pr, in_fmt=Fmt(True, pr.in_fmt.int_bits, k["w_frac"]), m=k["persp_m"],
                                b=k["persp_b"], t=k["persp_t"], p=k["persp_p"], guard=k["persp_guard"])
    return {
        "persp": dataclasses.replace(persp, recip=recip, uv_fmt=Fmt(True, k["uv_int"], k["uv_frac"]),
                                     coord_bits=k["coord_bits"]),
        "bump": dataclasses.replace(bump, n_fmt=Fmt(True, bump.n_fmt.int_bits, k["n_frac"]),
                                    d_fmt=Fmt(True, bump.d_fmt.int_bits, k["d_frac"]),
                                    a_fmt=Fmt(True, k["a_int"], k["a_frac"]), out_fmt=n_prime),
        "reflect": dataclasses.replace(reflect, n_fmt=n_prime, e_fmt=Fmt(True, k["e_int"], k["e_frac"]),
                                       r_bits=word),
        "cube": dataclasses.replace(cube, divide=cube_divider(Fmt(True, 1, word - 1), m=k["cube_m"], b=k["cube_b"],
                                                         t=k["cube_t"], p=k["cube_p"], guard=k["cube_guard"])),
        "shade": dataclasses.replace(shade, diffuse_fmt=Fmt(False, shade.diffuse_fmt.int_bits, k["diffuse_frac"]),
                                     specular_fmt=Fmt(False, shade.specular_fmt.int_bits, k["specular_frac"])),
        "weight_bits": k["weight_bits"],
        "cube_size": k["cube_size"],
        "raster_guard": k["raster_guard"],
        "diffuse_extra_frac": base.get("diffuse_extra_frac", 0),        # not a knob: the base preset's
    }


def _int_bits(max_abs: float) -> int:
    """Signed integer bits (sign included) that hold ``[-max_abs, max_abs]`` with half an ulp of headroom."""
    import math
    return max(1, math.floor(math.log2(max_abs)) + 2) if max_abs > 0 else 1


def measure_ranges(frame) -> dict:
    """The ranges a prepared scene produces: fragment inputs (float, before quantization) and the bump
    engine's ``N'`` (from the bit-exact model)."""
    import numpy as np
    f = frame.frags
    uv = np.abs(np.concatenate([f.U, f.V, f.Uc, f.Vc])) if len(f) else np.zeros(1)
    N, E, A = (np.abs(np.asarray(x)) if len(f) else np.zeros(1) for x in (f.N, f.E, f.A))
    W = np.asarray(f.W) if len(f) else np.ones(1)
    out = {"max_abs_uv": float(uv.max()), "min_W": float(W.min()), "max_W": float(W.max()),
           "max_abs_N": float(N.max()), "max_abs_E": float(E.max()), "max_abs_A": float(A.max())}
    if len(frame.codes):
        npr = frame.params.trace(frame.codes)["N'"][:, :3]
        out["max_abs_N_prime"] = float(frame.params.bump.out_fmt.to_real(np.abs(npr).max()))
    return out


def hardware(units: dict, params) -> dict:
    """The hardware estimate of a pipeline preset: ``params.cost()`` (:func:`fxmodel.core.cost.estimate` of the
    assembled :class:`~fxmodel.pipeline.pixel.PipelineParams`: MULT18X18D blocks ``dsp`` with the sampler blends, DP16KD
    blocks ``bram``, multipliers, table and memory bits), the sum of the units' port widths, and the scan
    converter in front of it (:func:`host.render.raster_params`): its blocks and its record's and
    accumulators' bits (the interpolators' registers)."""
    from host.render import raster_params
    raster = raster_params(units)
    return {**params.cost(),
            "datapath_port_bits": sum(p.fmt.width for u in (units[k] for k in UNIT_KEYS) for p in u.inputs + u.outputs),
            "raster_dsp": raster.cost()["dsp"], "raster_record_bits": sum(p.fmt.width for p in raster.record),
            "raster_accumulator_bits": sum(raster.acc_fmt(n).width for n in raster.names)}


def _render(frame, triangles: bool) -> dict:
    """The render report of ``frame`` as the hardware draws it: from triangles (the scan converter and
    interpolators of the frame's preset, ``raster_guard`` included: :func:`host.render.from_triangles`) or
    from the front end's fragments. A triangle the preset's set-up cannot draw raises ``ValueError``."""
    from host.render import from_triangles, render
    return render(frame, model=from_triangles(frame).in_frame_order() if triangles else None)


def _refused(frame) -> int:
    """Fragment inputs a frame clamps plus fragments whose texture addresses its preset does not resolve (what
    :func:`host.render.prepare` refuses without ``allow_clamp``)."""
    return sum(frame.stats["clamped_fragment_inputs"].values()) + sum(frame.stats["imprecise_fragments"].values())


#: What the widening phase of :func:`fit` may raise, and by how much per step.
WIDEN_STEPS = {"word": 2, "persp_p": 2, "persp_b": 2, "coord_bits": 2, "uv_frac": 2, "w_frac": 2, "n_frac": 2,
               "a_frac": 2, "e_frac": 2, "d_frac": 1, "weight_bits": 1, "diffuse_frac": 1, "specular_frac": 1,
               "cube_p": 2, "cube_b": 2, "persp_m": 1, "cube_m": 1, "cube_size": 32}
#: The fit knob of integer bits of each format field (:data:`fxmodel.units.raster.ATTRIBUTE_FORMATS` names which
#: field holds each fragment input).
FIELD_INT_KNOB = {"persp.uv_fmt": "uv_int", "reflect.e_fmt": "e_int", "bump.a_fmt": "a_int"}
INT_KNOB = {name: FIELD_INT_KNOB[path] for name, path in ATTRIBUTE_FORMATS.items() if path in FIELD_INT_KNOB}
WIDEN_LIMIT = 24


def widen(k: dict, base: dict, sizes: list, max_lsb: int, run) -> tuple[dict, list]:
    """The first phase of :func:`fit`: from knobs ``k``, the knobs of a preset that draws the scene (no clamped
    input, every texture address resolved) within ``max_lsb`` of reference (a) at every size in ``sizes``.

    Each step fixes the first problem found: a clamped input gets one more integer bit (:data:`INT_KNOB`);
    unresolved texture addresses get one more fraction bit of ``U, V`` and of ``W``; a frame over ``max_lsb``
    gets the one widening of :data:`WIDEN_STEPS` (wider words, more reciprocal table entries and precision, a
    larger cube face, ...) that brings the screening frame closest (fewest pixels over ``max_lsb``, then the
    smallest maximum). ``run(units, at)`` renders (see :func:`fit`).

    Returns
    -------
    (dict, list)
        The knobs, and the steps taken (``[knob, new value, why]``).

    Raises
    ------
    ValueError
        If the scene needs an input the pipeline cannot widen (``W``, ``N``).
    FitError
        If no widening helps, or none within :data:`WIDEN_LIMIT` steps: with the best bound reached (at every
        size) and the knobs that reach it.
    """
    steps, tried = [], []

    def problems(kk, at):
        frame, rep = run(units_of(kk, base), at)
        over = sum(rep["pixels_by_lsb_vs_float"][max_lsb + 1:])
        return frame, rep, over

    def give_up(why: str):
        try:
            bound, best = _best(tried, sizes, problems)
        except FitError as exc:
            raise FitError(f"fit: {why}; {str(exc).removeprefix('fit: ')}", None, {}) from None
        start = knobs_of(base)
        raise FitError(f"fit: {why}; no preset within the search's limits meets --max-lsb {max_lsb}: the best "
                       f"reached is {bound} LSB from reference (a), by the default preset with "
                       f"{changed_knobs(best, start)} (try --max-lsb {bound})", bound, best)

    for _ in range(WIDEN_LIMIT):
        for at in sizes:
            try:
                frame, rep, over = problems(k, at)
            except (ValueError, TypeError) as exc:      # the last widening made an invalid unit
                give_up(f"widened to {changed_knobs(k, knobs_of(base))}, the preset is invalid ({exc})")
            clamped = frame.stats["clamped_fragment_inputs"]
            if clamped or frame.stats["imprecise_fragments"] or over:
                break
        else:
            return k, steps
        if not clamped and not frame.stats["imprecise_fragments"]:
            tried.append(dict(k))
        if clamped:
            for name in clamped:
                if name not in INT_KNOB:
                    raise ValueError(f"fit: fragment input {name} does not fit, and no preset knob widens it")
            for knob in sorted({INT_KNOB[n] for n in clamped}):
                k = {**k, knob: k[knob] + 1}
                steps.append([knob, k[knob], f"clamped {', '.join(sorted(clamped))}"])
            continue
        if frame.stats["imprecise_fragments"]:
            k = {**k, "uv_frac": k["uv_frac"] + 1, "w_frac": k["w_frac"] + 1}
            steps.append(["uv_frac, w_frac", [k["uv_frac"], k["w_frac"]], "texture addresses not resolved"])
            continue
        best = None
        for knob, step in WIDEN_STEPS.items():
            cand = {**k, knob: k[knob] + step}
            try:
                f2, r2, o2 = problems(cand, sizes[0])
            except (ValueError, TypeError):
                continue
            score = (o2 + _refused(f2) * 10**6, r2["max_lsb_vs_float_well_conditioned"])
            if best is None or score < best[0]:
                best = (score, knob, cand)
        f0, r0, o0 = problems(k, sizes[0])
        now = (o0 + _refused(f0) * 10**6, r0["max_lsb_vs_float_well_conditioned"])
        if best is None or best[0] >= now and at == sizes[0]:
            give_up(f"the frame is {rep['max_lsb_vs_float_well_conditioned']} LSB from reference (a) at "
                    f"{'x'.join(map(str, at)) if at else 'full size'} and no single widening helps")
        k = best[2]
        steps.append([best[1], k[best[1]], f"{over} pixels over {max_lsb} LSB"])
    give_up(f"{WIDEN_LIMIT} widening steps did not reach it")


def _best(tried: list, sizes: list, problems) -> tuple[int, dict]:
    """``(bound, knobs)``: of the knob sets ``tried`` (each drawing the scene without refusals), the one whose
    largest difference from reference (a) on well-conditioned pixels, over every size, is smallest."""
    best = None
    for kk in tried:
        bound = max(problems(kk, at)[1]["max_lsb_vs_float_well_conditioned"] for at in sizes)
        if best is None or bound < best[0]:
            best = (bound, kk)
    if best is None:
        raise FitError("fit: no preset within the search's limits draws the scene without clamped inputs or "
                       "unresolved texture addresses", None, {})
    return best


def _savings(new: dict, old: dict) -> dict:
    return {k: {"default": old[k], "fit": new[k], "saved": old[k] - new[k],
                "saved_pct": round(100 * (old[k] - new[k]) / old[k], 1) if old[k] else 0.0}
            for k in new if isinstance(new[k], int) and k in old}


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One Dask task of the search: render a candidate preset at the screening sizes and judge it."""

    scene: object
    knobs: tuple                    # sorted (knob, value) pairs
    base: tuple                     # sorted (unit, params) pairs of the starting preset
    sizes: tuple                    # square sizes of the renders ((w, h) or None for the scene's own)
    ref: tuple                      # per size: (max LSB vs (a), refused fragments, max LSB vs (b)) of the start
    max_lsb: int
    triangles: bool = False         # judge the frame drawn from triangles (else from fragments)

    def describe(self) -> str:
        return f"fit candidate {dict(self.knobs)}"


def check_candidate(c: Candidate) -> dict:
    """``{"ok", "renders"}``: whether the candidate stays within ``max_lsb`` of reference (a) on every
    well-conditioned pixel, no more than ``max_lsb`` further from reference (b) than the start, and clamps no more
    fragment inputs and leaves no more texture addresses unresolved than the start (:func:`_refused`), at every
    size (stopping at the first size that fails), drawn from triangles when ``c.triangles`` (:func:`_render`;
    then the frame from the front end's fragments, which ``bumpmap render`` judges, within ``max_lsb`` of (a)
    too: the two frames quantize the attributes differently, and a preset fitted to one can miss by an LSB on
    the other). A
    candidate that makes an invalid unit or a triangle the set-up cannot draw (``ValueError``, ``TypeError``) is
    not ok."""
    from host.render import prepare

    renders = 0
    try:
        units = units_of(dict(c.knobs), dict(c.base))
        for at, (_lsb_a, clamped_ref, lsb_b) in zip(c.sizes, c.ref):
            renders += 1
            frame = prepare(c.scene, size=at, preset=units, allow_clamp=True)
            rep = _render(frame, c.triangles)
            if (rep["max_lsb_vs_float_well_conditioned"] > c.max_lsb or _refused(frame) > clamped_ref
                    or rep["max_lsb_vs_ideal"] > lsb_b + c.max_lsb):
                return {"ok": False, "renders": renders}
            if c.triangles:             # what `bumpmap render` judges too: the frame from the front end's fragments
                renders += 1
                if _render(frame, False)["max_lsb_vs_float_well_conditioned"] > c.max_lsb:
                    return {"ok": False, "renders": renders}
    except (ValueError, TypeError):
        return {"ok": False, "renders": renders}
    return {"ok": True, "renders": renders}


def _descent(value: int, step: int, low: int, verdict) -> tuple[int, int, int | None]:
    """Advance one knob's descent (in :func:`fit`: try ``value - step``; keep it if ok, else halve the step)
    through the verdicts known so far: ``(value, step, candidate)``, ``candidate`` the first value whose verdict
    ``verdict(v)`` (True, False or None) is unknown, or ``None`` when the descent is over."""
    while step >= 1:
        cand = value - step
        if cand < low:
            step //= 2
            continue
        ok = verdict(cand)
        if ok is None:
            return value, step, cand
        if ok:
            value = cand
        else:
            step //= 2
    return value, step, None


def _speculate(value: int, step: int, low: int, verdict, width: int) -> list[int]:
    """Up to ``width`` values whose verdicts the descent may need next: the one it needs now, then those it needs
    after either answer, breadth first (so that ``width`` workers judge them at once)."""
    out, queue = [], [(value, step)]
    while queue and len(out) < width:
        v, s = queue.pop(0)
        v, s, cand = _descent(v, s, low, verdict)
        if cand is None or cand in out:
            continue
        out.append(cand)
        queue += [(cand, s), (v, s // 2)]            # after "ok", after "not ok"
    return out


def _search(base, ranges, ok, judge, verdicts, width: int, passes: int, progress: bool, name: str, renders,
            initial: dict | None = None):
    """The greedy coordinate descent of :func:`fit` (its docstring); ``judge`` evaluates up to ``width``
    speculative candidates of a knob's descent at once (:func:`_speculate`), ``verdicts`` holds every answer, so
    the path taken, and the result, is the same for any ``width``. The descent starts from the knobs ``initial``
    (default: ``base``'s; :func:`fit` passes the widened ones)."""
    from tqdm import tqdm

    start = knobs_of(base)
    k = dict(initial if initial is not None else start)
    # integer bits from the measured ranges (only where that narrows; the render check decides)
    for knob, rng in (("uv_int", ranges["max_abs_uv"]), ("a_int", ranges["max_abs_A"]),
                      ("e_int", ranges["max_abs_E"])):
        want = _int_bits(rng)
        if want < k[knob] and ok({**k, knob: want}):
            k[knob] = want
    order = list(KNOB_STEPS)
    bar = tqdm(total=passes * len(order), desc=f"fit {name}", disable=not progress, unit="knob")
    for pass_ in range(passes):
        for knob in order:
            low = KNOB_MIN.get(knob, 0)

            def verdict(v, knob=knob):
                return verdicts.get(tuple(sorted({**k, knob: v}.items())))

            value, step = k[knob], KNOB_STEPS[knob] if pass_ == 0 else 1
            while True:
                value, step, cand = _descent(value, step, low, verdict)
                if cand is None:
                    break
                judge([{**k, knob: v} for v in _speculate(value, step, low, verdict, width)])
            k[knob] = value
            bar.set_postfix_str(f"{knob}={k[knob]} renders={renders()}")
            bar.update(1)
    bar.close()
    return k, start, order


def fit(scene, *, max_lsb: int = 1, size: int | None = 64, cube_size: int | None = None, name: str | None = None,
        directory=None, progress: bool = True, passes: int = 2, scene_size: int | None = None, jobs: int = 1,
        scheduler: str | None = None, speculate: int | None = None) -> dict:
    """Search the smallest formats and table sizes for which ``scene`` stays within ``max_lsb`` of reference (a).

    First :func:`widen`: from ``default``, the knobs of a preset that draws the scene (no clamped input, every
    texture address resolved) within ``max_lsb`` of reference (a) on every well-conditioned pixel. Then greedy
    coordinate descent from there over :data:`KNOB_STEPS`: each step lowers one knob (by its step, halved down to
    1 bit on failure) and keeps the change if the bit-exact frame stays within ``max_lsb`` of reference (a) on
    every well-conditioned pixel, no more than ``max_lsb`` further from the ideal reference (b) than the widened
    preset is, and clamps no more inputs and leaves no more addresses unresolved, first at the screening ``size``,
    then at the scene's own size (so the result holds at full size). The check against (b) is what holds the
    reflectance cubes' face size: reference (a) samples the same cubes in float, so their resolution error is
    invisible to it (without it the search shrank the tin plane's cubes to 2 texels, 1 LSB from (a) and 112
    from (b)). Knobs that make an
    invalid unit (``ValueError``) are not allowed. Integer bits start from the measured ranges.

    Parameters
    ----------
    scene : path or Scene
        The scene file.
    max_lsb : int
        Largest allowed per-channel difference from reference (a), in 8-bit steps.
    size : int or None
        Square image size of the screening renders (``None``: the scene's size only).
    cube_size : int, optional
        Texels per reflectance-cube face edge to start from (``None``: the default preset's, 64). A knob like the
        others: the search shrinks the cubes (memory, block RAM) while the frame stays within ``max_lsb``.
    name : str, optional
        Preset name to write (``presets/<name>.toml``; default ``<scene>-fit``).
    directory : path, optional
        Where to write the preset (default :func:`fxmodel.pipeline.presets.presets_dir`).
    progress : bool
        Show a progress bar (tqdm).
    passes : int
        Passes over the knobs (later passes use 1-bit steps).
    scene_size : int, optional
        Render the scene at this square size instead of its own as the "full size" (for quick runs and tests).
    jobs, scheduler
        Judge candidates as Dask tasks (:mod:`tools.jobs`): on a local cluster of ``jobs`` worker processes, or on
        the cluster at ``scheduler``. The search is sequential, so the workers judge the candidates a knob's
        descent may need next (:func:`_speculate`, ``speculate`` of them, default ``jobs``) at once; the answers
        decide the same path, so the preset is the same for any ``jobs``.

    Returns
    -------
    dict
        ``preset`` (name), ``path``, ``knobs`` (chosen and default), ``ranges``, ``final`` (max LSB and PSNR
        against reference (a) at full size), ``hardware`` (fit, default, savings), ``seconds``, ``renders``.

    Raises
    ------
    ValueError
        If no widening brings the scene within ``max_lsb`` (:func:`widen`).
    """
    import time

    t0 = time.perf_counter()
    job = _setup(scene, size, cube_size, scene_size)
    name = name or job.default_name
    check_preset_name(name)                         # before any work: the preset file stays in its folder
    k0, widened = _widen_both(job, max_lsb)
    ranges, default_hw = _reference(job)
    k, start, order = _descend(job, k0, ranges, max_lsb, passes, progress, jobs, scheduler, speculate)
    units = units_of(k, job.base)
    frame, rep = job.run(units, None)
    if rep["max_lsb_vs_float_well_conditioned"] > max_lsb:   # every step was checked at full size: a bug if so
        bound = rep["max_lsb_vs_float_well_conditioned"]
        raise FitError(f"fit: the final preset is {bound} LSB from reference (a) at full size, over --max-lsb "
                       f"{max_lsb} (default with {changed_knobs(k, start)})", bound, k)
    return _write(job, name, units, k, start, order, frame, rep, max_lsb, size, directory, widened, ranges,
                  default_hw, time.perf_counter() - t0)


@dataclasses.dataclass
class _Job:
    """What the steps of :func:`fit` share: the scene, the starting units, the screening sizes, the render
    counter and how frames are judged (from triangles or from fragments)."""

    scene: object
    base: dict
    sizes: list
    default_name: str
    renders: int = 0
    triangles: bool = False         # the widening judges the fragments' frame first; the descent, what is drawn

    def run(self, units, at):
        """Frame and render report of candidate ``units`` (a units dict) at size ``at`` (None: full size)."""
        from host.render import prepare
        self.renders += 1
        frame = prepare(self.scene, size=at, preset=units, allow_clamp=True)   # the cube size is the units' (a knob)
        return frame, _render(frame, self.triangles)


def _setup(scene, size, cube_size, scene_size) -> _Job:
    """Load the scene, refuse one that draws nothing, and fix the starting units and the screening sizes."""
    import re

    from host.render import prepare
    from host.scene import scene_at

    scene = scene_at(scene, (scene_size, scene_size) if scene_size else None)  # the file's may be larger
    base = BUILTIN_PRESET_UNITS["default"]
    if cube_size is not None:
        base = {**base, "cube_size": cube_size}
    if not len(prepare(scene, preset=base, allow_clamp=True).codes):
        raise ValueError(f"{scene.path or scene.name}: nothing is drawn: no triangle covers a pixel of the "
                         f"{scene.width}x{scene.height} frame (camera behind or inside the geometry, or everything "
                         f"clipped or culled), so there is no error to fit a preset to")
    sizes = [s for s in ((size, size), None) if s is None or s != (scene.width, scene.height)]
    if size is None:
        sizes = [None]
    stem = scene.path.stem if scene.path is not None else scene.name
    stem = re.sub(r"^[^A-Za-z0-9]+", "", re.sub(r"[^A-Za-z0-9_.+-]", "_", stem))[:90] or "scene"
    return _Job(scene, base, sizes, f"{stem}-fit")


def _widen_both(job: _Job, max_lsb: int) -> tuple[dict, list]:
    """:func:`widen` judged from the front end's fragments, then, where the scan converter draws the scene, from
    triangles as the engine draws it (and as the descent and the final check judge), widening on if needed."""
    k0, widened = widen(knobs_of(job.base), job.base, job.sizes, max_lsb, job.run)
    wide = units_of(k0, job.base)
    try:                                # the engine draws from triangles: judge that frame (raster_guard a knob)
        job.triangles = True
        for at in job.sizes:
            job.run(wide, at)
    except ValueError:                  # a scene the scan converter cannot draw (overlapping geometry, a
        job.triangles = False           # vertex value beyond a format): judged from fragments, raster_guard kept
        return k0, widened
    k1, more = widen(k0, job.base, job.sizes, max_lsb, job.run)
    return k1, widened + more


def _reference(job: _Job) -> tuple[dict, dict]:
    """The ranges the scene produces (:func:`measure_ranges`) and the default preset's hardware estimate."""
    from host.render import prepare
    full_frame = prepare(job.scene, preset=job.base, allow_clamp=True)
    return measure_ranges(full_frame), hardware(job.base, full_frame.params)


def _descend(job, k0, ranges, max_lsb, passes, progress, jobs, scheduler, speculate):
    """The greedy coordinate descent from the widened knobs ``k0`` (:func:`_search`), candidates judged as Dask
    tasks (:mod:`tools.jobs`; in this process without a cluster)."""
    from contextlib import nullcontext

    from . import jobs as jobrunner

    wide = units_of(k0, job.base)
    refs = {}
    for at in job.sizes:
        frame, rep = job.run(wide, at)
        refs[at] = (rep["max_lsb_vs_float_well_conditioned"], _refused(frame), rep["max_lsb_vs_ideal"])
    verdicts: dict[tuple, bool] = {}
    remote = jobs > 1 or bool(jobrunner.scheduler_address(scheduler))
    width = max(1, speculate if speculate is not None else (jobs if remote else 1))

    def judge(cands: list[dict]) -> None:
        todo = [c for c in {tuple(sorted(c.items())): c for c in cands} if c not in verdicts]
        pieces = [Candidate(job.scene, c, tuple(sorted(job.base.items())), tuple(job.sizes),
                            tuple(refs[at] for at in job.sizes), max_lsb, job.triangles) for c in todo]
        for c, out in zip(todo, jobrunner.run_pieces(check_candidate, pieces, client=client, progress=False,
                                                     describe=Candidate.describe)):
            verdicts[c] = out["ok"]
            job.renders += out["renders"]

    def ok(k) -> bool:
        judge([k])
        return verdicts[tuple(sorted(k.items()))]

    with (jobrunner.cluster(jobs, scheduler) if remote else nullcontext()) as client:
        k, start, order = _search(job.base, ranges, ok, judge, verdicts, width, passes, progress, job.scene.name,
                                  lambda: job.renders, initial=k0)
    return dict(k), start, order


def _write(job, name, units, k, start, order, frame, rep, max_lsb, size, directory, widened, ranges, default_hw,
           seconds) -> dict:
    """Write the preset file and return :func:`fit`'s report."""
    scene = job.scene
    fit_hw = hardware(units, frame.params)
    final = {"max_lsb_vs_float": rep["max_lsb_vs_float"], "psnr_db_vs_float": rep["psnr_db_vs_float"],
             "max_lsb_vs_float_well_conditioned": rep["max_lsb_vs_float_well_conditioned"],
             "ill_conditioned_pixels": rep["ill_conditioned_pixels"],
             "max_lsb_vs_ideal": rep["max_lsb_vs_ideal"], "psnr_db_vs_ideal": rep["psnr_db_vs_ideal"],
             "exact_vs_float": rep["exact_vs_float"], "exact_vs_ideal": rep["exact_vs_ideal"],
             "pixels": rep["pixels"], "width": scene.width, "height": scene.height}
    meta = {"scene": scene.name, "max_lsb": max_lsb, "screen_size": size or 0,
            "start_cube_size": job.base["cube_size"], "judged_from": "triangles" if job.triangles else "fragments",
            "final": {k_: v for k_, v in final.items() if v is not None}, "ranges": ranges, "knobs": k}
    path = write_preset(name, units, directory, meta=meta,
                        comment=f"Written by `bumpmap fit` for scene {scene.name} (--max-lsb {max_lsb}).\n"
                                f"Use: make sim PRESET={name} SCENE={scene.path or scene.name}")
    return {"preset": name, "path": str(path), "scene": scene.name, "max_lsb": max_lsb,
            "knobs": {kn: {"default": start[kn], "fit": k[kn]} for kn in order}, "widened": widened,
            "ranges": ranges, "final": final,
            "hardware": {"fit": fit_hw, "default": default_hw, "savings": _savings(fit_hw, default_hw)},
            "judged_from": meta["judged_from"], "renders": job.renders, "seconds": round(seconds, 1)}
