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
The exact ``D`` terms need eight wide products and four squares of ~60-bit numbers (72 multiplier blocks at the
grazing floor's formats); this unit narrows both to one block each, by block floating point:

1. **Operands to ``op_bits``.** Four groups share one shift each: ``(U, V)``, ``(W)``, ``(U_x, U_y, V_x, V_y)``,
   ``(W_x, W_y)``. A group's shift ``s = max(0, L - (op_bits - 1))``, ``L`` the largest bit length of its codes'
   magnitudes (``x`` or ``~x``), so every shifted code fits ``op_bits`` signed bits; the shift is arithmetic
   (``Rounding.FLOOR``: truncation toward minus infinity, an error below ``2^s <= 2^(2 - op_bits)`` times the
   group's largest magnitude; no overflow: the shifted codes fit by the choice of ``s``).
2. **Eight products** ``U_x W``, ``U W_x``, ... of the shifted operands (one block each), exact, and the four
   differences ``D = (U_x W << (s_duv + s_w + su)) - (U W_x << (s_uv + s_dw + sw))``, exact, at ``d_frac``
   fraction bits (``|D| <= d_bound``: the shifted-back operands never exceed the formats' largest magnitudes).
3. **``D`` to ``sq_bits``** by one shared shift ``s_D`` (the same rule, ``Rounding.FLOOR``), the four squares
   (one block each), the products by the map's size (constants), ``Q_x, Q_y``; ``Q = max(Q_x, Q_y)`` at scale
   ``2^(2 s_D)``.
4. ``log2`` of ``Q`` and of ``W``'s code by a leading-one detector (the integer part ``p``) and a table of
   ``2^table_bits`` entries indexed by the ``table_bits`` bits after the leading one (``log2`` of the middle of
   each mantissa interval's start, ``guard`` fraction bits beyond ``lod_frac``: a power of two is exact).
5. ``2 lambda = log2 Q + 2 s_D - 4 log2 W + const``; halved, rounded half-up to ``lod_frac`` fraction bits, plus
   the bias code; saturated to ``Fmt(True, lod_int, lod_frac)``.

Flags: bit 0 ``Q = 0`` (every ``D`` is zero: a footprint of zero size, from constant coordinates, degenerate
derivatives, or an ill-conditioned one, see below; the output is the format's minimum, the most magnified level),
bit 1 ``W <= 0`` (never sent by the front end; output 0), bit 2 saturated.

Error bound (:meth:`LodParams.error_bound`)
-------------------------------------------
Against the exact level of the same codes, on every unsaturated output with ``W > 0``:

``|lambda - lambda_exact| <= 5 e / 2 + 2^-(lod_frac + 1) - log2(1 - eta kappa) - log2(1 - delta)``

* ``e``: the table's error on each ``log2`` (mantissa truncation to ``table_bits`` bits and the table's rounding,
  computed over every entry); it enters as ``e / 2`` from ``Q`` and ``2 e`` from ``W``; the output rounding adds
  half an ulp.
* Step 1: with ``eps = 2^(2 - op_bits)`` the shifted ``U_x`` is ``U_x - r`` with ``0 <= r < eps M_duv``
  (``M_duv`` the group's largest magnitude), likewise for each operand; so ``|Delta(U_x W)| <= r W + |U_x| r_W
  <= 2 eps M_duv W`` (``W > 0``) and ``|Delta(U W_x)| <= (2 eps + eps^2) M_uv M_dw``: each ``D`` is off by at most
  ``eta M1``, ``eta = 2 eps + eps^2``, ``M1 = M_duv W 2^su + M_uv M_dw 2^sw``. ``sqrt Q`` is the largest of two
  Euclidean norms of ``(D_s w_tex, D_t h_tex)``, so it moves by at most ``eta M1 sqrt(w_tex^2 + h_tex^2) =
  eta kappa sqrt Q``, with the **conditioning** ``kappa = M1 sqrt(w_tex^2 + h_tex^2) / sqrt Q`` (exact, of the
  input codes: :meth:`LodParams.conditioning`). ``kappa`` is large only where ``U_x W`` and ``U W_x`` cancel: a
  footprint far smaller than the coordinates' own size times the relative change of ``W`` per pixel. The bound is
  stated for ``kappa <= 2^kappa_bits`` (the documented domain, 1/16 of a level at the defaults); no bound on the
  codes alone exists there, since cancellation depends on the triangle, not on the level: ``bumpmap errors lod``
  counts the vectors beyond it apart (each held to the bound at its own ``kappa``), and ``bumpmap mip`` measures
  the largest ``kappa`` over every fragment of the shipped scenes (``docs/records/mip.json``).
* Step 3: ``s_D`` drops less than ``2^(2 - sq_bits)`` times the largest ``|D|``, and ``sqrt Q >= |D| min(w_tex,
  h_tex)`` for every ``D``: a relative error ``delta = 2^(2 - sq_bits) sqrt(w_tex^2 + h_tex^2) / min(w_tex, h_tex)``.
  The two relative errors multiply; ``-log2(1 - a) >= log2(1 + a)`` bounds both directions.

A computed ``Q = 0`` with a nonzero exact footprint has ``eta kappa >= 1`` (every ``D`` lost): outside the domain.
Hard cases (tested with hypothesis against exact fractions): grazing triangles (``W`` small with large ``W_x``),
magnified (tiny increments), degenerate derivatives (zero increments, ``Q = 0``), the far end of ``W`` (one ulp).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fxmodel.core.cost import DSP_BITS, Memory, Product
from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, Unit, register

__all__ = ["LodParams", "FLAG_ZERO", "FLAG_BAD_W", "FLAG_SATURATED"]

FLAG_ZERO, FLAG_BAD_W, FLAG_SATURATED = 1, 2, 4

_bitlen = np.frompyfunc(int.bit_length, 1, 1)


def _norm_shift(cols, bits: int, n: int) -> np.ndarray:
    """The shared shift of a group of signed codes (object arrays of length ``n``): ``max(0, L - (bits - 1))``,
    ``L`` the largest bit length of ``x`` (``~x`` for a negative ``x``), so every ``x >> shift`` fits ``bits``
    signed bits."""
    m = np.zeros(n, dtype=object)
    for x in cols:
        m = m | np.array([~int(v) if v < 0 else int(v) for v in x], dtype=object)
    return np.array([max(0, int(v).bit_length() - (bits - 1)) for v in m], dtype=object)


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
    op_bits : int
        Signed width of the products' operands after their group's shift (step 1; one multiplier block at 18).
    sq_bits : int
        Signed width of the ``D`` terms squared (step 3).
    kappa_bits : int
        The bound's domain: conditioning ``kappa <= 2^kappa_bits`` (module docstring).
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
    op_bits: int = 18
    sq_bits: int = 18
    kappa_bits: int = 9

    def __post_init__(self):
        for name in ("uv_fmt", "w_fmt", "duv_fmt", "dw_fmt"):
            f = getattr(self, name)
            if not isinstance(f, Fmt) or not f.signed:
                raise ValueError(f"{name}={f!r}: must be a signed Fmt")
        if (len(self.size) != 2 or any(not isinstance(n, int) or isinstance(n, bool) or n < 1 for n in self.size)):
            raise ValueError(f"size={self.size!r}: must be two positive ints (width, height)")
        for name, lo, hi in (("table_bits", 1, 12), ("lod_frac", 0, 12), ("lod_int", 2, 10), ("guard", 0, 8),
                             ("op_bits", 4, DSP_BITS), ("sq_bits", 4, DSP_BITS), ("kappa_bits", 0, 20)):
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

    @property
    def eta(self) -> float:
        """Relative error of a ``D`` term against ``M1`` from the operands' shifts (module docstring)."""
        eps = 2.0 ** (2 - self.op_bits)
        return 2 * eps + eps * eps

    @property
    def delta(self) -> float:
        """Relative error of ``sqrt Q`` from the shift of the ``D`` terms (module docstring)."""
        w, h = self.size
        return 2.0 ** (2 - self.sq_bits) * math.hypot(w, h) / min(w, h)

    def error_bound(self, kappa: float | None = None) -> float:
        """Bound on ``|lambda - lambda_exact|`` in levels on the inputs of conditioning at most ``kappa`` (default
        ``2^kappa_bits``, the documented domain; module docstring)."""
        kappa = 2.0 ** self.kappa_bits if kappa is None else kappa
        if self.eta * kappa >= 1:
            return math.inf
        return (2.5 * self.table_error() + 2.0 ** -(self.lod_frac + 1) - math.log2(1 - self.eta * kappa)
                - math.log2(1 - self.delta))

    def conditioning(self, U, V, W, Ux, Uy, Vx, Vy, Wx, Wy) -> float:
        """``kappa = M1 sqrt(w^2 + h^2) / sqrt Q`` of one pixel's codes, exact but for the final float (``inf`` for
        ``Q = 0``; module docstring)."""
        su, sw = self._scales()
        m1 = ((max(abs(int(v)) for v in (Ux, Uy, Vx, Vy)) * int(W)) << su) + \
            ((max(abs(int(U)), abs(int(V))) * max(abs(int(Wx)), abs(int(Wy)))) << sw)
        d = {k: ((int(a) * int(W)) << su) - ((int(b) * int(c)) << sw)
             for k, a, b, c in (("sx", Ux, U, Wx), ("tx", Vx, V, Wx), ("sy", Uy, U, Wy), ("ty", Vy, V, Wy))}
        w, h = self.size
        q = max((d["sx"] * w) ** 2 + (d["tx"] * h) ** 2, (d["sy"] * w) ** 2 + (d["ty"] * h) ** 2)
        if q == 0:
            return math.inf
        return math.sqrt(Fraction(m1 * m1 * (w * w + h * h), q))

    def products_per_pixel(self) -> int:
        """Products per pixel: eight for the ``D`` terms, four by the size (shifts for a power of two; the RTL
        makes the others constant shift-and-add products, no multiplier block), four squares."""
        return 8 + sum(2 for n in self.size if n & (n - 1)) + 4

    def _scales(self) -> tuple[int, int]:
        """``(su, sw)``: the left shifts of ``U_x W`` and ``U W_x`` to ``d_frac`` fraction bits."""
        F = self.d_frac
        return (F - self.duv_fmt.frac_bits - self.w_fmt.frac_bits, F - self.uv_fmt.frac_bits - self.dw_fmt.frac_bits)

    #: The operand groups of step 1 (input names): each shares one shift.
    GROUPS = (("U", "V"), ("W",), ("Ux", "Uy", "Vx", "Vy"), ("Wx", "Wy"))

    def group_fmts(self) -> tuple:
        """The format of each of :data:`GROUPS`."""
        return (self.uv_fmt, self.w_fmt, self.duv_fmt, self.dw_fmt)

    def max_shift(self, width: int, bits: int) -> int:
        """The largest group shift of ``width``-bit signed codes narrowed to ``bits`` (0 if they fit)."""
        return max(0, width - bits)

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
    def latency(self) -> int:
        """Stages (``rtl/lod.py``): the groups' leading-zero counts | the operands' shifts | the eight products |
        the products shifted into place | ``D`` | ``D``'s leading-zero count | ``D``'s shift | the squares |
        ``Q_x, Q_y`` | ``Q_x > Q_y`` | ``Q`` | leading-zero counts | normalizing shifts | table read |
        ``2 lambda`` | round, bias, saturate."""
        return 16

    @property
    def d_bound(self) -> int:
        """Largest ``|D|`` code (at ``d_frac`` fraction bits) the input formats allow (also after the operands'
        shifts: a shifted code times ``2^s`` lies between the code and the format's end)."""
        su, sw = self._scales()
        big = lambda f: -f.min_code                                     # noqa: E731 -- the largest magnitude
        return (big(self.duv_fmt) * big(self.w_fmt) << su) + (big(self.uv_fmt) * big(self.dw_fmt) << sw)

    @property
    def d_bits(self) -> int:
        """Width of the signed ``D`` registers: ``|D| <= d_bound`` (a proven narrowing)."""
        return self.d_bound.bit_length() + 1

    def op_width(self, fmt: Fmt) -> int:
        """Signed width of a group's operands after its shift."""
        return min(fmt.width, self.op_bits)

    @property
    def sq_width(self) -> int:
        """Signed width of the shifted ``D`` terms."""
        return min(self.d_bits, self.sq_bits)

    @property
    def q_bits(self) -> int:
        """Width of the unsigned ``Q`` register: ``Q <= 2^(2 (sq_width - 1)) (w_tex^2 + h_tex^2)`` (proven)."""
        return ((1 << 2 * (self.sq_width - 1)) * (self.size[0] ** 2 + self.size[1] ** 2)).bit_length()

    @property
    def table_word_bits(self) -> int:
        """Bits of a ``log2`` table entry (the largest entry's)."""
        return max(1, int(self.table().max()).bit_length())

    def products(self) -> tuple:
        """Eight ``D`` products of the shifted operands and four squares of the shifted ``D`` (one block each at
        ``op_bits = sq_bits = 18``); the map's size is a constant (shifts, or shift-and-add:
        ``rtl.fixed.const_mul``)."""
        du, w, u, dw = (self.op_width(f) for f in (self.duv_fmt, self.w_fmt, self.uv_fmt, self.dw_fmt))
        q = self.sq_width
        return (Product(du, w, True, True, count=4, name="U_x W"), Product(u, dw, True, True, count=4, name="U W_x"),
                Product(q, q, True, True, count=4, square=True, name="D^2"))

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
                "kappa_domain": 2 ** self.kappa_bits, "eta": self.eta, "delta": self.delta,
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
        su, sw = self._scales()
        sx, sy = self.size
        named = dict(zip(("U", "V", "W", "Ux", "Uy", "Vx", "Vy", "Wx", "Wy"), c))
        n = len(W)
        shifts, op = {}, {}
        for group in self.GROUPS:                                         # step 1: each group's shift, FLOOR
            s = _norm_shift([named[k] for k in group], self.op_bits, n)
            for k in group:
                shifts[k] = s
                op[k] = np.array([int(v) >> int(t) for v, t in zip(named[k], s)], dtype=object)

        def d(num_inc, num, w_inc):                                       # step 2: exact products and D
            ea = shifts[num_inc] + shifts["W"] + su
            eb = shifts[num] + shifts[w_inc] + sw
            return np.array([(int(a) * int(b) << int(x)) - (int(p) * int(r) << int(y)) for a, b, x, p, r, y in
                             zip(op[num_inc], op["W"], ea, op[num], op[w_inc], eb)], dtype=object)

        ds = [d("Ux", "U", "Wx"), d("Vx", "V", "Wx"), d("Uy", "U", "Wy"), d("Vy", "V", "Wy")]
        s_d = _norm_shift(ds, self.sq_bits, n)                            # step 3: one shift for the four, FLOOR
        sx_, tx_, sy_, ty_ = (np.array([int(v) >> int(t) for v, t in zip(x, s_d)], dtype=object) for x in ds)
        qx = (sx_ * sx) ** 2 + (tx_ * sy) ** 2
        qy = (sy_ * sx) ** 2 + (ty_ * sy) ** 2
        q = np.maximum(qx, qy)
        flags = np.zeros(len(q), np.int64)
        zero, bad = q == 0, W <= 0
        flags[zero.astype(bool)] |= FLAG_ZERO
        flags[bad.astype(bool)] |= FLAG_BAD_W
        ok = ~(zero | bad).astype(bool)
        out = np.zeros(len(q), dtype=object)
        if ok.any():
            g = self.table_frac
            const = (4 * self.w_fmt.frac_bits - 2 * self.d_frac) << g                    # 2 log2 of the scales
            two = (self._log2(q[ok]) + (2 * s_d[ok] << g) - 4 * self._log2(W[ok])
                   + const)                                                     # 2 lambda, g fraction bits
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
