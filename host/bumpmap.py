r"""Bump maps, color textures and the per-triangle matrix ``A`` (paper, sections 3.2 and 5; Fig. 4, 9 and 11).

Host-side tools (the procedural height fields and color textures are in :mod:`host.textures`, re-exported
here): everything is float64 until :func:`quantize`, which narrows the perturbations **once** to the
bump engine's signed ``d_fmt`` (``BumpParams.d_fmt``; ``bumpmap info bump`` prints it).

Height fields
    :func:`mexican_hat` (the paper's Fig. 9: a Ricker wavelet, made periodic by summing the neighbouring tiles'
    copies), :func:`heights_from_image` (a greyscale PNG, white = high, heights in ``[0, 1]``) and
    :func:`chiselled_text` (Fig. 11: text carved into a rotten surface, drawn with Pillow). A height array ``h``
    has shape ``(H, W)``: row ``i`` runs along ``v`` (top to bottom of the image), column ``j`` along ``u``.
Perturbations
    :func:`perturbations`: central differences with wrap-around (the maps tile),
    ``du[i, j] = -(h[i, j+1] - h[i, j-1]) / 2`` and ``dv[i, j] = -(h[i+1, j] - h[i-1, j]) / 2``, i.e. minus the
    height gradient per texel. Sign (paper Fig. 4): a positive ``du`` tilts the normal toward ``+u``; on a slope
    rising toward ``+u`` the normal tilts back toward ``-u``, so ``du < 0`` there.
Quantization
    :func:`quantize`: ``code = round_half_up(d / (scale * ulp))`` saturated to the format, through
    :func:`fxmodel.core.rounding.narrow` (``Rounding.HALF_UP``, ``Overflow.SATURATE``, with a per-texel flag). By
    default ``scale = max(|du|, |dv|) / d_fmt.max_value`` so the largest perturbation uses the format's range (and
    nothing saturates). A code stands for the perturbation ``d = scale * d_fmt.to_real(code)``.
Matrix A (section 3.2)
    :func:`triangle_matrix`: ``A = strength * scale * [T B]`` with ``T``, ``B`` the unit tangent and bitangent of
    the triangle's ``(u, v)`` mapping, so ``N + du_r A[:, 0] + dv_r A[:, 1]`` (``du_r = d_fmt.to_real(code)``,
    what the bump engine computes) equals ``N + strength (du T + dv B) = N - strength (dh/du T + dh/dv B)``
    (``h`` per texel; ``|N| ~ 1``). As in the paper, ``A`` is computed relative to the triangle's face, not
    per pixel: section 5 discusses the resulting highlight shift on curved meshes.
Color textures
    :func:`color_texture`: ``uint8`` RGB arrays of shape ``(H, W, 3)``, row 0 at ``v = 0``; a constant color
    is a 1 x 1 texture. :func:`graffiti` (Fig. 11) and :func:`checker` are procedural.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.units.bump import BumpParams
from host.scene import Material, Scene
from host.textures import (
    checker,
    chiselled_text,
    color_texture,
    graffiti,
    height_field,
    height_picture,
    heights_from_image,
    mexican_hat,
    periodic_noise,
)

__all__ = ["block_exponent", "bump_rgb", "mexican_hat", "heights_from_image", "chiselled_text", "height_field",
           "height_picture", "perturbations", "BumpCodes", "quantize", "tangent_frame", "triangle_matrix", "graffiti",
           "checker", "color_texture",
           "MaterialMaps", "material_maps", "scene_maps", "bump_gain", "periodic_noise"]

DEFAULT_D_FMT = BumpParams().d_fmt


# ------------------------------------------------------------------------------------------------------------
# perturbations and quantization
# ------------------------------------------------------------------------------------------------------------
def perturbations(h) -> tuple[np.ndarray, np.ndarray]:
    """``(du, dv)`` = minus the central-difference gradient of ``h`` per texel, wrapping at the borders.

    ``du[i, j] = -(h[i, (j+1) % W] - h[i, (j-1) % W]) / 2`` and
    ``dv[i, j] = -(h[(i+1) % H, j] - h[(i-1) % H, j]) / 2``. A map 1 or 2 texels wide has zero differences along
    that axis, as the wrap implies.
    """
    h = np.asarray(h, dtype=np.float64)
    if h.ndim != 2:
        raise ValueError(f"height field must be 2-D (H, W), not shape {h.shape}")
    du = -(np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / 2.0
    dv = -(np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / 2.0
    return du, dv


@dataclass(frozen=True)
class BumpCodes:
    """A quantized bump map.

    Attributes
    ----------
    du, dv : ndarray, shape (H, W), int64
        Codes of :attr:`fmt` (two's-complement values): row ``i`` along ``v``, column ``j`` along ``u``.
    scale : float
        Perturbation per unit of the format's real value: ``du ~ scale * fmt.to_real(code)`` (0 for a flat map).
    fmt : Fmt
    rounding, overflow : Rounding, Overflow
        The narrowing's rules (``HALF_UP``, ``SATURATE``).
    saturated : ndarray, shape (H, W), bool
        True where ``du`` or ``dv`` was clamped.
    """

    du: np.ndarray = field(repr=False)
    dv: np.ndarray = field(repr=False)
    scale: float
    fmt: Fmt
    rounding: Rounding
    overflow: Overflow
    saturated: np.ndarray = field(repr=False)

    @property
    def n_saturated(self) -> int:
        """Texels where ``du`` or ``dv`` was clamped."""
        return int(np.count_nonzero(self.saturated))

    @property
    def shape(self) -> tuple[int, int]:
        return self.du.shape

    def to_real(self) -> tuple[np.ndarray, np.ndarray]:
        """The perturbations the codes stand for, ``scale * fmt.to_real(code)`` (float64)."""
        return self.scale * self.fmt.to_real(self.du), self.scale * self.fmt.to_real(self.dv)


def _round_to_codes(x: np.ndarray, fmt: Fmt, what: str):
    """``narrow`` the real values ``x`` (in the format's real units) to ``fmt``: half-up, saturated.

    ``x`` is first clamped to one ulp beyond the format's range (which cannot change a saturation decision), then
    scaled by ``2**G`` and floored: exact, and ``floor`` keeps every comparison with the rounding points, which
    are integers at ``G`` fraction bits, so the rounding is that of the exact real value.
    """
    if not fmt.signed:
        raise ValueError(f"fmt={fmt}: the bump perturbation format must be signed")
    lo, hi = float(fmt.min_value) - 2.0 ** -fmt.frac_bits, float(fmt.max_value) + 2.0 ** -fmt.frac_bits
    g = 61 - max(fmt.int_bits, 1) - 1
    if g < fmt.frac_bits:
        raise ValueError(f"fmt={fmt}: too wide for int64 quantization")
    xi = np.floor(np.ldexp(np.clip(x, lo, hi), g)).astype(np.int64)
    return narrow(xi, g, fmt, Rounding.HALF_UP, Overflow.SATURATE, what)


def _quotient_codes(d: np.ndarray, scale: float, fmt: Fmt, what: str):
    """``_round_to_codes`` of the exact quotient ``d / scale`` (not of its float64 rounding).

    The float division errs by half a float ulp, which can move a quotient onto or across a rounding point of
    ``fmt`` (the half-way points between codes, the saturation thresholds among them). Rows whose float quotient
    lies within a few float ulps of such a point are decided again in exact rational arithmetic; every other row's
    rounding is that of the exact quotient already.
    """
    y = d / scale
    codes, flags = _round_to_codes(y, fmt, what)
    t = np.ldexp(y, fmt.frac_bits)                                   # the quotient in ulps of fmt (exact scaling)
    near = np.abs(t - np.floor(t) - 0.5) <= 8 * np.spacing(np.abs(t)) + 8 * np.finfo(np.float64).tiny
    if np.any(near):
        q = Fraction(scale)
        for i in zip(*np.nonzero(near)):
            c = math.floor(Fraction(float(d[i])) / q * (1 << fmt.frac_bits) + Fraction(1, 2))    # HALF_UP
            codes[i] = min(max(c, fmt.min_code), fmt.max_code)                                   # SATURATE
            flags[i] = not fmt.min_code <= c <= fmt.max_code
    return codes, flags


def quantize(du, dv, fmt: Fmt = DEFAULT_D_FMT, scale: float | None = None) -> BumpCodes:
    """Quantize perturbations once to the signed ``fmt`` (the bump engine's ``d_fmt``).

    Parameters
    ----------
    du, dv : array_like, shape (H, W)
        Float perturbations from :func:`perturbations`.
    fmt : Fmt
        Signed target format (default ``BumpParams().d_fmt``, the bump engine's).
    scale : float, optional
        Perturbation represented by a real value of 1 in ``fmt``. Default:
        ``max(|du|, |dv|) / fmt.max_value``, so the largest magnitude becomes ``fmt.max_code`` (or its negation)
        and nothing saturates; a flat map (largest magnitude below the smallest normal float) gets
        ``scale = 0`` and zero codes.

    Returns
    -------
    BumpCodes
        ``code = round_half_up(d / scale / ulp)`` of the exact quotient (:attr:`Rounding.HALF_UP`, ties toward plus
        infinity),
        clamped to ``[min_code, max_code]`` (:attr:`Overflow.SATURATE`, flagged per texel).
    """
    du = np.asarray(du, dtype=np.float64)
    dv = np.asarray(dv, dtype=np.float64)
    if du.shape != dv.shape:
        raise ValueError(f"du and dv must have the same shape, not {du.shape} and {dv.shape}")
    if not (np.all(np.isfinite(du)) and np.all(np.isfinite(dv))):
        raise ValueError("du, dv must be finite")
    if scale is None:
        m = max(float(np.abs(du).max(initial=0.0)), float(np.abs(dv).max(initial=0.0)))
        scale = m / float(fmt.max_value) if m >= np.finfo(np.float64).tiny else 0.0     # subnormal: flat
    else:
        scale = float(scale)
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"scale={scale!r}: must be a finite number > 0")
    if scale == 0.0:
        z = np.zeros(du.shape, np.int64)
        return BumpCodes(z, z.copy(), 0.0, fmt, Rounding.HALF_UP, Overflow.SATURATE, np.zeros(du.shape, bool))
    cu, fu = _quotient_codes(du, scale, fmt, "bump du")
    cv, fv = _quotient_codes(dv, scale, fmt, "bump dv")
    return BumpCodes(cu, cv, scale, fmt, Rounding.HALF_UP, Overflow.SATURATE, fu | fv)


# ------------------------------------------------------------------------------------------------------------
# the per-triangle matrix A
# ------------------------------------------------------------------------------------------------------------
def tangent_frame(positions, uvs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit tangent ``T`` and bitangent ``B`` of triangles' ``(u, v)`` mappings (paper section 3.2).

    For ``P(u, v) = P0 + (u - u0) dP/du + (v - v0) dP/dv`` on the triangle, solve
    ``[P1 - P0, P2 - P0] = [dP/du, dP/dv] [[u1 - u0, u2 - u0], [v1 - v0, v2 - v0]]``; then project each onto the
    plane of the face normal ``n = normalize((P1 - P0) x (P2 - P0))`` (``X - (X.n) n``; a no-op up to rounding,
    since both lie in the face already) and normalize. ``T`` and ``B`` are *not* made orthogonal to each other:
    a sheared mapping keeps its shear, so the bumps follow the texture. Repeat counts scale ``u``, ``v`` and do
    not change the directions.

    Parameters
    ----------
    positions : array_like, shape (..., 3, 3)
    uvs : array_like, shape (..., 3, 2)

    Returns
    -------
    T, B : ndarray, shape (..., 3)
        Unit vectors along ``+u`` and ``+v`` in world space (zero where the mapping is degenerate).
    ok : ndarray, shape (...,), bool
        False for a degenerate ``(u, v)`` mapping (zero ``uv`` area) or a zero-area triangle.
    """
    P = np.asarray(positions, dtype=np.float64)
    UV = np.asarray(uvs, dtype=np.float64)
    e1, e2 = P[..., 1, :] - P[..., 0, :], P[..., 2, :] - P[..., 0, :]
    d1, d2 = UV[..., 1, :] - UV[..., 0, :], UV[..., 2, :] - UV[..., 0, :]
    det = d1[..., 0] * d2[..., 1] - d2[..., 0] * d1[..., 1]
    n = np.cross(e1, e2)
    nlen = np.linalg.norm(n, axis=-1)
    uvscale = np.maximum(np.abs(d1).max(axis=-1), np.abs(d2).max(axis=-1))
    ok = (np.abs(det) > 1e-12 * uvscale ** 2) & (nlen > 0)
    safe = np.where(ok, det, 1.0)[..., None]
    n = n / np.where(nlen > 0, nlen, 1.0)[..., None]
    T = (d2[..., 1, None] * e1 - d1[..., 1, None] * e2) / safe
    B = (d1[..., 0, None] * e2 - d2[..., 0, None] * e1) / safe
    out = []
    for X in (T, B):
        X = X - np.sum(X * n, axis=-1, keepdims=True) * n
        length = np.linalg.norm(X, axis=-1, keepdims=True)
        out.append(np.where(ok[..., None] & (length > 0), X / np.where(length > 0, length, 1.0), 0.0))
    return out[0], out[1], ok


def triangle_matrix(positions, uvs, strength: float, scale: float) -> np.ndarray:
    """The per-triangle matrix ``A = strength * scale * [T B]`` (3 x 2, paper section 3.2, Fig. 6).

    With it the bump engine's ``N' = N + du_r A[:, 0] + dv_r A[:, 1]`` (``du_r``, ``dv_r`` the real values of
    the quantized codes, ``du ~ scale du_r``) is the float perturbation ``N + strength (du T + dv B)
    = N - strength (dh/du T + dh/dv B)`` in units where ``|N| ~ 1``. The pipeline quantizes ``A`` to
    ``BumpParams.a_fmt`` (half-up, saturating): keep ``strength * scale`` below ``a_fmt.max_value``. A degenerate
    mapping gives ``A = 0``.

    Parameters
    ----------
    positions : array_like, shape (..., 3, 3)
    uvs : array_like, shape (..., 3, 2)
    strength, scale : float or array_like broadcasting to shape (...)

    Returns
    -------
    ndarray, shape (..., 3, 2), float64
        ``A[..., :, 0]`` is along ``+u`` (``T``), ``A[..., :, 1]`` along ``+v`` (``B``).
    """
    T, B, _ = tangent_frame(positions, uvs)
    k = np.asarray(strength, dtype=np.float64) * np.asarray(scale, dtype=np.float64)
    return np.stack([T, B], axis=-1) * k[..., None, None]


def _support(points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """``max_p |dirs . p|`` for each row of ``dirs`` ``(..., 2)`` over the points ``(P, 2)`` (their convex hull's
    vertices suffice: a bilinear blend of texels lies in it)."""
    pts = np.unique(points, axis=0)
    if len(pts) > 64:                                  # Andrew's monotone chain: the hull's vertices only
        def half(seq):
            out = []
            for p in seq:
                while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                         - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                    out.pop()
                out.append(p)
            return out[:-1]
        seq = [tuple(p) for p in pts.tolist()]
        pts = np.array(half(seq) + half(seq[::-1]) or seq, dtype=np.float64)
    flat = dirs.reshape(-1, 2)
    best = np.zeros(len(flat))
    for lo in range(0, len(flat), 4096):
        best[lo:lo + 4096] = np.abs(flat[lo:lo + 4096] @ pts.T).max(axis=1)
    return best.reshape(dirs.shape[:-1])


def block_exponent(A, n_max, duv, a_fmt: Fmt, out_fmt: Fmt, e_max: int) -> np.ndarray:
    """The per-triangle shared exponent ``e`` of the bump matrix (block floating point, triangle set-up).

    The bump engine computes ``N' = N 2**-e + du A0' + dv A1'`` with ``A' = A 2**-e`` (the cube lookups need the
    direction only). ``e`` is the smallest integer in ``[0, e_max]`` for which ``A 2**-e`` fits ``a_fmt`` (after
    its half-up rounding) and ``N'`` cannot saturate ``out_fmt``: ``2**-e (n_max_i + max |du A_i0 + dv A_i1|)``
    below ``out_fmt``'s largest value, with the maximum over the map's texels (a bilinear blend lies in their convex
    hull) and a margin of ``2**-10`` relative plus one ``out_fmt`` ulp for the roundings of ``A'`` and ``N'``.
    ``e = 0`` keeps ``N`` unscaled (the paper's engine); where no ``e <= e_max`` works, ``e_max`` (then
    ``A'`` clamps, which :func:`host.render.prepare` refuses).

    Parameters
    ----------
    A : ndarray, shape (T, 3, 2)
        The triangles' matrices (:func:`triangle_matrix`).
    n_max : ndarray, shape (T, 3)
        Per triangle and component, the largest ``|N_i|`` of its vertex normals (the interpolated normal stays in
        their convex hull).
    duv : ndarray, shape (P, 2)
        The bump map's perturbations ``(du, dv)`` in real units (the codes' values).
    a_fmt, out_fmt : Fmt
        ``BumpParams.a_fmt`` and ``out_fmt``.
    e_max : int
        ``BumpParams.e_max``.

    Returns
    -------
    ndarray, shape (T,), int64
    """
    A = np.asarray(A, dtype=np.float64)
    a_lim = float(a_fmt.max_value) + float(a_fmt.ulp) / 4          # half-up rounding stays within a_fmt below this
    need_a = np.abs(A).max(axis=(1, 2), initial=0.0) / a_lim
    pert = _support(np.asarray(duv, dtype=np.float64).reshape(-1, 2), A) if len(A) else np.zeros((0, 3))
    worst = (np.asarray(n_max, dtype=np.float64) + pert).max(axis=1, initial=0.0) * (1 + 2.0 ** -10)
    need_n = (worst + float(out_fmt.ulp)) / float(out_fmt.max_value)
    need = np.maximum(need_a, need_n)
    e = np.ceil(np.log2(np.maximum(need, 1.0)))
    return np.minimum(e, e_max).astype(np.int64)


# ------------------------------------------------------------------------------------------------------------
# everything a material needs
# ------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MaterialMaps:
    """The host-side maps of one material.

    Attributes
    ----------
    color : ndarray, shape (H, W, 3), uint8
    color_repeat : (float, float)
    heights : ndarray (Hb, Wb) float64 or None
        The height field (None without a bump map).
    bump : BumpCodes or None
    bump_repeat : (float, float)
        (1, 1) without a bump map.
    strength : float
        0 without a bump map.
    """

    color: np.ndarray = field(repr=False)
    color_repeat: tuple[float, float]
    heights: np.ndarray | None = field(repr=False)
    bump: BumpCodes | None
    bump_repeat: tuple[float, float]
    strength: float

    @property
    def a_gain(self) -> float:
        """``strength * scale``: the factor of ``[T B]`` in ``A`` (0 without a bump map or for a flat one)."""
        return self.strength * self.bump.scale if self.bump is not None else 0.0


def material_maps(material: Material, d_fmt: Fmt = DEFAULT_D_FMT) -> MaterialMaps:
    """Build a material's color texture and quantized bump map (``d_fmt``: the bump engine's ``d_fmt``)."""
    color = color_texture(material.color)
    if material.bump is None:
        return MaterialMaps(color, material.color.repeat, None, None, (1.0, 1.0), 0.0)
    h = height_field(material.bump)
    codes = quantize(*perturbations(h), d_fmt)
    return MaterialMaps(color, material.color.repeat, h, codes, material.bump.repeat, material.bump.strength)


def bump_gain(material: Material, d_fmt: Fmt = DEFAULT_D_FMT) -> float:
    """``strength * scale`` of a material's bump map (0 without one): :attr:`MaterialMaps.a_gain` without
    building the color texture."""
    if material.bump is None:
        return 0.0
    return material.bump.strength * quantize(*perturbations(height_field(material.bump)), d_fmt).scale


def scene_maps(scene: Scene, d_fmt: Fmt = DEFAULT_D_FMT) -> tuple[MaterialMaps, ...]:
    """:func:`material_maps` of every material of ``scene``, in order."""
    return tuple(material_maps(m, d_fmt) for m in scene.materials)


def bump_rgb(bump: BumpCodes) -> np.ndarray:
    """A quantized bump map as a picture: ``du`` red, ``dv`` green, 128 = no perturbation, full scale = the
    format's range."""
    rg = [np.clip(np.floor(128 + 127 * c / bump.fmt.max_code + 0.5), 0, 255) for c in (bump.du, bump.dv)]
    return np.stack(rg + [np.full_like(rg[0], 128)], -1).astype(np.uint8)
