"""Depth test and frame-buffer figures of the shipped scenes drawn from triangles (the bit-exact model):
overdraw, what an early depth test would save, the depth disagreements with reference (a), memory traffic.

``bumpmap depth [--scenes tin-sphere ...] [--size N] [--json] [--picture PNG]``

Per scene (at its own size unless ``--size``): the fragments the scan converter emits, the covered pixels, the
overdraw (fragments / covered pixels), the fragments that fail the depth test when they arrive in drawing order
(the shading an early depth test would save; the same count with the triangles drawn in reverse order, to bracket
what the order costs), the depth disagreements with reference (a)'s float z-buffer and their largest depth gap
against the documented precision (:mod:`host.visibility`), and the frame-buffer bytes read and written per
covered pixel (:func:`fxmodel.units.rop.draw`'s counts). Prints a Markdown table (the README's) or JSON.
``--picture`` writes the first scene's frame from triangles (doubled) beside its depth disagreements marked in red
(the README's ``docs/img/tin-sphere-depth.png``).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from fxmodel.core.paths import shipped_scenes
from host.render import compose, from_triangles, prepare, save_png
from host.scene import scene_path
from host.shipped import scene_preset
from host.visibility import disagreement_picture, draw_fragments
from tools.record import add_record_option, machine, write_if_asked


def reversed_order_failed(tframe) -> int:
    """Fragments failing the depth test when the same triangles are drawn in reverse order (each triangle's own
    fragments keep their order)."""
    rec = tframe.scan.record
    order = np.lexsort((np.arange(len(rec)), -rec))
    _, _, _, _, stats = draw_fragments(tframe, order)
    return int(stats["failed"])


def figures(scene, size=None, picture=None) -> dict:
    """One scene's row (module docstring); ``picture``: a PNG path for the frame and its disagreements."""
    tframe = from_triangles(prepare(scene_path(scene), size=size, preset=scene_preset(scene)))
    if picture is not None:
        frame = tframe.image(tframe.out[:, 2:5].astype(np.uint8))
        save_png(picture, compose(np.repeat(np.repeat(frame, 2, 0), 2, 1),
                                  disagreement_picture(frame, tframe.vis, frame.shape[1], scale=2)))
    d, m = tframe.vis.stats["depth"], tframe.vis.stats["memory"]
    sc = tframe.frame.scene
    return {"scene": sc.name, "size": f"{sc.width}x{sc.height}", "triangles": len(tframe.records),
            "fragments": d["fragments"], "covered_pixels": d["covered_pixels"], "overdraw": d["overdraw"],
            "failed": d["failed"], "early_depth_saves": d["early_depth"]["shading_saved"],
            "failed_reversed_order": reversed_order_failed(tframe),
            "raster_clocks": tframe.stats["raster_clocks"], "disagreements": d["disagreements"],
            "max_depth_gap_of_disagreements": d["max_depth_gap_of_disagreements"], "precision": d["precision"],
            "bytes_read_per_pixel": m["bytes_read_per_pixel"],
            "bytes_written_per_pixel": m["bytes_written_per_pixel"]}


def table(rows) -> str:
    head = ("| scene | size | fragments | covered pixels | overdraw | fail the depth test (early depth saves) | "
            "reversed order | depth disagreements (largest gap) | bytes read / pixel | bytes written / pixel |")
    lines = [head, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        gap = f" ({r['max_depth_gap_of_disagreements']:.2g})" if r["disagreements"] else ""
        lines.append(f"| `{r['scene']}` | {r['size']} | {r['fragments']:,} | {r['covered_pixels']:,} | "
                     f"{r['overdraw']:.3f} | {r['failed']:,} ({100 * r['early_depth_saves']:.1f} %) | "
                     f"{r['failed_reversed_order']:,} | {r['disagreements']}{gap} | {r['bytes_read_per_pixel']:.2f} | "
                     f"{r['bytes_written_per_pixel']:.2f} |")
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap depth``, :mod:`tools.main`)."""
    ap.add_argument("--scenes", nargs="+", default=shipped_scenes(),
                    help="scene names in scenes/ or .toml paths (default: every shipped scene)")
    ap.add_argument("--size", type=int, help="override the image width (aspect kept)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of the Markdown table")
    ap.add_argument("--picture", help="write the first scene's frame and its depth disagreements to this PNG")

    add_record_option(ap, "the rows")


def run(args: argparse.Namespace) -> int:
    before = machine()
    try:
        rows = [figures(s, args.size, args.picture if i == 0 else None) for i, s in enumerate(args.scenes)]
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(rows, indent=1) if args.json else table(rows))
    write_if_asked(args, rows, before)
    return 0
