r"""MIP pyramids of color textures and bump maps, the level of detail from screen-space derivatives, and
trilinear and anisotropic sampling, in float (host side; the study before the hardware, paper
section 6: "artifact reduced MIP mapping for bump textures").

Pyramids
--------
Level ``l + 1`` has ``max(1, n // 2)`` texels along each axis of ``n`` at level ``l``, and each of its texels is
the **box average** of the area of level ``l`` it covers (:func:`downsample`): the exact 2 x 2 box for an even
size, an area-weighted box of width ``n / m`` texels otherwise (a 40-texel bump map goes 40, 20, 10, 5, 2, 1).
Why a box: a texel of level ``l + 1`` stands for the average of the surface it covers, and the box is that
average exactly; it keeps the map's mean (a checker's far field is its mean grey, as in the true image), has no
negative lobes (no ringing around a checker's edges, no overshoot outside the texel range), and costs one add
tree per texel; the bilinear lookup within a level and the blend between two levels (trilinear) then widen it to
a tent. ``tools/filtering.py`` measures the box against a wider tent kernel.

Bump maps (LEAN mapping, Olano & Baker, I3D 2010)
-------------------------------------------------
What filters linearly is what the bump engine adds to ``N``: the slopes ``B = (du, dv)``
(``N' = N + du A0 + dv A1`` is linear in them), and their second moments ``M = (du^2, du dv, dv^2)``.
:func:`lean_pyramid` filters all five; at a pixel the filtered ``B`` gives the mean normal and
``M - B B^T`` the covariance of the slopes the filter averaged away, which must widen the specular lobe
(averaging the slopes alone flattens the bumps: a flat band at the horizon where the truth is grey).

The hardware's pyramid is :func:`fxmodel.units.mip.mip_pyramid` (the same box, in exact integers from level 0, rounded
once; :func:`reference_texture` gives its levels to reference (a)).

Level of detail
---------------
With ``s = U / W`` (``U``, ``W`` linear in screen space with per-triangle increments ``U_x``, ``W_x``):
``ds/dx = (U_x - s W_x) / W`` (and likewise ``y`` and ``t``). :func:`screen_derivatives` gives the exact float
derivatives of a scene's mesh coordinates ``(u, v)`` per fragment; :func:`level_of_detail` the level
``log2 rho + bias`` with ``rho`` the longer of the two footprint axes in texels (isotropic), or the level of
the minor axis and the taps along the major one (anisotropic, :func:`sample_anisotropic`).
"""

from __future__ import annotations

import numpy as np

from host.frontend import clip_space
from host.reference import sample_trilinear

__all__ = ["downsample", "pyramid", "lean_pyramid", "screen_derivatives", "texel_derivatives", "level_of_detail",
           "sample_trilinear", "sample_anisotropic", "anisotropic_taps", "KERNELS", "lod_increments",
           "reference_texture"]

#: Downsampling kernels: ``box`` (area average, the default) and ``tent`` (the box followed by a
#: ``[1, 2, 1] / 4`` blur of the new level, with wrap-around: wider, no ringing, for comparison).
KERNELS = ("box", "tent")


def _box_matrix(n: int, m: int) -> np.ndarray:
    """``(m, n)``: row ``j`` averages the source interval ``[j n / m, (j + 1) n / m)`` (area weights)."""
    edges = np.arange(m + 1) * (n / m)
    lo, hi = edges[:-1, None], edges[1:, None]
    i = np.arange(n)[None, :]
    overlap = np.clip(np.minimum(hi, i + 1) - np.maximum(lo, i), 0.0, None)
    return overlap / (n / m)


