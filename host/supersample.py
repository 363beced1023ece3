"""Scene samples at any sub-pixel positions, a band of pixel rows at a time: the sampler of reference (c)
(:mod:`host.truth`).

The same front end as every frame (:func:`host.frontend.screen_triangles`: projection, clipping, snapping to
1/256 pixel, culling), then per sample the front end's own rules at a point other than the pixel centre: the
integer edge functions with the top-left rule (:func:`fxmodel.units.raster.edge_setup`), the nearest surface by
the largest ``1 / w`` (the first triangle on a tie), and the perspective-correct attributes from the same
barycentric weights ``E_e (1 / w_e) / area``, in the order of :func:`host.frontend.rasterize`. Sample positions
are integers in 1/256 pixel (``SUBPIXEL_BITS``), so every K up to 128 that divides 256 puts a regular grid
exactly at ``(i + 1/2) / K``.

Memory is bounded by the band (``rows`` pixel rows times ``width`` times the samples per pixel), not by the
frame, so reference (c) is not limited by the front end's largest image size nor by the machine's memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxmodel.units.raster import area2, edge_setup
from host.frontend import SUBPIXEL_BITS, screen_triangles

__all__ = ["Samples", "offsets", "scene_samples"]

_ONE = 1 << SUBPIXEL_BITS


def offsets(k: int, pattern: str, seed: int, y: int, width: int) -> np.ndarray:
    """Sample offsets ``(width, k*k, 2)`` (1/256 pixel, ``x, y``) of the pixels of row ``y``.

    ``grid``: the regular grid ``(i + 1/2) / k`` (the same for every pixel). ``jittered``: one uniformly random
    point in each of the ``k x k`` cells (stratified), drawn from a generator seeded by ``(seed, y)``, so a row's
    samples do not depend on the band it is drawn in.
    """
    cell = _ONE // k
    i = np.arange(k)
    gx, gy = np.meshgrid(i, i)
    base = np.stack([gx.ravel(), gy.ravel()], -1) * cell                     # (k*k, 2)
    if pattern == "grid":
        return np.broadcast_to(base + cell // 2, (width, k * k, 2))
    if pattern == "jittered":
        rng = np.random.default_rng([seed, y])
        return base[None] + rng.integers(0, cell, (width, k * k, 2))
    raise ValueError(f"pattern={pattern!r}: must be grid or jittered")


@dataclass
class Samples:
    """The covered samples of a band: pixel index ``pix`` (``y * width + x``) and the attributes the shading
    needs (as :class:`host.frontend.Fragments` names them), and per pixel of the band the number of covered
    samples."""

    pix: np.ndarray
    material: np.ndarray
    s: np.ndarray
    t: np.ndarray
    sc: np.ndarray
    tc: np.ndarray
    N: np.ndarray
    E: np.ndarray
    A: np.ndarray


def _cover(st, j, cx, cy):
    """Which samples ``(cx, cy)`` (1/256 pixel) screen triangle ``j`` covers (top-left rule), and its three edge
    functions there."""
    X, Y = st.X[j], st.Y[j]
    A, B, C, bias = edge_setup(X, Y)
    E = [A[e] * cx + (B[e] * cy + C[e]) for e in range(3)]
    inside = (E[0] >= bias[0]) & (E[1] >= bias[1]) & (E[2] >= bias[2])
    return inside, E


def scene_samples(scene, gains, k: int, pattern: str = "grid", seed: int = 0, rows: int | None = None,
                  max_points: int = 1 << 16):
    """Yield ``(y0, y1, coverage, samples)`` for each band of pixel rows ``[y0, y1)`` of ``scene`` sampled with
    ``k x k`` samples per pixel (:func:`offsets`); ``coverage`` ``(y1 - y0, width)`` counts the covered samples,
    ``samples`` a :class:`Samples` of them. ``gains`` the ``a_gain`` per material (as
    :func:`host.frontend.rasterize` takes them)."""
    st = screen_triangles(scene, np.asarray(gains, dtype=np.float64))
    w, h = scene.width, scene.height
    n = k * k
    rows = rows or max(1, max_points // (w * n))
    sub, X, Y = st.sub, st.X, st.Y
    invw_v = 1.0 / sub[..., 2]
    area = area2(X, Y).astype(np.float64)
    # pixel bounding boxes of the triangles (samples lie inside their pixel)
    px0, px1 = np.floor_divide(X.min(1), _ONE), np.floor_divide(X.max(1), _ONE)
    py0, py1 = np.floor_divide(Y.min(1), _ONE), np.floor_divide(Y.max(1), _ONE)
    bump_rep, color_rep = st.bump_rep, st.color_rep
    mat_s = st.tris.material[st.src]
    sign_s = np.where(st.front, 1.0, -1.0)
    cam = np.asarray(scene.camera.position, dtype=np.float64)
    for y0 in range(0, h, rows):
        y1 = min(h, y0 + rows)
        off = np.stack([offsets(k, pattern, seed, y, w) for y in range(y0, y1)])       # (r, w, n, 2)
        xs = np.arange(w)[None, :, None] * _ONE + off[..., 0]
        ys = np.arange(y0, y1)[:, None, None] * _ONE + off[..., 1]
        cx, cy = xs.astype(np.int64), np.broadcast_to(ys, xs.shape).astype(np.int64)
        best = np.zeros(cx.shape)
        owner = np.full(cx.shape, -1, np.int64)
        cand = np.flatnonzero((py1 >= y0) & (py0 < y1) & (px1 >= 0) & (px0 < w))
        for j in cand:
            r0, r1 = max(int(py0[j]), y0) - y0, min(int(py1[j]), y1 - 1) - y0 + 1
            c0, c1 = max(int(px0[j]), 0), min(int(px1[j]), w - 1) + 1
            bx, by = cx[r0:r1, c0:c1], cy[r0:r1, c0:c1]
            inside, E = _cover(st, j, bx, by)
            iw = (E[0] * invw_v[j, 0] + E[1] * invw_v[j, 1] + E[2] * invw_v[j, 2]) / area[j]
            win = inside & (iw > best[r0:r1, c0:c1])
            best[r0:r1, c0:c1][win] = iw[win]
            owner[r0:r1, c0:c1][win] = j
        coverage = (owner >= 0).sum(-1)
        yield y0, y1, coverage, _attributes(scene, st, cx, cy, owner, y0, invw_v, area, bump_rep, color_rep, mat_s,
                                            sign_s, cam)


def _attributes(scene, st, cx, cy, owner, y0, invw_v, area, bump_rep, color_rep, mat_s, sign_s, cam) -> Samples:
    """Perspective-correct attributes of the covered samples (as step 7 of :func:`host.frontend.rasterize`)."""
    w = scene.width
    flat = np.flatnonzero(owner.ravel() >= 0)
    own = owner.ravel()[flat]
    sx, sy = cx.ravel()[flat], cy.ravel()[flat]
    attr = np.empty((flat.size, 8))
    order = np.argsort(own, kind="stable")
    bounds = np.searchsorted(own[order], np.arange(st.sub.shape[0] + 1))
    for j in np.flatnonzero(np.diff(bounds)):
        sel = order[bounds[j]:bounds[j + 1]]
        Xj, Yj = st.X[j], st.Y[j]
        lw = np.empty((sel.size, 3))
        for e in range(3):
            a, b = (e + 1) % 3, (e + 2) % 3
            Ee = (Xj[b] - Xj[a]) * (sy[sel] - Yj[a]) - (Yj[b] - Yj[a]) * (sx[sel] - Xj[a])
            lw[:, e] = Ee * (invw_v[j, e] / area[j])
        vals = np.einsum("kv,va->ka", lw, st.sub[j, :, 3:])
        vals /= lw.sum(axis=1)[:, None]
        attr[sel] = vals
    P, N, uv = attr[:, 0:3], attr[:, 3:6], attr[:, 6:8]
    mat = mat_s[own]
    N *= sign_s[own][:, None]
    E = cam - P
    E /= np.sqrt(np.einsum("ki,ki->k", E, E))[:, None]
    st_b, st_c = uv * bump_rep[mat], uv * color_rep[mat]
    pix = (sy // _ONE) * w + sx // _ONE
    return Samples(pix=pix, material=mat, s=st_b[:, 0], t=st_b[:, 1], sc=st_c[:, 0], tc=st_c[:, 1], N=N, E=E,
                   A=st.tri_A[st.src[own]] * sign_s[own][:, None, None])
