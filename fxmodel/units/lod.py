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

from fxmodel.core.cost import DSP_BITS, Memory, Product, pieces
from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, Unit, register

__all__ = ["LodParams", "FLAG_ZERO", "FLAG_BAD_W", "FLAG_SATURATED"]

FLAG_ZERO, FLAG_BAD_W, FLAG_SATURATED = 1, 2, 4

_bitlen = np.frompyfunc(int.bit_length, 1, 1)


@dataclass(frozen=True)
class LodParams(Unit):
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

    NAME = "lod"

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

    def products_per_pixel(self) -> int:
        """Products per pixel: eight for the ``D`` terms, four by the size (shifts for a power of two; the RTL
        makes the others constant shift-and-add products, no multiplier block), four squares."""
        return 8 + sum(2 for n in self.size if n & (n - 1)) + 4

    # -- the unit contract (fxmodel.core.unit.Unit): ports, latency, hardware -------------------------------
    FLAGS_FMT = Fmt(False, 3, 0)

    @property
    def inputs(self):
        u, w, du, dw = self.uv_fmt, self.w_fmt, self.duv_fmt, self.dw_fmt
        return (Port("U", u, "u/w at the pixel"), Port("V", u, "v/w at the pixel"), Port("W", w, "1/w at the pixel"),
                Port("Ux", du, "dU/dx of the triangle"), Port("Uy", du, "dU/dy"), Port("Vx", du, "dV/dx"),
                Port("Vy", du, "dV/dy"), Port("Wx", dw, "dW/dx of the triangle"), Port("Wy", dw, "dW/dy"))

    @property
    def outputs(self):
        return (Port("level", self.out_fmt, "level plus bias, saturated"),
                Port("flags", self.FLAGS_FMT, "bit 0 Q = 0, bit 1 W <= 0, bit 2 saturated"))

    @property
    def d_split(self) -> bool:
        """Whether an operand of the ``D`` products is wider than one multiplier block (the RTL then registers
        their partial products, ``rtl.recip.split_products``: one stage more)."""
        return max(self.uv_fmt.width, self.w_fmt.width, self.duv_fmt.width, self.dw_fmt.width) > DSP_BITS

    @property
    def latency(self) -> int:
        """Stages (``rtl/lod.py``): [partial products of the ``D`` products] | the two products of each ``D`` |
        ``D`` | the square's piece products | ``D^2`` in two | ``Q_x, Q_y`` | ``Q_x > Q_y`` | ``Q`` |
        leading-zero counts | normalizing shifts | table read | ``2 lambda`` | round, bias, saturate."""
        return 13 + int(self.d_split)

    @property
    def d_bound(self) -> int:
        """Largest ``|D|`` code (at ``d_frac`` fraction bits) the input formats allow."""
        F = self.d_frac
        su = F - self.duv_fmt.frac_bits - self.w_fmt.frac_bits
        sw = F - self.uv_fmt.frac_bits - self.dw_fmt.frac_bits
        big = lambda f: -f.min_code                                     # noqa: E731 -- the largest magnitude
        return (big(self.duv_fmt) * big(self.w_fmt) << su) + (big(self.uv_fmt) * big(self.dw_fmt) << sw)

    @property
    def d_bits(self) -> int:
        """Width of the signed ``D`` registers: ``|D| <= d_bound`` (a proven narrowing)."""
        return self.d_bound.bit_length() + 1

    @property
    def q_bits(self) -> int:
        """Width of the unsigned ``Q`` register: ``Q <= d_bound^2 (w_tex^2 + h_tex^2)`` (a proven narrowing)."""
        return (self.d_bound ** 2 * (self.size[0] ** 2 + self.size[1] ** 2)).bit_length()

    @property
    def table_word_bits(self) -> int:
        """Bits of a ``log2`` table entry (the largest entry's)."""
        return max(1, int(self.table().max()).bit_length())

    def square_pieces(self) -> list[tuple[int, int, int, int, bool, bool]]:
        """The piece products of ``D^2`` (``D`` cut by :func:`fxmodel.core.cost.pieces`): ``(i, j, a_bits, b_bits,
        a_signed, b_signed)`` for ``i <= j``, a cross product (``i < j``) once and doubled by a shift; one
        multiplier block each (``rtl/lod.py`` builds exactly these)."""
        cut = pieces(self.d_bits, True)
        return [(i, j, cut[i][1], cut[j][1], cut[i][2], cut[j][2]) for i in range(len(cut)) for j in range(i, len(cut))]

    def products(self) -> tuple:
        """Eight ``D`` products (``U_x W`` and ``U W_x`` and the others; split into registered partial products
        when an operand is wider than a block), the piece products of four squares ``D^2``; the map's size is a
        constant (shifts, or shift-and-add: ``rtl.fixed.const_mul``)."""
        split = self.d_split
        du, w, u, dw = self.duv_fmt, self.w_fmt, self.uv_fmt, self.dw_fmt
        sq = [Product(a, b, sa, sb, count=4, name=f"D^2 piece {i}{j}") for i, j, a, b, sa, sb in self.square_pieces()]
        return (Product(du.width, w.width, True, True, count=4, split=split, name="U_x W"),
                Product(u.width, dw.width, True, True, count=4, split=split, name="U W_x"), *sq)

    def memories(self) -> tuple:
        """The ``log2`` table, read for ``Q`` and for ``W`` (two read ports)."""
        return (Memory(1 << self.table_bits, self.table_word_bits, read_ports=2, name="log2 table"),)

    def _compute(self, cols):
        return list(self.levels(*cols))

    def hard_cases(self) -> np.ndarray:
        """Grazing (``W`` small, ``W_x`` large), magnified (increments of a few ulps), degenerate (zero
        increments: ``Q = 0``), ``W`` at its far end (one ulp) and at its largest, ``W <= 0``, saturation (the
        largest increments at the smallest ``W``; a minimal footprint beyond the format's bottom), powers of two."""
        u, w, du, dw = self.uv_fmt, self.w_fmt, self.duv_fmt, self.dw_fmt
        one_w = 1 << w.frac_bits
        ws = [min(v, w.max_code) for v in (1, 2, 3, one_w >> 12, one_w >> 1, one_w - 1, one_w, w.max_code)]
        ws += [0, -1, w.min_code]
        uvs = [0, 1, -1, u.max_code, u.min_code, min(3 << u.frac_bits, u.max_code)]
        incs = [(0, 0, 0, 0, 0, 0), (1, 0, 0, 1, 0, 0), (0, 0, 0, 0, 1, 0),          # degenerate, magnified
                (1 << max(0, du.frac_bits - 6), 0, 0, 1 << max(0, du.frac_bits - 6), 0, 0),       # one texel a pixel
                (du.max_code, du.min_code, du.min_code, du.max_code, dw.max_code, dw.min_code),   # saturation
                (3, -2, 5, 7, dw.max_code, -dw.max_code),                              # grazing: W_x large
                (1 << max(0, du.frac_bits - 10), 1 << max(0, du.frac_bits - 4), 0, 1, 0,
                 -(1 << max(0, dw.frac_bits - 3)))]
        rows = [[a, b, ww, *inc] for ww in ws for a in uvs for b in uvs[::2] for inc in incs]
        return np.array(rows, dtype=np.int64)

    def _info(self) -> dict:
        return {"error_bound_levels": self.error_bound(), "table_error_levels": self.table_error(),
                "d_bits": self.d_bits, "q_bits": self.q_bits, "products_per_pixel": self.products_per_pixel()}

    def _log2(self, x):
        """``log2 x`` in ``table_frac`` fraction bits for positive integers ``x`` (object array)."""
        t = self.table_bits
        p = _bitlen(x) - 1
        idx = np.array([(v >> (q - t)) if q >= t else (v << (t - q)) for v, q in zip(x, p)], dtype=object)
        idx = np.array([int(i) & ((1 << t) - 1) for i in idx], dtype=np.int64)
        return np.array([int(q) << self.table_frac for q in p], dtype=object) + self.table()[idx].astype(object)

    def compute(self, *cols):
        """``compute(U, V, W, Ux, Uy, Vx, Vy, Wx, Wy)``: :meth:`levels`; ``compute(codes)`` with one array of
        shape ``(K, 9)`` (the unit contract of :meth:`fxmodel.core.unit.Unit.compute`): codes ``(K, 2)`` of the
        level and the flags, range-checked."""
        if len(cols) == 1:
            return Unit.compute(self, cols[0])
        return self.levels(*cols)

    def levels(self, U, V, W, Ux, Uy, Vx, Vy, Wx, Wy):
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


LodParams.PRESETS = {
    "default": LodParams(),
    # a 40 x 24 map (the size a constant shift-and-add product), six fraction bits, a negative bias
    "npot": LodParams(size=(40, 24), table_bits=7, lod_frac=6, bias=-13, guard=3),
}
register(LodParams)
