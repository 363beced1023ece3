"""Where the pixel pipeline's fixed-point error goes against the true image, unit by unit, and what widening the
diffuse factor buys (paper sections 2 and 4: the shading ``texture D + S`` from the two reflectance cubes).

``bumpmap precision [--scenes tin-plane ...] [--samples 8] [--diffuse-frac 11 12] [--extra-frac 0 2 3] [--json]
[--record PATH]``

Per shipped scene, with its preset (:func:`host.shipped.scene_preset`; presets without MIP mapping):

* **Before rounding.** The model's exact ``t D + S`` (what the shading unit narrows once to a byte, from the codes
  it receives) minus float reference (a)'s ``t D + S`` before its rounding, in output LSB per channel: the mean
  (a bias, as a truncation somewhere would leave) and the RMS, and the RMS of each unit's part of it, an exact
  split: the texture ``(t_model - t_a) D_a``, the diffuse factor ``t_model (D_model - D_a)``, the specular
  ``S_model - S_a``.
* **Frames.** Against reference (c), the true image (:func:`host.truth.true_image`, ``--samples`` per pixel along
  each axis; PSNR and mean FLIP over the fully covered pixels), and against (a) (largest difference and PSNR): float
  (a); the model; the model with one unit's output swapped for (a)'s float value (``D`` or ``S``: what that
  unit's quantization costs); the model with the diffuse factor widened to each ``--diffuse-frac`` fraction bits
  (``shade.diffuse_fmt``: the diffuse cube's texels, its sampler's blend and the shading unit's input, the blend
  no finer than the texels), and with the preset's texels but the diffuse sampler's blend rounded to each
  ``--extra-frac`` more fraction bits (the preset's ``diffuse_extra_frac``, ``SamplerParams.extra_frac``: no more
  block RAM), with the hardware estimate of each frame's pipeline (MULT18X18D and DP16KD blocks,
  :mod:`fxmodel.core.cost`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import shipped_scenes
from fxmodel.pipeline.lighting import face_directions
from fxmodel.pipeline.presets import preset_units, top_problem
from host.metrics import compare
from host.reference import cube_address_float, perturbed, sample_float
from host.render import prepare
from host.scene import scene_path
from host.shipped import scene_preset
from host.truth import DEFAULT_SAMPLES, true_image
from tools.record import add_record_option, machine, write_if_asked

__all__ = ["float_terms", "model_terms", "split", "scene_figures", "table", "add_arguments", "run"]


def float_terms(frame) -> dict:
    """Reference (a)'s terms ``t, D, S`` ``(K, 3)`` in float (:func:`host.reference.float_pipeline` before its
    rounding; the color texture bilinear at level 0)."""
    p, fi = frame.params, frame.float_inputs()
    if p.lod is not None:
        raise ValueError(f"{frame.scene.name}: precision measures presets without MIP mapping")
    n = perturbed(fi, frame.bump_float(), p.bump_map.filter)
    E = fi["E"]
    R = 2 * n * np.sum(n * E, 1, keepdims=True) - E * np.sum(n * n, 1, keepdims=True)
    dirs = face_directions(p.diffuse.width, p.diffuse.border)
    D = sample_float(frame.lighting.diffuse_factor(dirs), *cube_address_float(n), "bilinear", p.diffuse.edge)
    S = sample_float(frame.lighting.specular_bytes(dirs), *cube_address_float(R), "bilinear", p.specular.edge)
    t = sample_float(np.asarray(frame.maps.color, np.float64)[None], np.zeros(len(n), np.int64), fi["sc"], fi["tc"],
                     p.texture.filter, "repeat")
    return {"t": t, "D": D, "S": S}


def model_terms(frame) -> dict:
    """The model's terms ``t, D, S`` ``(K, 3)`` as real values (the shading unit's input codes) and its bytes."""
    p = frame.params
    tr = p.trace(frame.codes)
    sh = p.shade
    return {"t": tr["tex"] * float(sh.tex_fmt.ulp), "D": tr["D"] * float(sh.diffuse_fmt.ulp),
            "S": tr["S"] * float(sh.specular_fmt.ulp), "rgb": tr["rgb"]}


def split(m: dict, a: dict) -> dict:
    """The model's exact ``t D + S`` minus (a)'s, in output LSB: mean and RMS per channel, and the RMS of the
    texture's, the diffuse factor's and the specular's parts (they sum to the difference exactly)."""
    parts = {"texture": (m["t"] - a["t"]) * a["D"], "diffuse": m["t"] * (m["D"] - a["D"]), "specular": m["S"] - a["S"]}
    total = m["t"] * m["D"] + m["S"] - (a["t"] * a["D"] + a["S"])

    def rms(x):
        return [round(float(v), 4) for v in np.sqrt(np.mean(x ** 2, axis=0))]

    return {"mean": [round(float(v), 4) for v in total.mean(axis=0)], "rms": rms(total),
            **{f"rms_{k}": rms(v) for k, v in parts.items()}}


def _to_bytes(x: np.ndarray) -> np.ndarray:
    """Half-up and saturated to bytes, as the shading unit and the references narrow."""
    return np.clip(np.floor(x + 0.5), 0, 255).astype(np.uint8)


def _row(frame, rgb, truth, a, flip: bool, cost=None) -> dict:
    d = rgb.astype(np.int64) - a.astype(np.int64)
    mse = float(np.mean(d ** 2)) if d.size else 0.0
    vs_c = compare(frame.image(rgb), truth.image, truth.full, flip=flip)
    row = {"vs_c_psnr_db": vs_c["psnr_db"], "vs_c_flip": vs_c.get("flip_mean"),
           "vs_a_max_lsb": int(np.abs(d).max(initial=0)),
           "vs_a_psnr_db": None if mse == 0 else round(10 * np.log10(255.0 ** 2 / mse), 2)}
    if cost is not None:
        row |= {"dsp": cost["dsp"], "bram": cost["bram"]}
    return row


