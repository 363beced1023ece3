"""``bumpmap figures [OUTDIR] [--record PATH]``: the pictures of the docs, from the bit-exact model.

Writes into ``OUTDIR`` (default ``docs/img``):

* ``<scene>.png`` for every shipped scene -- the bit-exact model (left) beside the ideal per-pixel Phong
  reference (right), at the scene's own size;
* ``tin-plane-cubes.png`` -- the tin plane's diffuse (top) and specular (bottom) reflectance cubes as stored in
  the pipeline's memories, each laid out as a cross (``+Y`` above ``-X +Z +X -Z``, ``-Y`` below; every face as
  stored, row 0 at ``t = 0``, border texels left out), all lights baked in;
* ``tin-plane-bump.png`` and ``berlin-wall-bump.png`` -- the height field (left) and the quantized bump map
  ``(du, dv)`` as red and green (right, 128 = no perturbation).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from fxmodel.core.paths import ROOT
from host.bumpmap import bump_rgb
from host.render import compose, from_triangles, prepare, render, render_triangles, save_png
from host.shipped import scene_preset
from host.truth import DEFAULT_SAMPLES
from tools.record import add_record_option, machine, write_if_asked

# cross layout: (row, column) of each face 0..5 = +X, -X, +Y, -Y, +Z, -Z
CROSS = {0: (1, 2), 1: (1, 0), 2: (0, 1), 3: (2, 1), 4: (1, 1), 5: (1, 3)}


def cube_cross(codes: np.ndarray, border: int, scale: float) -> np.ndarray:
    """A cube's texels ``(6, F + 2 border, F + 2 border, 3)`` as an RGB cross image (``value * scale`` bytes)."""
    faces = codes[:, border:codes.shape[1] - border, border:codes.shape[2] - border]
    F = faces.shape[1]
    img = np.full((3 * F, 4 * F, 3), 30, dtype=np.uint8)
    for f, (r, c) in CROSS.items():
        img[r * F:(r + 1) * F, c * F:(c + 1) * F] = np.clip(faces[f] * scale + 0.5, 0, 255).astype(np.uint8)
    return img


def bump_picture(maps) -> np.ndarray:
    """Height field and quantized ``(du, dv)`` side by side."""
    h = maps.heights
    grey = np.clip((h - h.min()) / max(np.ptp(h), 1e-12) * 255 + 0.5, 0, 255).astype(np.uint8)
    return compose(np.repeat(grey[..., None], 3, -1), bump_rgb(maps.bump))


def triangle_figures(frame) -> dict:
    """The frame drawn from triangles (the engine's set-up, scan converter and interpolators): triangles,
    fragments, the scan converter's clocks per covered pixel, its distance from the references and from the frame
    of float-interpolated fragments."""
    tframe = from_triangles(frame)
    report = render_triangles(tframe)
    report.pop("_triangle_bytes")
    covered = report["depth"]["covered_pixels"]
    return {"triangles": len(tframe.records), "fragments": len(tframe.out), "covered_pixels": covered,
            "raster_clocks": report["raster_clocks"], "clocks_per_covered_pixel": report["raster_clocks"] / covered,
            **{k: report[k] for k in ("psnr_db_vs_float", "max_lsb_vs_float", "max_lsb_vs_ideal")},
            "vs_fragments": report["triangles_vs_fragments"]}


def _upscale(img: np.ndarray, k: int) -> np.ndarray:
    return np.repeat(np.repeat(img, k, 0), k, 1)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap figures``, :mod:`tools.main`)."""
    ap.add_argument("outdir", nargs="?", default=str(ROOT / "docs" / "img"))
    add_record_option(ap, "the figures (the docs' results tables)")


def run(args: argparse.Namespace) -> int:
    before = machine()
    out = Path(args.outdir)
    summary = {}
    for path in sorted((ROOT / "scenes").glob("*.toml")):
        frame = prepare(path, preset=scene_preset(path))
        report = render(frame, truth_samples=DEFAULT_SAMPLES)
        model = frame.image(report.pop("_model_bytes"))
        a, b = frame.references()
        save_png(out / f"{path.stem}.png", compose(model, frame.image(b)))
        summary[path.stem] = {k: report[k] for k in ("pixels", "psnr_db_vs_float", "max_lsb_vs_float",
                                                     "psnr_db_vs_ideal", "max_lsb_vs_ideal")}
        truth = report["vs_truth"]
        summary[path.stem]["vs_truth"] = {"samples": truth["samples"], "full_pixels": truth["full_pixels"],
                                          **{k: truth[k]["full"] for k in ("model", "float", "ideal")}}
        summary[path.stem]["triangles"] = triangle_figures(frame)
        if frame.maps.bump is not None and path.stem in ("tin-plane", "berlin-wall"):
            pic = bump_picture(frame.maps)
            save_png(out / f"{path.stem}-bump.png", _upscale(pic, 4) if pic.shape[0] < 100 else pic)
        if path.stem == "tin-plane":
            p = frame.params
            d = cube_cross(p.diffuse.texels.codes, p.diffuse.border, 255 / (1 << p.diffuse.channels[0].frac_bits) / 1.5)
            s = cube_cross(p.specular.texels.codes, p.specular.border, 1 / (1 << p.shade.specular_fmt.frac_bits))
            save_png(out / "tin-plane-cubes.png", np.concatenate([d, s], 0))
    print(json.dumps(summary, indent=2))
    print(f"wrote {out}")
    write_if_asked(args, summary, before)
    return 0
