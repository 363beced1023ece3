r"""Reciprocal unit 1/w by table lookup and Taylor series (paper, section 4.1); the divider built on it is
:mod:`fxmodel.units.divide`.

Algorithm (bit-exact; ``rtl/recip.py`` builds the same datapath from the same :class:`RecipParams`)
--------------------------------------------------------------------------------------------------------
Input ``w`` is a signed fixed-point code of ``n = in_fmt.width`` bits with ``F = in_fmt.frac_bits`` fraction bits.

1. **Sign and magnitude.** ``X = |W|`` (two's complement negation; the most negative code gives ``2**(n-1)``,
   which an ``n``-bit unsigned word holds). ``W = 0`` raises ``dbz``.
2. **Normalization** by a leading-zero count ``s`` of ``X`` in ``n`` bits: ``x = (X << s) / 2**n`` lies in
   ``[0.5, 1)`` and ``1/|w| = (1/x) * 2**e`` with ``e = F - bitlen(X)``.
3. **Table.** The top ``m`` bits of ``x`` (the leading 1 and ``m - 1`` index bits) select ``B ~ 1/w_h`` from a table
   of ``2**(m-1)`` words of ``b`` significant bits (``u1.(b-1)``; the leading 1 is not stored, so the ROM holds
   ``b - 1`` bits a word). ``w_h`` is those ``m`` bits followed by ones, so ``d = w_h - x >= 0`` is the bitwise
   complement of the low ``n - m`` bits: no subtractor.

   *The paper's sign error.* The paper writes ``dw = w - w_h <= 0`` with an all-plus series; that expansion is
   wrong (about 1.5 % error at 128 entries). About ``w_h`` with ``d = w_h - w >= 0``,
   ``1/w = B0 (1 + B0 d + (B0 d)**2 + ...)`` with ``B0 = 1/w_h``: every omitted term is positive, so the
   truncation error is one-sided (the series falls short).
4. **Taylor terms in Horner form.** ``d`` is truncated to ``fd = fq + 1`` fraction bits, ``q = B d`` to
   ``fq = p - 1 + guard`` bits; ``g_1 = 0``, ``g_2 = q``, ``g_(k+1) = q + trunc(q g_k)`` (this is
   ``h_(k+1) = 1 + q h_k`` with the constant 1 kept implicit, so every multiplier sees only small operands);
   ``t`` terms need ``t`` multipliers (``t >= 2``): ``q``, ``t - 2`` Horner steps and ``B (1 + g_t)``.
5. **Result.** ``r = B + B g_t`` rounded half-up to ``p - 1`` fraction bits. A carry out of the binade
   (``r >= 2``; the exact value there is at most 2) and the exact case ``x = 0.5`` give the mantissa 1.0 and
   ``e + 1``, so every output mantissa is normalized to ``[1, 2)`` and powers of two are exact. (Normalized
   whenever ``error_bound_ulp < 1``: then ``r > 1/x - ulp/2 > 1 - ulp/2``. A sloppier configuration of a
   ``midpoint`` mode may return ``1 - ulp`` just below a binade; its value is still within the bound.) The sign is
   restored by negating the mantissa.

Table modes (``table``, :data:`TABLE_MODES`)
--------------------------------------------
The paper expands about the top ``w_h`` of each interval with ``B = round(1/w_h)`` (``round``). Two better
choices, both free in hardware:

* ``minimax``: same expansion, but each word is the ``b``-bit value minimising the interval's worst error
  ``|T(B, d) - 1/x|`` (``T`` the truncated series), instead of rounding ``1/w_h``. Because the centring bias
  (``center``) already shifts the whole error band for free, this buys only the table's quantization slack
  (<= 0.05 bits; about 1 bit over ``round`` with ``center=False``).
* ``midpoint``: expand about the interval's centre ``c = w_h - 2**-(m+1)`` with ``B = round(1/c)``:
  ``d = c - x`` is *signed*, ``[-2**-(m+1), 2**-(m+1))``. In hardware it is the same complemented low bits with
  the top one inverted, read as two's complement: no subtractor, same widths; the products become signed
  (``u x s``, still one MULT18X18D up to 18 bits). The series error ``-B0 (B0 d)**t / (1 - B0 d)`` shrinks by
  ``2**t`` (``|d|`` halves): ``t`` bits for even ``t``, ``t - 1`` for odd ``t`` (where the error becomes
  two-sided, which the bias already achieved), nothing for ``t = 1``. ``midpoint-minimax`` also picks each
  word by minimax.

``bumpmap tables`` prints the correct bits of every mode per table size and term count.

Outputs: ``mant`` (``s2.(p-1)``, magnitude in ``[1, 2)``), ``exp`` (integer, ``[F - n, F]``) and ``dbz``;
``1/w = mant * 2**exp``. ``w = 0`` gives the largest magnitude, ``mant = 2 - 2**-(p-1)``, ``exp = F``, ``dbz = 1``.

Error bound: ``RecipParams.error_bound_ulp`` (ulps of the result), proved from the actual table with exact
fractions in :mod:`fxmodel.units.recip_bound` (its docstring derives every term).

Hard cases (each has a test): ``w = 0.5``; ``w = 1 - ulp``; every table boundary and one ulp either side, in
every binade, both signs; for the ``midpoint`` modes also every interval centre (``d = 0``) and one ulp either
side; the smallest and largest ``|w|``; the most negative code; zero.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

import numpy as np

from fxmodel.core.cost import DSP_BITS, Memory, Product
from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow, saturate, shift_round
from fxmodel.core.unit import Port, Unit, register, require
from fxmodel.units import recip_bound

from .recip_tables import minimax_codes

__all__ = ["RecipParams", "TABLE_MODES"]

#: How table entries are chosen and where the series is expanded (module docstring, "Table modes"):
#: ``round`` is the paper's ``round(1/w_h)`` about the top ``w_h`` of each interval; ``minimax`` expands about
#: ``w_h`` too but picks each word to minimise the interval's worst approximation error; ``midpoint`` expands
#: about the interval's centre ``c`` (signed ``d``) with ``round(1/c)``; ``midpoint-minimax`` combines both.
TABLE_MODES = ("round", "minimax", "midpoint", "midpoint-minimax")


@dataclass(frozen=True)
class RecipParams(Unit):
    """Parameters of the reciprocal unit.

    Parameters
    ----------
    in_fmt : Fmt
        Signed format of the input ``w`` (``n = in_fmt.width`` bits).
    m : int
        Bits of ``w_h`` that index the table, the leading 1 included: ``2**(m-1)`` entries. ``2 <= m < n``.
    b : int
        Significant bits of each table word ``B`` (``u1.(b-1)``, the ROM stores ``b - 1``). ``b >= p``.
    t : int
        Taylor terms, 1 to 4 (the paper uses 3).
    p : int
        Significant bits of the result mantissa (``s2.(p-1)`` output).
    guard : int
        Extra fraction bits kept in the Horner datapath beyond the output's ``p - 1``.
    table : str
        How table entries are chosen (see :data:`TABLE_MODES`).
    center : bool
        Add the constant :attr:`bias_code` before the final rounding so that the one-sided (downward) Taylor and
        truncation errors are centred on zero. Costs nothing in hardware; the paper has no such term.
    """

    NAME = "recip"

    in_fmt: Fmt = Fmt(True, 8, 16)
    m: int = 7
    b: int = 19
    t: int = 3
    p: int = 17
    guard: int = 2
    table: str = "round"
    center: bool = True

    def __post_init__(self):
        require(isinstance(self.in_fmt, Fmt), "in_fmt", self.in_fmt, "must be an Fmt")
        require(self.in_fmt.signed, "in_fmt", str(self.in_fmt), "the input must be a signed format")
        for name in ("m", "b", "t", "p", "guard"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool):
                raise TypeError(f"{name} must be an int, not {value!r}")
        n = self.in_fmt.width
        require(n <= 48, "in_fmt", str(self.in_fmt), "input width above 48 bits is not supported")
        require(self.m >= 2, "m", self.m, "the table needs at least 2 entries (m >= 2)")
        require(self.m < n, "m", self.m, f"must be smaller than the input width n={n}")
        require(self.m <= 16, "m", self.m, "tables above 2**15 entries are not supported")
        require(1 <= self.t <= 4, "t", self.t, "Taylor terms must be 1 to 4")
        require(self.p >= 2, "p", self.p, "the result needs at least 2 significant bits")
        require(self.guard >= 0, "guard", self.guard, "must be >= 0")
        require(self.b >= self.p, "b", self.b,
                 f"too small for the output: the table word needs at least p={self.p} significant bits")
        require(self.b <= 40, "b", self.b, "table words above 40 bits are not supported")
        require(isinstance(self.center, bool), "center", self.center, "must be a bool")
        require(self.table in TABLE_MODES, "table", self.table, f"must be one of {TABLE_MODES}")
        if self.t >= 2:
            require(self.fd > self.m, "m", self.m,
                     f"leaves no bits of d at fd={self.fd} fraction bits (raise p or guard, or use t=1)")
        for what, bits in self.product_widths().items():
            require(bits <= INT64_SAFE_BITS, "b", self.b, f"product {what} would need {bits} bits (> 62)")

    # -- formats (the RTL reads these) --------------------------------------------------------------------
    @cached_property
    def n(self) -> int:
        return self.in_fmt.width

    @cached_property
    def fo(self) -> int:
        """Fraction bits of the output mantissa."""
        return self.p - 1

    @cached_property
    def fq(self) -> int:
        """Fraction bits of ``q`` and of the Horner terms ``g``."""
        return self.fo + self.guard

    @cached_property
    def fd(self) -> int:
        """Fraction bits of ``d`` kept for the first product (``n`` if ``d`` has no more)."""
        return min(self.fq + 1, self.n)

    @cached_property
    def entries(self) -> int:
        return 1 << (self.m - 1)

    @cached_property
    def b_fmt(self) -> Fmt:
        """Table word ``B`` in ``[1, 2)``."""
        return Fmt(False, 1, self.b - 1)

    @cached_property
    def rom_bits(self) -> int:
        """Stored bits per table word (the leading 1 is implicit)."""
        return self.b - 1

    @cached_property
    def signed_d(self) -> bool:
        """``d`` is signed: the series is expanded about the interval's centre (``midpoint`` modes)."""
        return self.table.startswith("midpoint")

    @cached_property
    def d_fmt(self) -> Fmt:
        """``0 <= d < 2**-m``: only the bits below the table index remain. Signed modes: ``d - 2**-(m+1)`` in
        ``[-2**-(m+1), 2**-(m+1))``, the same bits with the top one inverted (same width)."""
        return Fmt(self.signed_d, -self.m, self.fd)

    @cached_property
    def q_fmt(self) -> Fmt:
        """``q = B d < 2 * 2**-m`` (proof: ``B < 2``, ``d < 2**-m``); signed modes ``|q| < 2 * 2**-(m+1)``, and
        flooring stays ``>= -2**-m``."""
        return Fmt(self.signed_d, 1 - self.m, self.fq)

    @cached_property
    def g_fmt(self) -> Fmt:
        """``g = q + q**2 + ... < q / (1 - q) <= 2 q < 2**(2-m)`` (``q <= 1/2`` as ``m >= 2``); signed modes
        ``|g| <= |q| / (1 - |q|) < 2**(1-m)`` (the floor of each step adds less than an ulp below)."""
        return Fmt(self.signed_d, 2 - self.m, self.fq)

    @cached_property
    def bq(self) -> int:
        """Significant bits of ``B`` fed to the small products ``B d`` and ``B g`` (``B`` truncated)."""
        return min(self.b, self.fq - self.m + 3)

    @cached_property
    def bg_fmt(self) -> Fmt:
        """``B g < 2 * 2**(2-m)``; signed modes ``|B g| < 2 * 2**(1-m)``."""
        return Fmt(self.signed_d, 3 - self.m, self.fq)

    @cached_property
    def fr(self) -> int:
        """Fraction bits of the exact sum ``B + B g + bias`` before the final rounding."""
        return max(self.b - 1, self.fq) if self.t >= 2 else self.b - 1

    @cached_property
    def mant_fmt(self) -> Fmt:
        return Fmt(True, 2, self.fo)

    @cached_property
    def exp_fmt(self) -> Fmt:
        F = self.in_fmt.frac_bits
        return Fmt.integer(F - self.n, F)

    def product_widths(self) -> dict:
        """Bit widths of each exact product of the datapath (checked against int64 at construction)."""
        return {
            "B*d": self.bq + max(self.fd - self.m, 0),
            "q*g": self.q_fmt.width + self.g_fmt.width,
            "B*g": self.bq + self.g_fmt.width,
            "B+Bg": 2 + self.fr,
        }

    #: Widest operand of one ECP5 multiplier block (MULT18X18D, :data:`fxmodel.core.cost.DSP_BITS`); wider products are
    #: split (:attr:`split_products`).
    DSP_BITS = DSP_BITS

    def products(self) -> tuple:
        """The multipliers of the datapath in order (``t >= 2``), each split into registered partial products
        when an operand is wider than :attr:`DSP_BITS` (:class:`fxmodel.core.cost.Product`): ``B*d`` (``B``
        truncated to :attr:`bq` bits, unsigned), the Horner steps (``q*q`` first, then ``q*g``) and ``B*g``
        (``g = q`` when ``t = 2``)."""
        if self.t < 2:
            return ()
        q, g = self.q_fmt, self.g_fmt
        steps = [Product(q.width, q.width, q.signed, q.signed, split=True, square=True, name="q*q")] + \
            [Product(q.width, g.width, q.signed, g.signed, split=True, name="q*g")] * (self.t - 3)
        last = g if self.t > 2 else q
        return (Product(self.bq, self.d_fmt.width, False, self.d_fmt.signed, split=True, name="B*d"),
                *steps[:self.t - 2],
                Product(self.bq, last.width, False, last.signed, split=True, name="B*g"))

    def memories(self) -> tuple:
        """The table ROM: :attr:`entries` words of :attr:`rom_bits` (the leading 1 is implicit)."""
        return (Memory(self.entries, self.rom_bits, name="table 1/w"),)

    def product_operands(self) -> list[tuple[str, int, int]]:
        """``(name, width, width)`` of the operands of every multiplier in datapath order (:meth:`products`)."""
        return [(p.name, p.a_bits, p.b_bits) for p in self.products()]

    def times_product(self, width: int, name: str = "x*mant", count: int = 1) -> Product:
        """``x * mant`` for a signed ``width``-bit ``x`` (the users of ``1/w``), split like the unit's own
        products (``rtl.recip.times_reciprocal``)."""
        return Product(width, self.mant_fmt.width, True, self.mant_fmt.signed, count=count, split=True, name=name)

    @property
    def split_products(self) -> int:
        """Multipliers with an operand wider than :attr:`DSP_BITS`. The RTL cuts those operands into 17-bit
        pieces, registers the partial products (one 18x18 block each) and sums them in the next stage: one extra
        pipeline stage each (``rtl/recip.py``)."""
        return sum(max(a, b) > self.DSP_BITS for _, a, b in self.product_operands())

    @property
    def settled_products(self) -> int:
        """Split multipliers whose sum is another multiplier's operand: ``B*d`` (its ``q`` feeds the Horner steps,
        or ``B*g`` when ``t = 2``), when split. The RTL registers its partial products twice (in the multiplier
        blocks, then in the fabric near their sum), one more stage: the routed MIP engine's slowest path ran from
        the blocks' outputs through the sum's carry chain into the next blocks' input registers
        (``docs/fpga/placement.json``). The other products' sums go into the fabric."""
        return int(self.t >= 2 and max(self.product_operands()[0][1:]) > self.DSP_BITS)

    def times_split(self, width: int) -> int:
        """Extra stages of ``x * mant`` for a ``width``-bit ``x`` (the users of ``1/w``: divider, perspective
        coordinates, cube address): 2 when an operand is wider than :attr:`DSP_BITS` (the RTL registers the
        partial products twice, in the multiplier blocks and then in the fabric near their sum, then sums them;
        ``rtl.recip.times_reciprocal``), else 0."""
        return 2 * int(max(width, self.mant_fmt.width) > self.DSP_BITS)

    @property
    def multipliers(self) -> int:
        return 0 if self.t == 1 else self.t

    @property
    def table_bits(self) -> int:
        return self.entries * self.rom_bits

    # -- using the result: x * (1/w) ----------------------------------------------------------------------
    def shift_plan(self, prod_frac: int, out_frac: int) -> tuple[int, int]:
        """``(pre_shift, shift_min)`` to turn ``prod * 2**exp`` (``prod = x * mant`` with ``prod_frac``
        fraction bits) into ``out_frac`` fraction bits: shift ``prod`` left by ``pre_shift`` (so that every
        data-dependent shift is a right shift), then right by ``shift_min + pre_shift + (exp_max - exp)``."""
        shift_min = prod_frac - out_frac - self.exp_fmt.max_code
        return max(0, -shift_min), shift_min

    def scale(self, prod, prod_frac: int, exp, out_frac: int, rounding: Rounding):
        """``prod * 2**exp`` rounded to ``out_frac`` fraction bits: the barrel shifter after ``x * mant``.

        Shared by every user of the reciprocal (divider, cube address, perspective texture coordinates);
        ``rtl.recip.scale`` is its hardware twin."""
        pre, shift_min = self.shift_plan(prod_frac, out_frac)
        return shift_round(prod << pre, shift_min + pre + (self.exp_fmt.max_code - exp), rounding)

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        return (Port("w", self.in_fmt, "divisor"),)

    @property
    def outputs(self):
        return (Port("mant", self.mant_fmt, "signed mantissa of 1/w, magnitude in [1, 2)"),
                Port("exp", self.exp_fmt, "1/w = mant * 2**exp"),
                Port("dbz", Fmt(False, 1, 0), "w was zero"))

    @property
    def latency(self) -> int:
        """Stages: magnitude | leading-zero count | normalizing shift | table read | [q | t-2 Horner steps of two
        stages each (product, then add) | B*g] | sum and round | renormalize and sign: 6 for ``t = 1``,
        ``2 t + 4`` for ``t >= 2``, plus one stage for each of the :attr:`split_products` (partial products) and
        one for each of the :attr:`settled_products`.

        Each stage holds at most one carry chain or one 18x18 product (``rtl/recip.py``; ECP5 timing from
        ``bumpmap fpga``)."""
        return 6 if self.t == 1 else 2 * self.t + 4 + self.split_products + self.settled_products

    # -- the table ----------------------------------------------------------------------------------------
    @cached_property
    def centers(self) -> tuple[int, ...]:
        """Expansion point of each interval times ``2**n`` (exact integers): ``w_h`` (the ``m`` index bits
        followed by ones), or for the signed (``midpoint``) modes ``c = w_h - 2**-(m+1)``."""
        n, m = self.n, self.m
        off = (1 << (n - m - 1)) if self.signed_d else 0
        return tuple(((((1 << (m - 1)) + i + 1) << (n - m)) - 1 - off) for i in range(self.entries))

    @cached_property
    def d_range(self) -> tuple[Fraction, Fraction]:
        """Exact ``(lo, hi)`` of ``d`` (before its truncation to ``fd`` bits) over every input of every interval:
        ``[0, 2**-m - 2**-n]``, or ``[-2**-(m+1), 2**-(m+1) - 2**-n]`` for the signed modes."""
        off = Fraction(1, 1 << (self.m + 1)) if self.signed_d else Fraction(0)
        return -off, Fraction(1, 1 << self.m) - Fraction(1, 1 << self.n) - off

    @cached_property
    def table_codes(self) -> np.ndarray:
        """The ``2**(m-1)`` table words as ``b_fmt`` codes (hidden bit included), chosen by :attr:`table`."""
        n, fb = self.n, self.b - 1
        if self.table.endswith("minimax"):
            codes = minimax_codes(self)
        else:
            # B = round_half_up(2**n / center) at fb fraction bits
            codes = [((1 << (n + fb + 1)) // c + 1) // 2 for c in self.centers]
        codes, _ = narrow(np.asarray(codes, dtype=np.int64), fb, self.b_fmt, Rounding.TRUNC, Overflow.SATURATE)
        return codes

    def series(self, B, d):
        """The truncated series ``T(B, d) = B (1 + B d + ... + (B d)**(t-1))`` the datapath approximates (exact
        for ``Fraction`` arguments, elementwise for float arrays)."""
        u = B * d
        acc = 1
        for _ in range(self.t - 1):
            acc = 1 + u * acc
        return B * acc

    def with_table(self, codes, *, keep_bias: bool = True) -> RecipParams:
        """A copy whose table words are ``codes`` (``b_fmt`` codes, hidden bit included) instead of the ones
        :attr:`table` chooses: fault injection for the co-simulation tests (a wrong ROM word must be caught).
        Every value cached from the table (the model's per-entry constants, its memoized datapath) is dropped and
        rebuilt from ``codes``; with ``keep_bias`` the centring constant stays this table's, as a wrong ROM word
        leaves the rest of the datapath unchanged. The copy compares equal to ``self`` (same fields): key build
        caches by something else (the co-simulation's ``variant``)."""
        codes = np.array(codes, dtype=np.int64)
        require(codes.shape == (self.entries,), "codes", codes.shape, f"must hold {self.entries} table words")
        require(bool(np.all((codes >= self.b_fmt.min_code) & (codes <= self.b_fmt.max_code))), "codes",
                f"[{codes.min()}, {codes.max()}]", f"must be codes of {self.b_fmt}")
        bias = self.bias_code
        out = copy.copy(self)
        for name in [k for k in out.__dict__ if isinstance(getattr(type(self), k, None), cached_property)]:
            del out.__dict__[name]
        codes.setflags(write=False)
        out.__dict__["table_codes"] = codes
        if keep_bias:
            out.__dict__["bias_code"] = bias
        return out

    @property
    def rom(self) -> list[int]:
        """ROM contents: each word without its hidden leading 1."""
        return [int(c) - (1 << (self.b - 1)) for c in self.table_codes]

    # -- bit-exact model ----------------------------------------------------------------------------------
    def _compute(self, cols):
        return self._recip_chunk(cols[0])

    def recip_codes(self, w):
        """``(mant, exp, dbz)`` code arrays for input codes ``w`` (used by units built on the reciprocal)."""
        out = self.compute(np.asarray(w, dtype=np.int64)[:, None])
        return out[:, 0], out[:, 1], out[:, 2]

    @cached_property
    def _tables(self):
        """Per-entry constants for the model's inner loop: ``B`` aligned to ``fr`` with the bias added, and
        ``B`` truncated to ``bq`` bits. (The same values the RTL computes from the ROM word.)"""
        B = self.table_codes
        return (B << (self.fr - (self.b - 1))) + self.bias_code, B >> (self.b - self.bq)

    def _core(self, idx, d):
        """The table and Taylor datapath: the unrounded-then-rounded mantissa ``r`` (``fo`` fraction bits) from the
        table index ``idx`` and ``d`` (the complement of the low bits, truncated to ``fd`` fraction bits)."""
        fq, fd, fr = self.fq, self.fd, self.fr
        acc_tab, bh_tab = self._tables
        acc = acc_tab[idx]                                # B (+ bias) at fr fraction bits
        if self.t >= 2:
            Bh = bh_tab[idx]                              # B truncated to bq bits for the small products
            if self.signed_d:                             # about the centre: d - 2**-(m+1), exact (in hardware:
                d = d - (1 << (fd - self.m - 1))          # the top bit of d inverted and read as signed)
            q, _ = narrow(Bh * d, self.bq - 1 + fd, self.q_fmt, Rounding.TRUNC, Overflow.PROVEN, "recip q")
            g = q
            for _ in range(self.t - 2):
                qg, _ = narrow(q * g, 2 * fq, self.g_fmt, Rounding.TRUNC, Overflow.PROVEN, "recip q*g")
                g, _ = saturate(q + qg, self.g_fmt, Overflow.PROVEN, "recip g")
            bg, _ = narrow(Bh * g, self.bq - 1 + fq, self.bg_fmt, Rounding.TRUNC, Overflow.PROVEN, "recip B*g")
            acc = acc + (bg << (fr - fq))
        return shift_round(acc, fr - self.fo, Rounding.HALF_UP)

    @property
    def key_bits(self) -> int:
        """Bits of the normalized word the datapath depends on: the table index and the kept bits of ``d``."""
        return self.m - 1 if self.t == 1 else self.fd - 1

    @cached_property
    def _lut(self):
        """``_core`` over its whole input space, when that has at most 2**22 points (4 M, 16 MB), else None.

        Everything after the normalization depends only on the index and the kept bits of ``d``, so evaluating
        the datapath once on every such pair (every PROVEN check included) and looking results up is the same
        model, bit for bit (tested against the direct evaluation), about 2.5 times faster."""
        kb = self.key_bits
        if kb > 22:
            return None
        key = np.arange(1 << kb, dtype=np.int64)
        if self.t == 1:
            return self._core(key, None).astype(np.int32)
        dbits = self.fd - self.m
        return self._core(key >> dbits, ~key & ((1 << dbits) - 1)).astype(np.int32)

    def _recip_chunk(self, w, direct: bool = False):
        n, fo, fd = self.n, self.fo, self.fd
        F = self.in_fmt.frac_bits
        X = np.abs(w)                                     # |most negative| = 2**(n-1) fits int64
        # normalization: bit length bl = e - 1022 from the biased exponent field e of float64(X) (exact as
        # X < 2**53). X = 0 has e = 0: its shift exceeds 63, which numpy defines to give 0 (the zero flag
        # below overrides the result anyway, like the hardware's).
        e = X.astype(np.float64).view(np.int64) >> 52
        xn = X << ((n + 1022) - e)                        # n-bit word, top bit set
        lut = None if direct else self._lut
        if self.t == 1:
            key = (xn >> (n - self.m)) & (self.entries - 1)
            r = lut[key].astype(np.int64) if lut is not None else self._core(key, None)
        else:
            key = (xn >> (n - fd)) & ((1 << (fd - 1)) - 1)   # index bits, then the bits d complements
            if lut is not None:
                r = lut[key].astype(np.int64)
            else:
                dbits = fd - self.m
                r = self._core(key >> dbits, ~key & ((1 << dbits) - 1))
        one = 1 << fo
        # carry out of [1, 2) (the exact value is at most 2 there) or exactly x = 0.5: mantissa 1.0, exponent + 1
        carry = (r >= 2 * one) | (xn == (1 << (n - 1)))
        r = np.where(carry, one, r)
        exp = ((F + 1022) - e) + carry                    # F - bl (+1 on carry)
        sign = w >> 63                                    # -1 where w < 0, else 0
        r = (r ^ sign) - sign                             # two's-complement negation where w < 0
        zero = X == 0
        if zero.any():
            r[zero] = self.mant_fmt.max_code
            exp[zero] = F
        return r, exp, zero.astype(np.int64)

    # -- hard cases ---------------------------------------------------------------------------------------
    def hard_cases(self) -> np.ndarray:
        n, m, F = self.n, self.m, self.in_fmt.frac_bits
        fmt = self.in_fmt
        codes = {0, 1, -1, fmt.max_code, fmt.min_code, fmt.min_code + 1, fmt.max_code - 1}
        if F >= 1:
            codes |= {1 << (F - 1), (1 << F) - 1, 1 << F}            # 0.5, 1 - ulp, 1.0
        for k in range(1, n):                                         # every binade: X in [2**(k-1), 2**k)
            codes |= {(1 << (k - 1)), (1 << k) - 1}
            if k >= m:
                for i in range(self.entries):
                    base = ((1 << (m - 1)) + i) << (k - m)
                    codes |= {base - 1, base, base + 1}
                    if self.signed_d and k > m:                      # the centre c, where d = 0
                        mid = base + (1 << (k - m - 1)) - 1
                        codes |= {mid - 1, mid, mid + 1}
        codes = np.array(sorted(codes), dtype=np.int64)
        codes = np.concatenate([codes, -codes])
        codes = np.unique(codes[(codes >= fmt.min_code) & (codes <= fmt.max_code)])
        return codes[:, None]

    # -- documented error bound (derived and computed in fxmodel/units/recip_bound.py) --------------------------------
    @cached_property
    def _raw_error(self) -> tuple[Fraction, Fraction]:
        """``(L, H)``: the exact sum ``B + B g`` (before bias and final rounding) minus ``1/x`` lies in
        ``[L, H]`` for every input (:func:`fxmodel.units.recip_bound.raw_error`)."""
        return recip_bound.raw_error(self)

    @cached_property
    def approx_error(self) -> tuple[Fraction, Fraction]:
        """Rigorous ``(min, max)`` over all intervals of the approximation error ``T(B, d) - 1/x`` of the table
        and the truncated series alone (exact ``d``, no datapath rounding, no bias), from the actual table
        (:func:`fxmodel.units.recip_bound.approx_error`)."""
        return recip_bound.approx_error(self)

    @property
    def approx_bits(self) -> float:
        """Correct bits of the table and series alone: ``-log2`` of the half-width of :attr:`approx_error` (the
        worst ``|error|`` of the mantissa in ``[1, 2)`` once a constant centres it)."""
        lo, hi = self.approx_error
        return -math.log2(float(hi - lo) / 2)

    @cached_property
    def bias_code(self) -> int:
        """Constant added before the final rounding (``fr`` fraction bits) that centres the one-sided errors;
        free in hardware (it merges with the rounding constant). Zero unless ``center``."""
        if not self.center:
            return 0
        lo, hi = self._raw_error
        return int(round(-(lo + hi) / 2 * (1 << self.fr)))

    @cached_property
    def error_terms(self) -> dict:
        """Worst error below and above the exact value, in result ulps (exact fractions)."""
        lo, hi = self._raw_error
        bias = Fraction(self.bias_code, 1 << self.fr)
        ulp = Fraction(1, 1 << self.fo)
        return {"below_ulp": -(lo + bias) / ulp + Fraction(1, 2),
                "above_ulp": (hi + bias) / ulp + Fraction(1, 2)}

    @property
    def error_bound_ulp(self) -> Fraction:
        """Documented bound: ``|result - 1/w| <= error_bound_ulp`` ulps of the result, for every input."""
        terms = self.error_terms
        return max(terms["below_ulp"], terms["above_ulp"])

    def _info(self):
        return {
            "precision_bits": self.p,
            "table_entries": self.entries,
            "table_bits": self.table_bits,
            "terms": self.t,
            "multipliers": self.multipliers,
            "max_error_ulp": float(self.error_bound_ulp),
            "faithful_by_bound": bool(self.error_bound_ulp < 1),
        }


RecipParams.PRESETS = {
    # 24-bit input, 17-bit faithful result from 64 entries and 3 terms; every product within 18x18.
    "default": RecipParams(in_fmt=Fmt(True, 8, 16), m=7, b=20, t=3, p=17, guard=5),
    # 16-bit input, 12-bit result.
    "small": RecipParams(in_fmt=Fmt(True, 4, 12), m=6, b=14, t=3, p=12, guard=4),
    # 25-bit input (sign and a 24-bit magnitude, the default's 16 fraction bits), 24-bit faithful result from
    # 64 entries of 26 stored bits (1664 ROM bits) and 4 terms expanded about each interval's centre. Faithful
    # by the bound and on every one of the 2**25 inputs (tests/fxmodel/units/test_recip.py, `bumpmap errors recip
    # --preset rcp24`). Products up to 23x22 bits, each split into 18x18 partial products (one more stage each).
    "rcp24": RecipParams(in_fmt=Fmt(True, 9, 16), m=7, b=27, t=4, p=24, guard=4, table="midpoint"),
    # 32-bit input (16 fraction bits), 24-bit faithful result: the smallest table faithful by the bound in a scan
    # of m 5..8, t 3..4, b 25..28, guard 3..5, both midpoint modes (bound 0.890 ulp; m = 6 or t = 3 never reach
    # 1 ulp): 64 entries of 24 stored bits (1536 ROM bits), 4 terms about each interval's centre. The tests check
    # the hard cases and random inputs; all 2**32 inputs, model against exact math and RTL against model, are the
    # long run `make exhaustive-wide` (README, "Long runs on a cluster").
    "rcp32": RecipParams(in_fmt=Fmt(True, 16, 16), m=7, b=25, t=4, p=24, guard=5, table="midpoint"),
}
register(RecipParams)
