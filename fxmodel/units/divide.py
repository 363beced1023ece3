"""Divider ``q = n / d``: ``n`` times the reciprocal unit's ``1/d`` (paper, section 4.1: "division with on chip
ROM"; the cube-map unit's ``minor / major``, :mod:`fxmodel.units.cube`). ``rtl/divide.py`` builds the same datapath
from the same :class:`DivideParams`; the reciprocal is :mod:`fxmodel.units.recip`.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Overflow, Rounding, saturate
from fxmodel.core.unit import Port, Unit, register, require
from fxmodel.units.recip import RecipParams

__all__ = ["DivideParams"]


@dataclass(frozen=True)
class DivideParams(Unit):
    """Parameters of the divider ``q = n / d``: ``n`` times the reciprocal unit's ``1/d``.

    Algorithm: ``(mant, exp, dbz) = recip(d)``; the exact product ``n * mant`` is shifted by the
    data-dependent amount ``exp`` (a barrel shifter), rounded half-up to ``out_fmt`` and saturated with the
    ``ovf`` flag. ``d = 0`` gives ``dbz``, ``q = 0`` for ``n = 0`` and the saturated end of the sign of ``n``
    otherwise (``ovf`` set).

    Error bound: for an unsaturated result, ``|q - n/d| <= |n/d| * E * 2**-(p-1) + 2**-(out_fmt.frac_bits+1)``
    with ``E = recip.error_bound_ulp`` (the reciprocal's relative error is at most ``E`` ulps of a mantissa
    ``>= 1``). :attr:`max_error` evaluates it at ``|n/d| <= quotient_limit``.

    Parameters
    ----------
    recip : RecipParams
        The reciprocal unit; its ``in_fmt`` is the format of ``d``.
    num_fmt : Fmt
        Signed format of ``n``.
    out_fmt : Fmt
        Signed format of ``q``.
    quotient_limit : int
        Largest ``|n/d|`` the user promises (the cube unit's minor/major is at most 1); used for the bound only.
    """

    NAME = "divide"

    recip: RecipParams = RecipParams(in_fmt=Fmt(True, 2, 14), m=6, b=13, t=2, p=12, guard=2)
    num_fmt: Fmt = Fmt(True, 2, 14)
    out_fmt: Fmt = Fmt(True, 2, 12)
    quotient_limit: int = 1

    def __post_init__(self):
        require(isinstance(self.recip, RecipParams), "recip", self.recip, "must be a RecipParams")
        for name in ("num_fmt", "out_fmt"):
            fmt = getattr(self, name)
            require(isinstance(fmt, Fmt) and fmt.signed, name, fmt, "must be a signed Fmt")
        require(isinstance(self.quotient_limit, int) and self.quotient_limit >= 1, "quotient_limit",
                 self.quotient_limit, "must be an int >= 1")
        bits = self.prod_fmt.width + self.pre_shift
        require(bits <= INT64_SAFE_BITS, "out_fmt", str(self.out_fmt), f"needs a {bits}-bit shifter (> 62)")

    @property
    def prod_fmt(self) -> Fmt:
        """Exact ``n * mant``: ``|mant| < 2``."""
        r = self.recip
        return Fmt(True, self.num_fmt.int_bits + 1, self.num_fmt.frac_bits + r.fo)

    @property
    def shift_range(self) -> tuple[int, int]:
        """Right shift ``prod_frac - out_frac - exp`` over the reciprocal's exponent range."""
        r = self.recip
        base = self.prod_fmt.frac_bits - self.out_fmt.frac_bits
        return base - r.exp_fmt.max_code, base - r.exp_fmt.min_code

    @property
    def pre_shift(self) -> int:
        """Left shift applied first so that every data-dependent shift is a right shift."""
        return self.recip.shift_plan(self.prod_fmt.frac_bits, self.out_fmt.frac_bits)[0]

    def products(self) -> tuple:
        """The reciprocal's products and ``n * mant``."""
        return (*self.recip.products(), self.recip.times_product(self.num_fmt.width, "n*mant"))

    def memories(self) -> tuple:
        return self.recip.memories()

    @property
    def inputs(self):
        return (Port("n", self.num_fmt, "numerator"), Port("d", self.recip.in_fmt, "denominator"))

    @property
    def outputs(self):
        return (Port("q", self.out_fmt, "n / d"), Port("dbz", Fmt(False, 1, 0), "d was zero"),
                Port("ovf", Fmt(False, 1, 0), "q saturated"))

    @property
    def latency(self) -> int:
        """The reciprocal's latency, one stage for ``n * mant`` (three when split into partial products,
        :meth:`RecipParams.times_split`), one for the shift, one to round and saturate."""
        return self.recip.latency + 3 + self.recip.times_split(self.num_fmt.width)

    def _compute(self, cols):
        n, d = cols
        mant, exp, dbz = self.recip.recip_codes(d)
        y = self.recip.scale(n * mant, self.prod_fmt.frac_bits, exp, self.out_fmt.frac_bits, Rounding.HALF_UP)
        q, ovf = saturate(y, self.out_fmt, Overflow.SATURATE)
        dz = dbz.astype(bool)
        q = np.where(dz, np.sign(n) * np.where(n > 0, self.out_fmt.max_code, -self.out_fmt.min_code), q)
        ovf = np.where(dz, n != 0, ovf)
        return [q, dbz, ovf.astype(np.int64)]

    def hard_cases(self) -> np.ndarray:
        rd = self.recip.hard_cases()[:, 0]
        nf = self.num_fmt
        nums = np.unique(np.array([0, 1, -1, nf.max_code, nf.min_code, 1 << nf.frac_bits,
                                   -(1 << nf.frac_bits)], dtype=np.int64).clip(nf.min_code, nf.max_code))
        grid = np.array(np.meshgrid(nums, rd, indexing="ij")).reshape(2, -1).T
        # n = +-d (quotient exactly +-1) and n = d/2, where representable
        for k in (1, -1):
            nn = k * rd
            ok = (nn >= nf.min_code) & (nn <= nf.max_code)
            grid = np.concatenate([grid, np.stack([nn[ok], rd[ok]], 1), np.stack([nn[ok] // 2, rd[ok]], 1)])
        return np.unique(grid, axis=0)

    def error_bound(self, quotient: Fraction) -> Fraction:
        """Bound on ``|q - n/d|`` (real units) for an unsaturated result with ``|n/d| <= quotient``."""
        r = self.recip
        return quotient * r.error_bound_ulp / (1 << r.fo) + Fraction(1, 1 << (self.out_fmt.frac_bits + 1))

    @property
    def max_error(self) -> Fraction:
        return self.error_bound(Fraction(self.quotient_limit))

    def _info(self):
        return {"precision_bits": self.recip.p, "table_entries": self.recip.entries, "terms": self.recip.t,
                "recip_max_error_ulp": float(self.recip.error_bound_ulp),
                "quotient_limit": self.quotient_limit,
                "max_error": float(self.max_error),
                "max_error_ulp": float(self.max_error / self.out_fmt.ulp)}


DivideParams.PRESETS = {
    "default": DivideParams(),
}
register(DivideParams)
