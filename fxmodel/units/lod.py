r"""Level of detail per pixel in fixed point, for MIP-mapped bump maps and color textures (paper section 6 names
"artifact reduced MIP mapping for bump textures" as the next step; this unit chooses the level).

The scan converter interpolates ``U = u/w``, ``V = v/w`` and ``W = 1/w`` linearly in screen space, so each
triangle holds their x and y increments ``U_x, U_y, V_x, ...`` and the perspective unit divides ``s = U / W``
(paper section 3.2). The screen-space derivatives of ``s`` follow without a division:

``ds/dx = (U_x - s W_x) / W = (U_x W - U W_x) / W^2``

(and likewise ``y`` and ``t``). The level is ``lambda = log2 rho + bias`` with ``rho`` the longer of the
footprint's two axes in texels (OpenGL's isotropic scale factor)::

    rho^2 = max(Q_x, Q_y) / W^4,   Q_x = (D_sx w_tex)^2 + (D_tx h_tex)^2,   D_sx = U_x W - U W_x, ...

Algorithm (bit-exact, on the integer codes)
-------------------------------------------
1. Eight exact products and four differences give ``D_sx, D_sy, D_tx, D_ty`` at a common scale; four products by
   the map's size and four squares give ``Q_x, Q_y``; ``Q = max(Q_x, Q_y)``.
2. ``log2`` of ``Q`` and of ``W``'s code by a leading-one detector (the integer part ``p``) and a table of
   ``2^table_bits`` entries indexed by the ``table_bits`` bits after the leading one (``log2`` of the middle of
   each mantissa interval's start, ``guard`` fraction bits beyond ``lod_frac``: a power of two is exact).
3. ``2 lambda = log2 Q - 4 log2 W + const``; halved, rounded half-up to ``lod_frac`` fraction bits, plus the
   bias code; saturated to ``Fmt(True, lod_int, lod_frac)``.

Flags: bit 0 ``Q = 0`` (a footprint of zero size: constant coordinates or degenerate derivatives; the output is
the format's minimum, the most magnified level), bit 1 ``W <= 0`` (never sent by the front end; output 0),
bit 2 saturated.

Error bound (:meth:`LodParams.error_bound`): the table's error ``e`` on each ``log2`` (mantissa truncation to
``table_bits`` bits and the table's rounding; computed over every entry) enters as ``e / 2`` from ``Q`` and ``2 e``
from ``W``, and the output rounding adds half an ulp: ``|lambda - lambda_exact| <= 5 e / 2 + 2^-(lod_frac + 1)``
on every unsaturated output with ``W > 0`` and ``Q > 0``, against the exact level of the same codes.
Hard cases (tested with hypothesis against exact fractions): grazing triangles (``W`` small with large ``W_x``),
magnified (tiny increments), degenerate derivatives (zero increments, ``Q = 0``), the far end of ``W`` (one ulp).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import Fmt

__all__ = ["LodParams", "FLAG_ZERO", "FLAG_BAD_W", "FLAG_SATURATED"]

FLAG_ZERO, FLAG_BAD_W, FLAG_SATURATED = 1, 2, 4

_bitlen = np.frompyfunc(int.bit_length, 1, 1)


@dataclass(frozen=True)
class LodParams:
    """Parameters of the level-of-detail unit.

    Parameters
    ----------
    uv_fmt, w_fmt : Fmt
        Signed formats of ``U, V`` and ``W`` at the pixel (the perspective unit's inputs).
    duv_fmt, dw_fmt : Fmt
        Signed formats of the increments ``U_x, U_y, V_x, V_y`` and ``W_x, W_y``.
    size : (int, int)
        ``(width, height)`` of the map's level 0 in texels.
    table_bits : int
        Mantissa bits indexing the ``log2`` table (``2**table_bits`` entries).
    lod_frac, lod_int : int
        The level's format ``Fmt(True, lod_int, lod_frac)`` (``lod_frac`` also feeds the trilinear blend).
    guard : int
        Fraction bits of the table entries beyond ``lod_frac``.
    bias : int
        LOD bias, a code of ``lod_frac`` fraction bits.
    """

    uv_fmt: Fmt = Fmt(True, 6, 20)
    w_fmt: Fmt = Fmt(True, 2, 22)
    duv_fmt: Fmt = Fmt(True, 4, 28)
    dw_fmt: Fmt = Fmt(True, 2, 30)
    size: tuple = (64, 64)
    table_bits: int = 7
    lod_frac: int = 8
    lod_int: int = 6
    guard: int = 2
    bias: int = 0

    def __post_init__(self):
        for name in ("uv_fmt", "w_fmt", "duv_fmt", "dw_fmt"):
            f = getattr(self, name)
            if not isinstance(f, Fmt) or not f.signed:
                raise ValueError(f"{name}={f!r}: must be a signed Fmt")
        if (len(self.size) != 2 or any(not isinstance(n, int) or isinstance(n, bool) or n < 1 for n in self.size)):
            raise ValueError(f"size={self.size!r}: must be two positive ints (width, height)")
        for name, lo, hi in (("table_bits", 1, 12), ("lod_frac", 0, 12), ("lod_int", 2, 10), ("guard", 0, 8)):
            v = getattr(self, name)
            if not isinstance(v, int) or not lo <= v <= hi:
                raise ValueError(f"{name}={v!r}: must be an int in {lo}..{hi}")
        if not isinstance(self.bias, int):
            raise ValueError(f"bias={self.bias!r}: must be an int code")

    @property
    def out_fmt(self) -> Fmt:
        return Fmt(True, self.lod_int, self.lod_frac)

    @property
    def table_frac(self) -> int:
        return self.lod_frac + self.guard

    @property
    def d_frac(self) -> int:
        """Fraction bits of the ``D`` terms: the finer of ``U_x W`` and ``U W_x``."""
        return max(self.duv_fmt.frac_bits + self.w_fmt.frac_bits, self.uv_fmt.frac_bits + self.dw_fmt.frac_bits)

    def table(self) -> np.ndarray:
        """``round(log2(1 + i / 2^table_bits) 2^table_frac)`` for each index ``i``: exact at a power of two (a
        footprint of exactly 1, 2, 4, ... texels gives exactly level 0, 1, 2, ...)."""
        n = 1 << self.table_bits
        return np.array([math.floor(math.log2(1 + i / n) * (1 << self.table_frac) + 0.5) for i in range(n)],
                        dtype=np.int64)

    def table_error(self) -> float:
        """Largest ``|log2 m - entry|`` over every mantissa ``m`` of every entry's interval (log2 is monotone:
        the interval's ends), in levels."""
        n, tab = 1 << self.table_bits, self.table() / (1 << self.table_frac)
        return max(max(abs(math.log2(1 + i / n) - tab[i]), abs(math.log2(1 + (i + 1) / n) - tab[i]))
                   for i in range(n))

    def error_bound(self) -> float:
        """Bound on ``|lambda - lambda_exact|`` in levels (module docstring)."""
        return 2.5 * self.table_error() + 2.0 ** -(self.lod_frac + 1)

    def products(self) -> int:
        """Multipliers per pixel: eight for the ``D`` terms, four by the size (shifts for a power of two), four
        squares."""
        return 8 + sum(2 for n in self.size if n & (n - 1)) + 4

    def _log2(self, x):
        """``log2 x`` in ``table_frac`` fraction bits for positive integers ``x`` (object array)."""
        t = self.table_bits
        p = _bitlen(x) - 1
        idx = np.array([(v >> (q - t)) if q >= t else (v << (t - q)) for v, q in zip(x, p)], dtype=object)
        idx = np.array([int(i) & ((1 << t) - 1) for i in idx], dtype=np.int64)
        return np.array([int(q) << self.table_frac for q in p], dtype=object) + self.table()[idx].astype(object)

    def compute(self, U, V, W, Ux, Uy, Vx, Vy, Wx, Wy):
        """Level codes and flags (two ``int64`` arrays) from the integer codes of the pixel's ``U, V, W`` and the
        triangle's increments (see the module docstring)."""
        # exact Python ints: the products exceed 64 bits
        c = [np.array([int(v) for v in np.ravel(a)], dtype=object) for a in (U, V, W, Ux, Uy, Vx, Vy, Wx, Wy)]
        U, V, W, Ux, Uy, Vx, Vy, Wx, Wy = c
        F = self.d_frac
        su = F - self.duv_fmt.frac_bits - self.w_fmt.frac_bits
        sw = F - self.uv_fmt.frac_bits - self.dw_fmt.frac_bits
        sx, sy = self.size

        def d(num_inc, num, w_inc):
            return ((num_inc * W) << su) - ((num * w_inc) << sw)

        qx = (d(Ux, U, Wx) * sx) ** 2 + (d(Vx, V, Wx) * sy) ** 2
        qy = (d(Uy, U, Wy) * sx) ** 2 + (d(Vy, V, Wy) * sy) ** 2
        q = np.maximum(qx, qy)
        flags = np.zeros(len(q), np.int64)
        zero, bad = q == 0, W <= 0
        flags[zero.astype(bool)] |= FLAG_ZERO
        flags[bad.astype(bool)] |= FLAG_BAD_W
        ok = ~(zero | bad).astype(bool)
        out = np.zeros(len(q), dtype=object)
        if ok.any():
            g = self.table_frac
            const = (4 * self.w_fmt.frac_bits - 2 * F) << g                     # 2 log2 of the scales
            two = self._log2(q[ok]) - 4 * self._log2(W[ok]) + const              # 2 lambda, g fraction bits
            shift = g + 1 - self.lod_frac
            out[ok] = ((two + (1 << (shift - 1))) >> shift) + self.bias
        fmt = self.out_fmt
        out[zero.astype(bool)] = fmt.min_code
        out[bad.astype(bool)] = 0
        sat = (out > fmt.max_code) | (out < fmt.min_code)
        flags[(sat & ok).astype(bool)] |= FLAG_SATURATED
        out = np.minimum(np.maximum(out, fmt.min_code), fmt.max_code)
        return out.astype(np.int64), flags

    def exact(self, U, V, W, Ux, Uy, Vx, Vy, Wx, Wy) -> float:
        """The exact level (plus bias) of one pixel's codes, from exact fractions (``-inf`` for ``Q = 0``)."""
        fu, fw, fdu, fdw = (self.uv_fmt.frac_bits, self.w_fmt.frac_bits, self.duv_fmt.frac_bits,
                            self.dw_fmt.frac_bits)
        w = Fraction(int(W), 1 << fw)
        rho2 = []
        for nx, wx in ((0, 0), (1, 1)):
            du = (Fraction(int((Ux, Uy)[nx]), 1 << fdu) * w - Fraction(int(U), 1 << fu)
                  * Fraction(int((Wx, Wy)[wx]), 1 << fdw)) / (w * w)
            dv = (Fraction(int((Vx, Vy)[nx]), 1 << fdu) * w - Fraction(int(V), 1 << fu)
                  * Fraction(int((Wx, Wy)[wx]), 1 << fdw)) / (w * w)
            rho2.append((du * self.size[0]) ** 2 + (dv * self.size[1]) ** 2)
        r = max(rho2)
        if r == 0:
            return -math.inf
        return (math.log2(r.numerator) - math.log2(r.denominator)) / 2 + self.bias / (1 << self.lod_frac)
