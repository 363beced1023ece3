"""Small measurement commands of the lower layers' models, kept here so that no model or host module carries a
command line of its own: ``bumpmap raster-errors``, ``bumpmap frontend``, ``bumpmap maps``, ``bumpmap
rop-throughput``."""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

__all__ = ["COMMANDS"]


def add_raster_errors_arguments(ap: argparse.ArgumentParser) -> None:
    from fxmodel.units.raster import RasterParams
    ap.add_argument("--preset", default="default", choices=sorted(RasterParams.PRESETS))
    ap.add_argument("--triangles", type=int, default=4, help="random triangles spanning the viewport")
    ap.add_argument("--seed", type=int, default=1)


def raster_errors(args) -> int:
    """The worst interpolation error of the scan converter against exact planes over triangles spanning the whole
    viewport (:func:`fxmodel.units.raster_errors.measure`), as JSON."""
    from fxmodel.units.raster import RasterParams
    from fxmodel.units.raster_errors import measure
    print(json.dumps(measure(RasterParams.PRESETS[args.preset], args.triangles, args.seed), indent=1))
    return 0


def add_frontend_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("scene")
    ap.add_argument("--size", type=int, nargs="+", metavar="N", help="image width [height] override")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs (the median and best are printed)")


def frontend(args) -> int:
    """Rasterize a scene with the float front end; print its statistics and timing, and the scan converter's clocks
    per covered pixel on the same triangles, as JSON."""
    from fxmodel.units.raster import RasterParams, scan
    from host.frontend import bump_gain, rasterize, triangle_records
    from host.scene import SceneError, load_scene
    try:
        size = None if not args.size else (args.size[0] if len(args.size) == 1 else tuple(args.size[:2]))
        scene = load_scene(args.scene, size=size)
    except SceneError as exc:
        print(f"error: {exc}")
        return 2

    class _Gain:                                  # the maps interface rasterize needs, without color textures
        def __init__(self, g):
            self.a_gain = g
    maps = [_Gain(bump_gain(m)) for m in scene.materials]
    times = []
    for _ in range(max(1, args.repeat)):
        t0 = time.perf_counter()
        fr = rasterize(scene, maps)
        times.append(time.perf_counter() - t0)
    stats = dict(fr.stats)
    stats["seconds"] = {k: round(float(v), 4) for k, v in stats["seconds"].items()}
    recs, _, _ = triangle_records(scene, RasterParams.PRESETS["default"], maps)
    res = scan(recs.params, recs)
    stats["raster"] = {"records": len(recs), "fragments": len(res), "clocks": int(res.clocks.sum()),
                       "clocks_per_fragment": round(float(res.clocks.sum()) / max(1, len(res)), 4)}
    print(json.dumps({"scene": str(args.scene), "width": scene.width, "height": scene.height, **stats,
                      "W_range": [float(fr.W.min()), float(fr.W.max())] if len(fr) else None,
                      "max_abs_UV": float(np.abs(np.r_[fr.U, fr.V]).max()) if len(fr) else None,
                      "max_abs_A": float(np.abs(fr.tri_A).max()) if fr.tri_A.size else 0.0,
                      "rasterize_seconds_median": round(float(np.median(times)), 4),
                      "rasterize_seconds_best": round(float(min(times)), 4)}, indent=1))
    return 0


def add_maps_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("scene")
    ap.add_argument("outdir")


def maps(args) -> int:
    """Write each material's maps as PNG files: ``<i>-<material>_color.png`` (the color texture), and for a
    bump-mapped material ``<i>-<material>_height.png`` (the height field, white = high) and
    ``<i>-<material>_bump.png`` (the quantized ``(du, dv)`` as red and green, 128 = zero, full scale = the format's
    range). ``<i>`` is the material's index and ``<material>`` its name with every character but letters, digits,
    ``-`` and ``_`` made ``_``: a name from the file is a label, never a path."""
    import re

    from host.atomic import atomic_save_png, check_output_dir
    from host.bumpmap import bump_rgb, height_picture, scene_maps
    from host.scene import SceneError, load_scene
    out = check_output_dir(args.outdir, "output folder")
    try:
        scene = load_scene(args.scene)
    except SceneError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for i, (mat, m) in enumerate(zip(scene.materials, scene_maps(scene))):
        stem = f"{i}-{re.sub(r'[^A-Za-z0-9_-]', '_', mat.name)[:40]}"
        atomic_save_png(out / f"{stem}_color.png", m.color)
        if m.bump is None:
            continue
        atomic_save_png(out / f"{stem}_height.png", height_picture(m.heights))
        atomic_save_png(out / f"{stem}_bump.png", bump_rgb(m.bump))
        print(f"{mat.name}: {m.bump.shape[1]}x{m.bump.shape[0]} bump map, scale {m.bump.scale:.6g}, "
              f"A gain {m.a_gain:.6g}, saturated {m.bump.n_saturated}")
    print(f"wrote {out}")
    return 0


def add_rop_throughput_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--sim", default=None, help="icarus or verilator (default: $SIM or icarus)")


def rop_throughput(args) -> int:
    """The ROP's fragments per clock against memory latency and slots (co-simulation), as a markdown table."""
    from cosim.rop import throughput
    rows = throughput(sim=args.sim)
    print("| slots | latency (added cycles) | fragments / clock |\n|---:|---:|---:|")
    for r in rows:
        print(f"| {r['outstanding']} | {r['latency']} | {r['fragments_per_clock']} |")
    return 1 if any(r["mismatches"] for r in rows) else 0


#: The commands of this module (``tools.main``): name -> (help, add arguments, run).
COMMANDS = {
    "raster-errors": ("worst interpolation error of the scan converter against exact planes (JSON)",
                      add_raster_errors_arguments, raster_errors),
    "frontend": ("float front end statistics and timing of a scene (JSON)", add_frontend_arguments, frontend),
    "maps": ("write a scene's color textures, height fields and bump maps as PNG", add_maps_arguments, maps),
    "rop-throughput": ("the ROP's fragments per clock against memory latency (co-simulation)",
                       add_rop_throughput_arguments, rop_throughput),
}
