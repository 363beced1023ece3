"""The host's set-up of a prepared frame (:class:`host.render.Frame`) for the engine from the triangle: the scan
converter of its preset (:func:`raster_params`, :func:`frame_raster`), its triangle records, of the whole frame or
of one tile of it (:func:`frame_records`; the board draws a picture a tile at a time, ``docs/board.md``), and its
depth test and frame buffer (:func:`frame_rop`). :func:`host.render.from_triangles` draws with them.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from fxmodel.pipeline.pixel import lod_slopes
from fxmodel.pipeline.presets import top_value
from fxmodel.units.raster import RasterParams, Records
from fxmodel.units.rop import RopParams
from host.bumpmap import bump_gain
from host.frontend import triangle_records

__all__ = ["raster_params", "frame_raster", "frame_rop", "frame_records"]


def raster_params(units: dict, lod=None) -> RasterParams:
    """The scan converter and interpolators of a pipeline preset's units: the pixel pipeline's input formats
    (:meth:`RasterParams.for_pipeline`) and the preset's ``raster_guard`` (``extra_guard``); with the pipeline's
    LOD unit ``lod`` (MIP mapping), the triangle's increments it reads carried with every fragment
    (:func:`fxmodel.pipeline.pixel.lod_slopes`)."""
    return RasterParams.for_pipeline(units, extra_guard=top_value(units, "raster_guard"), slopes=lod_slopes(lod),
                                     span_dsp=bool(top_value(units, "span_dsp")))


def frame_raster(frame) -> RasterParams:
    """The scan converter of ``frame``'s preset (:func:`raster_params`: the pipeline's input formats)."""
    p = frame.params
    return raster_params(frame.units, p.lod) if frame.units is not None else \
        RasterParams.for_pipeline({"persp": p.persp, "bump": p.bump, "reflect": p.reflect}, slopes=lod_slopes(p.lod))


def frame_rop(frame, raster: RasterParams, width: int, height: int) -> RopParams:
    """The depth test and frame buffer of a ``width x height`` frame (or tile) of ``frame``'s scene, cleared to its
    background, taking ``raster``'s depth."""
    clear = tuple(int(c) for c in np.floor(np.asarray(frame.scene.background) * 255 + 0.5))
    return RopParams(width=width, height=height, max_size=raster.max_size, z_in=raster.out_fmt("Z"),
                     clear_color=clear)


def frame_records(frame, raster: RasterParams, tile=None) -> tuple[Records, np.ndarray]:
    """The host's set-up of ``frame`` (:func:`host.frontend.triangle_records`) into ``raster``'s records, those of
    the frame's material (the pipeline holds one material's maps), with the same block exponent of ``A`` per scene
    triangle as the fragments (``frame.exponent``); ``(records, scene triangle of each)``. ``tile``: ``(x, y,
    width, height)``, the records of that tile of the frame (:func:`host.frontend.triangle_records`)."""
    scene = frame.scene
    mi = int(frame.frags.material[0]) if len(frame.frags) else 0
    gains = [frame.maps if i == mi else SimpleNamespace(a_gain=bump_gain(m)) for i, m in enumerate(scene.materials)]
    recs, tri, mat = triangle_records(scene, raster, gains, frame.exponent, tile)
    keep = np.flatnonzero(mat == mi)
    return Records(params=raster, codes={k: v[keep] for k, v in recs.codes.items()}, source=recs.source[keep],
                   dropped=recs.dropped), tri[keep]