def scene_figures(scene, samples: int = DEFAULT_SAMPLES, fracs=(11, 12), size=None, flip: bool = True,
                  extras=()) -> dict:
    """One scene's figures (module docstring): ``{"scene", "preset", "diffuse_fmt", "diffuse_extra_frac", "pixels",
    "before_rounding", "frames": {label: row}}`` (``diffuse_fmt``: the preset's diffuse texels)."""
    path = scene_path(scene)
    preset = scene_preset(path)
    frame = prepare(path, size=size, preset=preset)
    truth = true_image(frame.scene, samples)
    a_bytes, _ = frame.references()
    fa, fm = float_terms(frame), model_terms(frame)
    base = preset_units(preset)
    fmt = base["shade"].diffuse_fmt
    frames = {"float (a)": _row(frame, a_bytes, truth, a_bytes, flip),
              "model": _row(frame, fm["rgb"].astype(np.uint8), truth, a_bytes, flip, frame.params.info()["cost"]),
              "model, D from (a)": _row(frame, _to_bytes(fm["t"] * fa["D"] + fm["S"]), truth, a_bytes, flip),
              "model, S from (a)": _row(frame, _to_bytes(fm["t"] * fm["D"] + fa["S"]), truth, a_bytes, flip)}
    variants = {f"model, D {Fmt(False, fmt.int_bits, f)}": dataclasses.replace(
        base, shade=dataclasses.replace(base["shade"], diffuse_fmt=Fmt(False, fmt.int_bits, f)), diffuse_extra_frac=0)
        for f in fracs}
    variants |= {f"model, D blend +{e} bits": dataclasses.replace(base, diffuse_extra_frac=e) for e in extras}
    for label, units in variants.items():
        other = prepare(path, size=size, preset=units)
        rgb = other.params.compute(other.codes)[:, :3].astype(np.uint8)
        frames[label] = _row(frame, rgb, truth, a_bytes, flip, other.params.info()["cost"])
    return {"scene": frame.scene.name, "preset": preset, "diffuse_fmt": str(fmt),
            "diffuse_extra_frac": base["diffuse_extra_frac"], "pixels": len(frame.codes),
            "samples": samples, "before_rounding": split(fm, fa), "frames": frames}


def _fmt(v, spec: str = ".2f") -> str:
    return "exact" if v is None else format(v, spec)


def table(rows) -> str:
    """Markdown: the split before rounding, then the frames of every scene."""
    def rgb(v, sign=""):
        return " / ".join(format(x, f"{sign}.3f") for x in v)

    lines = ["| scene (preset, D texels, blend) | mean, LSB (r / g / b) | RMS | texture part | diffuse D part | "
             "specular S part |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        b = r["before_rounding"]
        cells = [rgb(b["mean"], "+")] + [rgb(b[k]) for k in ("rms", "rms_texture", "rms_diffuse", "rms_specular")]
        lines.append(f"| `{r['scene']}` ({r['preset']}, {r['diffuse_fmt']}, +{r.get('diffuse_extra_frac', 0)} "
                     f"bits) | " + " | ".join(cells) + " |")
    lines += ["", "| scene | frame | vs (c): PSNR dB | vs (c): FLIP | vs (a): max LSB | vs (a): PSNR dB | "
              "MULT18X18D | DP16KD |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        for label, f in r["frames"].items():
            lines.append(f"| `{r['scene']}` | {label} | {_fmt(f['vs_c_psnr_db'])} | {_fmt(f['vs_c_flip'], '.4f')} | "
                         f"{f['vs_a_max_lsb']} | {_fmt(f['vs_a_psnr_db'])} | {f.get('dsp', '')} | "
                         f"{f.get('bram', '')} |")
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap precision``, :mod:`tools.main`)."""
    ap.add_argument("--scenes", nargs="+", default=shipped_scenes(),
                    help="scene names in scenes/ or .toml paths (default: every shipped scene)")
    ap.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                    help="samples per pixel along each axis of reference (c) (a power of two)")
    ap.add_argument("--diffuse-frac", type=int, nargs="*", default=[11, 12], metavar="F",
                    help="also draw with the diffuse factor at F fraction bits (the preset's integer bits; texels "
                         "and blend)")
    ap.add_argument("--extra-frac", type=int, nargs="*", default=[], metavar="E",
                    help="also draw with the preset's diffuse texels and their sampler's blend E fraction bits finer "
                         "(the preset's diffuse_extra_frac)")
    ap.add_argument("--size", type=int, help="override the image width (aspect kept)")
    ap.add_argument("--no-flip", action="store_true", help="leave out FLIP (faster)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of the Markdown tables")
    add_record_option(ap, "the rows")


def run(args: argparse.Namespace) -> int:
    before = machine()
    for f in args.diffuse_frac:
        if not 1 <= f <= 24:
            print(f"error: --diffuse-frac {f}: must be 1..24 fraction bits", file=sys.stderr)
            return 2
    for e in args.extra_frac:
        if problem := top_problem("diffuse_extra_frac", e):
            print(f"error: --extra-frac {e}: {problem}", file=sys.stderr)
            return 2
    try:
        rows = [scene_figures(s, args.samples, tuple(args.diffuse_frac), args.size, not args.no_flip,
                              tuple(args.extra_frac)) for s in args.scenes]
    except (ValueError, OSError, KeyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(rows, indent=1) if args.json else table(rows))
    write_if_asked(args, rows, before)
    return 0