def downsample(img: np.ndarray, kernel: str = "box") -> np.ndarray:
    """The next MIP level ``(max(1, H // 2), max(1, W // 2), C)`` of ``img`` ``(H, W, C)`` float (see the module
    docstring)."""
    if kernel not in KERNELS:
        raise ValueError(f"kernel={kernel!r}: must be one of {', '.join(KERNELS)}")
    img = np.asarray(img, dtype=np.float64)
    h, w = img.shape[:2]
    out = np.einsum("jh,hwc->jwc", _box_matrix(h, max(1, h // 2)), img)
    out = np.einsum("iw,jwc->jic", _box_matrix(w, max(1, w // 2)), out)
    if kernel == "tent":
        for axis in (0, 1):
            if out.shape[axis] > 2:
                out = (np.roll(out, 1, axis) + 2 * out + np.roll(out, -1, axis)) / 4
    return out


def pyramid(img: np.ndarray, kernel: str = "box", levels: int | None = None) -> list[np.ndarray]:
    """The MIP pyramid of ``img`` ``(H, W, C)``: level 0 the image itself (float), down to one texel (or
    ``levels`` levels)."""
    out = [np.asarray(img, dtype=np.float64)]
    while max(out[-1].shape[:2]) > 1 and (levels is None or len(out) < levels):
        out.append(downsample(out[-1], kernel))
    return out


def lean_pyramid(slopes: np.ndarray, kernel: str = "box") -> list[np.ndarray]:
    """The LEAN pyramid of a bump map's slopes ``(H, W, 2)``: per level ``(h, w, 5)`` holding
    ``du, dv, du^2, du dv, dv^2`` (each filtered linearly)."""
    du, dv = slopes[..., 0], slopes[..., 1]
    return pyramid(np.stack([du, dv, du * du, du * dv, dv * dv], -1), kernel)


def screen_derivatives(scene, frags) -> np.ndarray:
    """Exact screen-space derivatives of the mesh coordinates ``(u, v)`` per fragment: ``(K, 2, 2)`` indexed
    ``[k, (u, v), (x, y)]``, pixels x right and y down.

    On a triangle's plane, any attribute ``a`` affine on the triangle is ``a = alpha x_c + beta y_c + gamma
    w_c`` in clip coordinates (three vertices fix ``alpha, beta, gamma``; clipping keeps the plane), so
    ``a / w_c`` is affine in normalized device coordinates and, with ``q = 1 / w_c``,
    ``da/dx = (alpha_a - a alpha_1) / q`` times ``dx_ndc / dx = 2 / width`` (``-2 / height`` along y): the float
    form of ``(U_x - s W_x) / W``.
    """
    tris = scene.triangles()
    clip = clip_space(scene, tris.positions)                      # (T, 3, 3): x_c, y_c, w_c per vertex
    vals = np.concatenate([tris.uvs, np.ones(tris.uvs.shape[:2] + (1,))], -1)     # (T, 3, 3): u, v, 1
    coef = np.linalg.solve(clip, vals)                             # (T, 3 [alpha, beta, gamma], 3 [u, v, 1])
    c = coef[np.asarray(frags.tri)]                                # (K, 3, 3)
    uv = np.asarray(frags.uv)
    w = np.asarray(frags.depth)[:, None]
    scale = np.array([2.0 / scene.width, -2.0 / scene.height])
    d = np.empty((len(uv), 2, 2))
    for a in range(2):
        for ax in range(2):
            d[:, a, ax] = (c[:, ax, a] - uv[:, a] * c[:, ax, 2]) * w[:, 0] * scale[ax]
    return d


def texel_derivatives(duv: np.ndarray, repeat, shape) -> np.ndarray:
    """Derivatives ``(K, 2, 2)`` of a map's texel coordinates: ``duv`` of :func:`screen_derivatives` times the
    map's ``repeat`` and its size (``shape`` ``(H, W)``)."""
    f = np.array([repeat[0] * shape[1], repeat[1] * shape[0]], dtype=np.float64)
    return duv * f[None, :, None]


def level_of_detail(dtex: np.ndarray, bias: float = 0.0) -> np.ndarray:
    """Isotropic level of detail ``log2 rho + bias`` per fragment, ``rho = max(|d/dx|, |d/dy|)`` of the texel
    coordinates ``dtex`` ``(K, 2, 2)`` (OpenGL's scale factor); not clamped (negative: magnified)."""
    rho = np.maximum(np.hypot(dtex[:, 0, 0], dtex[:, 1, 0]), np.hypot(dtex[:, 0, 1], dtex[:, 1, 1]))
    return np.log2(np.maximum(rho, 1e-300)) + bias


def anisotropic_taps(dtex: np.ndarray, max_taps: int = 16):
    """``(taps, P_max, P_min, major_x)`` per fragment: ``taps = min(ceil(P_max / P_min), max_taps)`` with
    ``P_max``, ``P_min`` the longer and shorter footprint axes in texels (``dtex`` ``(K, 2, 2)``) and
    ``major_x`` True where the x axis is the longer."""
    px = np.hypot(dtex[:, 0, 0], dtex[:, 1, 0])
    py = np.hypot(dtex[:, 0, 1], dtex[:, 1, 1])
    pmax, pmin = np.maximum(px, py), np.maximum(np.minimum(px, py), 1e-300)
    return np.clip(np.ceil(pmax / pmin), 1, max_taps).astype(np.int64), pmax, pmin, px >= py


def sample_anisotropic(levels, s, t, dtex, shape, max_taps: int = 16, bias: float = 0.0) -> np.ndarray:
    """Anisotropic sampling (as the OpenGL anisotropic-filtering extension describes it): ``N = min(ceil(P_max /
    P_min), max_taps)`` trilinear taps spaced evenly along the footprint's major axis, each at the level
    ``log2(P_max / N) + bias``, averaged. ``dtex`` ``(K, 2, 2)`` texel derivatives, ``shape`` ``(H, W)`` of
    level 0 (to turn texel offsets into ``s, t``)."""
    n, pmax, pmin, major_x = anisotropic_taps(dtex, max_taps)
    lod = np.log2(np.maximum(pmax / n, 1e-300)) + bias
    axis = np.where(major_x[:, None], dtex[:, :, 0], dtex[:, :, 1])            # texels per pixel along the major
    axis = axis / np.array([shape[1], shape[0]], dtype=np.float64)             # in s, t
    out = np.zeros((len(s), levels[0].shape[-1]))
    for taps in np.unique(n):
        sel = np.flatnonzero(n == taps)
        acc = np.zeros((sel.size, out.shape[1]))
        for i in range(taps):
            o = (i + 0.5) / taps - 0.5
            acc += sample_trilinear(levels, s[sel] + o * axis[sel, 0], t[sel] + o * axis[sel, 1], lod[sel])
        out[sel] = acc / taps
    return out


def lod_increments(scene, frags, repeat) -> dict:
    """The triangle's increments of the color texture's homogeneous coordinates per fragment, in the units of the
    fragment's ``Uc, Vc, W`` per pixel: ``{"Ucx", "Ucy", "Vcx", "Vcy", "Wx", "Wy"}`` float arrays ``(K,)``,
    exact from the scene triangle's plane (:func:`screen_derivatives`' ``alpha, beta, gamma``):
    ``W_x = k (1/w)_x``, ``Uc_x = k (rep u_x - tile (1/w)_x)`` with ``k`` the fragment's ``wscale`` and ``tile`` its
    color tile offset (``frags.tile_c``). ``repeat``: the color texture's ``(u, v)`` repeat."""
    tris = scene.triangles()
    coef = np.linalg.solve(clip_space(scene, tris.positions),
                           np.concatenate([tris.uvs, np.ones(tris.uvs.shape[:2] + (1,))], -1))[np.asarray(frags.tri)]
    px = np.array([2.0 / scene.width, -2.0 / scene.height])
    k, tile = np.asarray(frags.wscale, np.float64), np.asarray(frags.tile_c, np.float64)
    out = {}
    for ax, axn in ((0, "x"), (1, "y")):
        out["W" + axn] = k * coef[:, ax, 2] * px[ax]
        for i, n in enumerate(("Uc", "Vc")):
            out[n + axn] = k * (repeat[i] * coef[:, ax, i] - tile[:, i] * coef[:, ax, 2]) * px[ax]
    return out


def reference_texture(params, codes) -> dict:
    """What reference (a) and (b) need to sample the color texture as a pipeline with MIP mapping does
    (:attr:`fxmodel.pipeline.pixel.PipelineParams.lod`): ``{"texture_levels": [float levels], "texture_lod": (K,)}``,
    the stored pyramid (the data the hardware holds) and the LOD unit's level of each fragment (``codes``: the
    pipeline's input codes), in levels; ``{}`` without MIP mapping. The level is the unit's, proven against exact
    arithmetic on its own (:meth:`fxmodel.units.lod.LodParams.error_bound`): so the distance from (a) is the
    sampler's and the rest of the pipeline's fixed-point error, as before."""
    if params.lod is None:
        return {}
    from fxmodel.pipeline.pixel import LOD_INPUTS
    names = [p.name for p in params.inputs]
    cols = [np.asarray(codes)[:, names.index(n)] for n in ("Uc", "Vc", "W", *LOD_INPUTS)]
    lod, _ = params.lod.compute(*cols) if len(codes) else (np.zeros(0, np.int64), None)
    tex = params.texture
    return {"texture_levels": [tex.level_codes(lv)[0].astype(np.float64) for lv in range(tex.levels)],
            "texture_lod": np.asarray(lod, np.float64) / (1 << params.lod.lod_frac)}
