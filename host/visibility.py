"""Which surface a pixel shows when triangles overlap: the fixed-point depth test against the float z-buffer of
reference (a) (paper, section 4: the engine writes into a frame buffer; docs/design.md, "Depth: which quantity,
and its precision").

The engine from the triangle draws every fragment of every triangle in drawing order, and the raster-operations
unit (:func:`fxmodel.units.rop.draw`, the model's only depth test) keeps, per pixel, the fragment with the largest
fixed-point depth code ``Z`` (pass iff strictly greater than the stored depth; ties: the fragment drawn first).
Reference (a) decides visibility with the front end's float z-buffer on ``1 / w_c`` (:mod:`host.frontend`,
same rule). :func:`resolve` compares the two on the same fragments:

* the float z-buffer over the scan converter's fragments, with the front end's own float depth
  (:func:`host.frontend.inverse_w`), must keep exactly the front end's visible fragments (else the two paths
  drew different triangles: an error, not a depth question);
* a pixel where the two keep different triangles is a **depth disagreement**. It is legitimate only when the two
  surfaces' float depths there differ by at most the documented depth precision
  (:meth:`fxmodel.units.raster.RasterParams.depth_precision`, plus the float reference's own rounding,
  :data:`fxmodel.units.raster.FLOAT_DEPTH_SLACK`); any other disagreement is a problem that fails the verdict;
* disagreements are counted, their largest depth gap reported, they are left out of the frame's LSB comparison
  with reference (a) (the two frames show different surfaces there), and :func:`disagreement_picture` marks them.

Early against late depth (:attr:`Visibility.stats`, ``early_depth``): the fragments that fail the test when they
arrive, in drawing order, are the shading work an early test (before the pixel pipeline) would save.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fxmodel.units.raster import FLOAT_DEPTH_SLACK
from host.frontend import inverse_w, screen_triangles

__all__ = ["Visibility", "resolve", "first_max", "disagreement_picture", "draw_fragments", "rop_params"]


def first_max(pixel: np.ndarray, value: np.ndarray) -> np.ndarray:
    """Per pixel, the index of the first entry (in array order) holding the pixel's largest ``value``: the winner
    of a z-buffer where a strictly larger value wins and a tie keeps the entry drawn first. Returns the indices,
    sorted by pixel."""
    order = np.lexsort((np.arange(len(pixel)), -np.asarray(value), pixel))
    p = pixel[order]
    start = np.r_[True, p[1:] != p[:-1]] if len(p) else np.zeros(0, bool)
    return order[start]


@dataclass
class Visibility:
    """The depth resolution of a frame drawn from triangles (:func:`resolve`).

    Attributes
    ----------
    winner : ndarray (P,), int64
        Per covered pixel (row-major), the fragment index (drawing order) the fixed-point depth test keeps.
    winner_float : ndarray (P,), int64
        The same for the float z-buffer of reference (a).
    pixel : ndarray (P,), int64
        The covered pixels ``y * width + x``, row-major.
    disagree : ndarray (P,), bool
        Pixels where the two keep different triangles.
    gap : ndarray (P,), float64
        The float depth gap ``|Z_fixed winner - Z_float winner|`` (units of ``Z``; 0 where they agree).
    color : ndarray (H, W, 4), int64
        The frame buffer after the draw: ``r, g, b, flags`` (:func:`fxmodel.units.rop.draw`).
    stats : dict
        The report's ``depth`` and ``memory`` sections (see :func:`resolve`).
    problems : list of str
        Disagreements beyond the depth precision (each one line); empty when the frame is consistent.
    """

    winner: np.ndarray = field(repr=False)
    winner_float: np.ndarray = field(repr=False)
    pixel: np.ndarray = field(repr=False)
    disagree: np.ndarray = field(repr=False)
    gap: np.ndarray = field(repr=False)
    color: np.ndarray = field(repr=False)
    stats: dict = field(default_factory=dict)
    problems: list = field(default_factory=list)


def resolve(tframe, out: np.ndarray | None = None) -> Visibility:
    """Resolve the visibility of a frame drawn from triangles (a :class:`host.render.TriangleFrame`).

    Parameters
    ----------
    tframe : TriangleFrame
        Its scan (fragments in drawing order with their ``Z`` codes) and records.
    out : ndarray (K, 6), optional
        The engine's outputs ``x, y, r, g, b, flags`` per fragment in drawing order (default: the model's,
        ``tframe.out``; the RTL's give the frame the RTL drew).

    Returns
    -------
    Visibility
        ``stats``: ``depth`` (``fragments``, ``passed``, ``failed``, ``overdraw`` = fragments / covered pixels,
        ``disagreements``, ``max_depth_gap_of_disagreements``, ``precision``, ``covered_pixels``,
        ``early_depth``) and ``memory`` (``bytes_read``, ``bytes_written`` and their ratios to the covered pixels,
        from the raster-operations unit's counts).

    Raises
    ------
    ValueError
        The float z-buffer over the scan converter's fragments keeps other fragments than the front end's
        rasterizer: the two paths disagree on coverage or on the float depth itself.
    """
    frame = tframe.frame
    scene = frame.scene
    res = tframe.scan
    raster = tframe.params.raster
    x, y, z = (np.asarray(res.codes[k], np.int64) for k in ("x", "y", "Z"))
    pixel = y * scene.width + x
    out = np.asarray(tframe.out if out is None else out, np.int64)
    if out.shape != (len(res), 6) or not (np.array_equal(out[:, 0], x) and np.array_equal(out[:, 1], y)):
        raise ValueError(f"{scene.name}: the engine's outputs are not the scan's {len(res)} fragments in order")

    # the float z-buffer of reference (a), on the front end's own float depth of every fragment
    st = screen_triangles(scene, np.zeros(len(scene.materials)))
    sub = tframe.records.source[res.record]
    iw = inverse_w(st.X[sub], st.Y[sub], 1.0 / st.sub[sub, :, 2], x, y)
    win_f = first_max(pixel, iw)
    tri = np.asarray(tframe.tri)[res.record]
    fr = frame.frags
    mine = sorted(zip(pixel[win_f].tolist(), tri[win_f].tolist()))
    theirs = sorted(zip(np.asarray(fr.index).tolist(), np.asarray(fr.tri).tolist()))
    if mine != theirs:
        raise ValueError(f"{scene.name}: the float z-buffer over the scan converter's {len(res)} fragments keeps "
                         f"{len(mine)} pixels, the front end shows {len(theirs)} visible fragments, "
                         f"{len(set(mine) ^ set(theirs))} (pixel, triangle) pairs differ")

    # the fixed-point depth test: the raster-operations unit's draw, in drawing order
    rop, zc, depth, color, rop_stats = draw_fragments(tframe, out=out)
    # the documented precision is Z's: the stored depth must hold Z exactly (a narrower one, TRUNC, would tie
    # codes up to one of its ulps apart and add that ulp to the precision)
    if rop.z_fmt.frac_bits != raster.out_fmt("Z").frac_bits:
        raise ValueError(f"{scene.name}: the stored depth {rop.z_fmt} is narrower than Z {raster.out_fmt('Z')}")
    win = first_max(pixel, zc)                    # the fragment whose stored depth the buffer holds, drawn first
    if not np.array_equal(depth.reshape(-1)[pixel[win]], zc[win]):
        raise ValueError(f"{scene.name}: the depth buffer holds other depths than the largest fragment depths")
    if not np.array_equal(color.reshape(-1, 4)[pixel[win]], out[win, 2:6]):
        raise ValueError(f"{scene.name}: the frame buffer's colors are not those of the fragments that won")

    near = scene.camera.near
    disagree = res.record[win] != res.record[win_f]
    gap = np.where(disagree, near * np.abs(iw[win] - iw[win_f]), 0.0)
    precision = float(raster.depth_precision())
    limit = precision + FLOAT_DEPTH_SLACK * near * np.maximum(iw[win], iw[win_f])
    bad = np.flatnonzero(disagree & (gap > limit))
    problems = []
    if bad.size:
        k = int(bad[np.argmax(gap[bad])])
        problems.append(f"{bad.size} pixels where the fixed-point depth test keeps another triangle than the float "
                        f"z-buffer although their depths differ by more than the depth precision {precision:.3g} "
                        f"(worst {gap[k]:.3g} at pixel ({int(pixel[win][k] % scene.width)}, "
                        f"{int(pixel[win][k] // scene.width)})): the fixed-point depth is wrong")
    covered = len(win)
    n = len(res)
    passed, failed = int(rop_stats["passed"]), int(rop_stats["failed"])
    if passed + failed != n:
        problems.append(f"the depth test counted {passed} passed + {failed} failed fragments, not {n}")
    read, written = int(rop_stats["bytes_read"]), int(rop_stats["bytes_written"])
    stats = {"depth": {"fragments": n, "passed": passed, "failed": failed, "covered_pixels": covered,
                       "overdraw": round(n / covered, 4) if covered else None,
                       "disagreements": int(disagree.sum()),
                       "max_depth_gap_of_disagreements": float(gap.max(initial=0.0)),
                       "precision": precision,
                       "precision_ulp": round(precision / float(raster.out_fmt("Z").ulp), 5),
                       "early_depth": {"shaded_late": n, "shaded_early": passed,
                                       "shading_saved": round(failed / n, 4) if n else 0.0}},
             "memory": {"bytes_read": read, "bytes_written": written,
                        "bytes_read_per_pixel": round(read / covered, 3) if covered else None,
                        "bytes_written_per_pixel": round(written / covered, 3) if covered else None}}
    return Visibility(winner=win, winner_float=win_f, pixel=pixel[win], disagree=disagree, gap=gap, color=color,
                      stats=stats, problems=problems)


def rop_params(tframe):
    """The raster-operations unit for a frame drawn from triangles: the engine's own (``params.rop``) if it has
    one, else one with the frame's size, the scan converter's viewport limit and ``Z`` format (stored exactly)."""
    from fxmodel.units.rop import RopParams
    own = getattr(tframe.params, "rop", None)
    if own is not None:
        return own
    scene, raster = tframe.frame.scene, tframe.params.raster
    return RopParams(width=scene.width, height=scene.height, max_size=raster.max_size, z_in=raster.out_fmt("Z"))


def draw_fragments(tframe, order=None, out=None):
    """The raster-operations unit's model (:func:`fxmodel.units.rop.draw`, the model's depth test) on a frame's
    fragments in drawing order, or in ``order`` (a permutation of the fragments, e.g. the triangles reversed).

    ``out``: the engine's outputs ``x, y, r, g, b, flags`` per fragment (default the model's). Returns
    ``(params, z, depth, color, stats)``: the :class:`~fxmodel.units.rop.RopParams`, the fragments' stored depth
    codes (in ``order``), and what ``draw`` returns."""
    from fxmodel.units.rop import draw
    params = rop_params(tframe)
    out = np.asarray(tframe.out if out is None else out, np.int64)
    z = np.asarray(tframe.scan.codes["Z"], np.int64)
    if order is not None:
        out, z = out[order], z[order]
    frags = {"x": out[:, 0], "y": out[:, 1], "z": z, "r": out[:, 2], "g": out[:, 3], "b": out[:, 4],
             "flags": out[:, 5]}
    zc, _ = params.depth_codes(z)
    return (params, zc) + draw(params, frags)


def disagreement_picture(image: np.ndarray, vis: Visibility, width: int, scale: int = 2) -> np.ndarray:
    """``image`` (the frame, ``(H, W, 3)`` bytes) dimmed to grey and enlarged ``scale`` times, with every depth
    disagreement filled red and ringed (so that single pixels show)."""
    from PIL import Image, ImageDraw
    grey = (image.astype(np.float64) @ np.array([0.299, 0.587, 0.114]) * 0.6).astype(np.uint8)
    pic = Image.fromarray(np.repeat(grey[..., None], 3, -1)).resize(
        (image.shape[1] * scale, image.shape[0] * scale), Image.NEAREST)
    draw = ImageDraw.Draw(pic)
    corners = [((p % width) * scale, (p // width) * scale) for p in vis.pixel[vis.disagree].tolist()]
    r = 3 * scale
    for cx, cy in corners:                                  # the rings first: they must not hide a marked pixel
        draw.ellipse([cx - r, cy - r, cx + scale + r, cy + scale + r], outline=(255, 80, 80))
    for cx, cy in corners:
        draw.rectangle([cx, cy, cx + scale - 1, cy + scale - 1], fill=(255, 0, 0))
    return np.asarray(pic)
