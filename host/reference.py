r"""Two float64 references for a rendered frame (paper sections 2-4), to measure what the hardware costs.

(a) :func:`float_pipeline` -- *the same algorithm without quantization*: the same stages as
``fxmodel/pipeline/pixel.py`` (perspective division, bump-map lookup, ``N' = N + du A0 + dv A1``, EQ 1, cube
addresses, bilinear reflectance-cube lookups, ``b D + S``) on the unquantized fragment attributes, maps and cube
texels, with exact division and exact bilinear weights. Its difference from the bit-exact model is the
fixed-point error alone.

(b) :func:`ideal_phong` -- ideal per-pixel Phong: the same perturbed normal, but normalized vectors and the
lighting evaluated exactly at the pixel's normal and reflection direction instead of looked up in cubes. Its
difference from (a) is what the reflectance-cube method itself costs (lighting sampled at texel centres).

Both produce bytes by one rounding (half-up) and clipping to ``[0, 255]``, as the hardware's shading does.

With MIP mapping (``texture_levels`` and ``texture_lod``, :func:`host.mipmap.reference_texture`), both sample the
color texture trilinearly in float (:func:`sample_trilinear`: exact bilinear weights in the two levels
around the level of detail, clamped to the pyramid, and an exact blend between them) from the stored pyramid at the
LOD unit's level: the same algorithm as the trilinear sampler without its quantization.
"""

from __future__ import annotations

import numpy as np

from fxmodel.units.cube import FLIP_S, FLIP_T, CubeParams

__all__ = ["sample_float", "sample_trilinear", "cube_address_float", "perturbed", "float_pipeline", "ideal_phong",
           "to_bytes", "psnr", "max_lsb"]


def sample_float(texels: np.ndarray, face, s, t, filter: str, edge: str) -> np.ndarray:
    """The sampler's addressing and filtering rules (``fxmodel/units/sampler.py``) with exact weights, in float.

    ``texels`` is ``(faces, H, W, C)`` float; returns ``(K, C)``.
    """
    border = 1 if edge == "border" else 0
    _, H, W, _ = texels.shape
    H, W = H - 2 * border, W - 2 * border

    def axis(v, size):
        v = v - np.floor(v) if edge == "repeat" else np.clip(v, 0.0, 1.0)
        if filter == "nearest":
            return np.minimum(np.floor(v * size).astype(np.int64), size - 1) + border, None, None
        x = v * size - 0.5 + border
        i0 = np.floor(x).astype(np.int64)
        f = x - i0
        i1 = i0 + 1
        if edge == "repeat":
            i0, i1 = i0 % size, i1 % size
        elif edge == "clamp":
            i0, i1 = np.clip(i0, 0, size - 1), np.clip(i1, 0, size - 1)
        return i0, i1, f

    i0, i1, fx = axis(np.asarray(s, dtype=np.float64), W)
    j0, j1, fy = axis(np.asarray(t, dtype=np.float64), H)
    face = np.asarray(face, dtype=np.int64)
    if filter == "nearest":
        return texels[face, j0, i0]
    fx, fy = fx[:, None], fy[:, None]
    top = texels[face, j0, i0] * (1 - fx) + texels[face, j0, i1] * fx
    bot = texels[face, j1, i0] * (1 - fx) + texels[face, j1, i1] * fx
    return top * (1 - fy) + bot * fy


def _bilinear(level: np.ndarray, s, t) -> np.ndarray:
    return sample_float(level[None], np.zeros(len(s), np.int64), s, t, "bilinear", "repeat")


def sample_trilinear(levels: list[np.ndarray], s, t, lod, trilinear: bool = True) -> np.ndarray:
    """Sample a pyramid at ``(s, t)`` (1 = one tile, repeating) with level ``lod`` per fragment, clamped to the
    pyramid: bilinear in the two levels around it and a linear blend between them (``trilinear=False``: the
    nearest level only). Returns ``(K, C)``."""
    s, t = np.asarray(s, np.float64), np.asarray(t, np.float64)
    lam = np.clip(np.asarray(lod, np.float64), 0.0, len(levels) - 1)
    if not trilinear:
        lam = np.floor(lam + 0.5)
    l0 = np.minimum(np.floor(lam).astype(np.int64), len(levels) - 1)
    f = lam - l0
    out = np.zeros((len(s), levels[0].shape[-1]))
    for lv in np.unique(l0):
        sel = np.flatnonzero(l0 == lv)
        lo = _bilinear(levels[lv], s[sel], t[sel])
        if lv + 1 < len(levels):
            hi_sel = f[sel] > 0
            hi = lo.copy()
            if hi_sel.any():
                hi[hi_sel] = _bilinear(levels[lv + 1], s[sel][hi_sel], t[sel][hi_sel])
            lo = lo + f[sel][:, None] * (hi - lo)
        out[sel] = lo
    return out


def cube_address_float(v: np.ndarray):
    """``(face, s, t)`` of vectors ``v (K, 3)`` by the cube unit's table and tie rule, with exact division."""
    face, ma, a, b = CubeParams.select(v[:, 0], v[:, 1], v[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        qs = np.where(ma != 0, a / np.where(ma != 0, ma, 1), 0.0)
        qt = np.where(ma != 0, b / np.where(ma != 0, ma, 1), 0.0)
    s = (1 + np.where(np.asarray(FLIP_S)[face], -qs, qs)) / 2
    t = (1 + np.where(np.asarray(FLIP_T)[face], -qt, qt)) / 2
    return face, s, t


def to_bytes(x: np.ndarray) -> np.ndarray:
    """Round half-up and clip to bytes."""
    return np.clip(np.floor(x + 0.5), 0, 255).astype(np.uint8)


def perturbed(frags, bump_float, bump_filter):
    """The float perturbed normal ``N + du A0 + dv A1`` ``(K, 3)`` of reference (a) and (b): ``frags`` as
    :func:`float_pipeline` takes them, the bump map sampled at the exact ``s, t``."""
    duv = sample_float(bump_float[None], np.zeros(len(frags["U"]), np.int64), frags["s"], frags["t"], bump_filter,
                       "repeat")
    A = frags["A"]
    return frags["N"] + duv[:, :1] * A[:, :, 0] + duv[:, 1:2] * A[:, :, 1]


def _texture(frags, texture, texture_filter, texture_levels, texture_lod) -> np.ndarray:
    """The color texture's float sample ``(K, 3)``: bilinear at level 0, or trilinear (module docstring)."""
    if texture_levels is not None:
        return sample_trilinear(texture_levels, frags["sc"], frags["tc"], texture_lod)
    return sample_float(np.asarray(texture, dtype=np.float64)[None], np.zeros(len(frags["sc"]), np.int64),
                        frags["sc"], frags["tc"], texture_filter, "repeat")


def float_pipeline(frags: dict, *, bump_float, texture, diffuse_cube, specular_cube, bump_filter="bilinear",
                   texture_filter="bilinear", cube_edge="border", texture_levels=None, texture_lod=None) -> np.ndarray:
    """Reference (a): bytes ``(K, 3)``.

    ``frags`` holds float arrays: ``s, t, sc, tc`` (exact ``U/W`` ...), ``N (K, 3)``, ``E (K, 3)``,
    ``A (K, 3, 2)``; ``bump_float (H, W, 2)`` the unquantized perturbations in the units ``A`` expects;
    ``texture (H, W, 3)`` bytes; the cubes ``(6, F, F, 3)`` unquantized lighting at texel centres;
    ``texture_levels``, ``texture_lod``: MIP mapping (module docstring), ``None``: none.
    """
    n = perturbed(frags, bump_float, bump_filter)
    E = frags["E"]
    R = 2 * n * np.sum(n * E, 1, keepdims=True) - E * np.sum(n * n, 1, keepdims=True)
    fd, sd, td = cube_address_float(n)
    fs, ss, ts = cube_address_float(R)
    D = sample_float(diffuse_cube, fd, sd, td, "bilinear", cube_edge)
    S = sample_float(specular_cube, fs, ss, ts, "bilinear", cube_edge)
    tex = _texture(frags, texture, texture_filter, texture_levels, texture_lod)
    return to_bytes(tex * D + S)


def ideal_phong(frags: dict, *, bump_float, texture, lighting, bump_filter="bilinear",
                texture_filter="bilinear", texture_levels=None, texture_lod=None) -> np.ndarray:
    """Reference (b): bytes ``(K, 3)`` from normalized vectors and exact lighting (see the module docstring)."""
    n = perturbed(frags, bump_float, bump_filter)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    e = frags["E"] / np.maximum(np.linalg.norm(frags["E"], axis=1, keepdims=True), 1e-300)
    r = 2 * n * np.sum(n * e, 1, keepdims=True) - e
    D = lighting.diffuse_factor(n)
    S = lighting.specular_bytes(r)
    tex = _texture(frags, texture, texture_filter, texture_levels, texture_lod)
    return to_bytes(tex * D + S)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB between byte arrays (``inf`` when identical, empty arrays included: a frame
    with no covered pixel has nothing that differs)."""
    if np.size(a) == 0 and np.size(b) == 0:
        return float("inf")
    mse = np.mean((np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) ** 2)
    return float("inf") if mse == 0 else float(10 * np.log10(255.0 ** 2 / mse))


def max_lsb(a: np.ndarray, b: np.ndarray) -> int:
    """Largest per-channel difference in 8-bit steps."""
    return int(np.max(np.abs(np.asarray(a, dtype=np.int64) - np.asarray(b, dtype=np.int64)), initial=0))
