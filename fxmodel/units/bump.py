r"""Bump engine: ``N' = N 2**-e + du A[:,0] + dv A[:,1]`` (paper, section 3.2 and Fig. 6).

The bump map holds the perturbation ``(du, dv)`` of the normal ``[0, 0, 1]`` in texture space; the per-triangle
matrix ``A`` (3 x 2, computed once per triangle by the host, see :func:`host.bumpmap.triangle_matrix`) turns
it into a perturbation in the space of the interpolated normal ``N``.

Block floating point for ``A``: the triangle set-up stores ``A 2**-e`` with a per-triangle shared exponent
``0 <= e < 2**exp_bits`` (the smallest that makes ``A`` fit ``a_fmt`` and ``N'`` fit ``out_fmt``,
:func:`host.bumpmap.block_exponent`), and the engine scales ``N`` by the same ``2**-e``. The result is
``2**-e (N + du A0 + dv A1)``: the perturbed normal up to a positive factor, which is all the reflection and the
cube lookups need (they use directions only; the reflection unit normalizes its blocks the same way). ``e = 0``
is the plain engine of the paper.

Algorithm (bit-exact; ``rtl/bump.py`` builds the same datapath from the same :class:`BumpParams`)
--------------------------------------------------------------------------------------------------
Six exact products ``du A_i0`` and ``dv A_i1`` (``d_fmt`` times ``a_fmt``, both signed), and per component the
exact sum ``N_i 2**-e + du A_i0 + dv A_i1`` at ``F = max(n_fmt.frac + e_max, d_fmt.frac + a_fmt.frac)``
fraction bits (``e_max = 2**exp_bits - 1``): ``N_i 2**-e`` is an arithmetic right shift of ``N_i`` aligned to
``F`` bits, **exact** (no rounding: ``F`` keeps every bit ``e`` shifts out); then
*one* narrowing to ``out_fmt``: :attr:`rounding` (half-up by default) and
:attr:`~fxmodel.core.rounding.Overflow.SATURATE`. ``saturated`` is the OR of the three components' flags: a
perturbed normal too long for ``out_fmt`` is clamped per component (its direction then changes, which the flag
reports), it never wraps.

Widths (:meth:`BumpParams.widths`): each product has ``d_fmt.width + a_fmt.width`` bits (14 + 16 for ``default``,
within one 18 x 18 DSP block); the sum of the aligned ``N`` and two products needs two more bits than the widest
term; all exact in ``int64``.

Error bound: an unsaturated component is within half an ``out_fmt`` ulp of the exact ``N 2**-e + du A0 + dv A1``
(``HALF_UP``; one ulp for ``TRUNC``), :attr:`BumpParams.max_error`.

Hard cases (each has a test): ``du``, ``dv`` at the extremes of their format (most negative included) with ``A``
entries at theirs; sums that saturate up and down in each component; zero perturbation (``N' = N 2**-e``
exactly when ``N`` fits ``out_fmt``); ``N`` at its extremes; each with ``e = 0``, ``1`` and ``e_max``.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

import numpy as np

from fxmodel.core.cost import Product
from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, Unit, register

__all__ = ["BumpParams"]

AXES = "xyz"


@dataclass(frozen=True)
class BumpParams(Unit):
    """Parameters of the bump engine.

    Parameters
    ----------
    n_fmt : Fmt
        Signed format of the interpolated normal's components ``Nx, Ny, Nz``.
    d_fmt : Fmt
        Signed format of the bump-map perturbation ``du, dv``.
    a_fmt : Fmt
        Signed format of the six entries of the per-triangle matrix ``A``.
    out_fmt : Fmt
        Signed format of the perturbed normal ``N'`` (the reflection and cube units' input format).
    rounding : Rounding
        Rounding of the one narrowing to ``out_fmt``.
    exp_bits : int
        Bits of the per-triangle block exponent ``e`` of ``A`` (input ``Ae``, unsigned); 0: no exponent input.
    """

    NAME = "bump"

    n_fmt: Fmt = Fmt(True, 2, 16)
    d_fmt: Fmt = Fmt(True, 1, 13)           # 12 bits left 0.07 degree of N' at strength 8: 2 LSB at a highlight
    a_fmt: Fmt = Fmt(True, 2, 14)
    out_fmt: Fmt = Fmt(True, 2, 16)
    rounding: Rounding = Rounding.HALF_UP
    exp_bits: int = 3

    def __post_init__(self):
        if not isinstance(self.exp_bits, int) or isinstance(self.exp_bits, bool) or not 0 <= self.exp_bits <= 4:
            raise ValueError(f"exp_bits={self.exp_bits!r}: must be an int in 0..4")
        for name in ("n_fmt", "d_fmt", "a_fmt", "out_fmt"):
            fmt = getattr(self, name)
            if not isinstance(fmt, Fmt) or not fmt.signed:
                raise ValueError(f"{name}={fmt!r}: must be a signed Fmt")
        if not isinstance(self.rounding, Rounding):
            raise ValueError(f"rounding={self.rounding!r}: must be a Rounding")
        if self.sum_fmt.width > INT64_SAFE_BITS:
            raise ValueError(f"out_fmt={self.out_fmt}: the exact sum would need {self.sum_fmt.width} bits (> 62)")

    # -- widths (the RTL reads these) ---------------------------------------------------------------------
    @property
    def e_max(self) -> int:
        """The largest block exponent ``e``."""
        return (1 << self.exp_bits) - 1

    @property
    def e_fmt(self) -> Fmt:
        """Format of the block exponent input ``Ae`` (unsigned integer)."""
        return Fmt(False, max(self.exp_bits, 1), 0)

    @cached_property
    def frac(self) -> int:
        """Fraction bits of the exact sum (``N 2**-e`` exact for every ``e``)."""
        return max(self.n_fmt.frac_bits + self.e_max, self.d_fmt.frac_bits + self.a_fmt.frac_bits)

    @cached_property
    def prod_fmt(self) -> Fmt:
        """One exact product ``du * A_ij``: the corner products of the two code ranges."""
        d, a = self.d_fmt, self.a_fmt
        corners = [x * y for x in (d.min_code, d.max_code) for y in (a.min_code, a.max_code)]
        f = Fmt.integer(min(corners), max(corners))
        return Fmt(True, f.int_bits - d.frac_bits - a.frac_bits, d.frac_bits + a.frac_bits)

    @cached_property
    def sum_fmt(self) -> Fmt:
        """Exact ``N_i + du A_i0 + dv A_i1`` at :attr:`frac` fraction bits (interval bound of the three terms)."""
        sn = 1 << (self.frac - self.n_fmt.frac_bits)
        sp = 1 << (self.frac - self.prod_fmt.frac_bits)
        lo = self.n_fmt.min_code * sn + 2 * self.prod_fmt.min_code * sp
        hi = self.n_fmt.max_code * sn + 2 * self.prod_fmt.max_code * sp
        f = Fmt.integer(lo, hi)
        return Fmt(True, f.int_bits - self.frac, self.frac)

    def widths(self) -> dict:
        return {"product": self.prod_fmt.width, "sum": self.sum_fmt.width,
                "multiplier": f"{self.d_fmt.width}x{self.a_fmt.width}"}

    def products(self) -> tuple:
        """``du A[i,0]`` and ``dv A[i,1]`` for each axis: six products."""
        d, a = self.d_fmt, self.a_fmt
        return (Product(d.width, a.width, d.signed, a.signed, count=2 * len(AXES), name="d*A"),)

    @property
    def max_error(self) -> Fraction:
        """Bound on ``|N'_i - exact|`` (real units) for an unsaturated component."""
        return self.out_fmt.ulp / 2 if self.rounding is not Rounding.TRUNC else self.out_fmt.ulp

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        return (tuple(Port(f"N{c}", self.n_fmt, "interpolated normal") for c in AXES)
                + (Port("du", self.d_fmt, "bump perturbation along u"), Port("dv", self.d_fmt, "along v"))
                + tuple(Port(f"A{i}0", self.a_fmt, "A[:,0]: u direction") for i in range(3))
                + tuple(Port(f"A{i}1", self.a_fmt, "A[:,1]: v direction") for i in range(3))
                + ((Port("Ae", self.e_fmt, "A's block exponent e (per triangle): N' = N 2^-e + du A0 + dv A1"),)
                   if self.exp_bits else ()))

    @property
    def outputs(self):
        return (tuple(Port(f"Np{c}", self.out_fmt, "perturbed normal N'") for c in AXES)
                + (Port("saturated", Fmt(False, 1, 0), "some component of N' was clamped"),))

    @property
    def latency(self) -> int:
        """Three stages: the six products | the exact sums | rounding and saturation (one carry chain or one
        product a stage, for Fmax)."""
        return 3

    # -- bit-exact model ----------------------------------------------------------------------------------
    def perturb(self, N, du, dv, A0, A1, e=0):
        """``(N', saturated)`` from code arrays: ``N``, ``A0``, ``A1`` of shape ``(..., 3)``; ``e`` the block
        exponent (shape ``(...)`` or a scalar)."""
        sn = self.frac - self.n_fmt.frac_bits
        sp = self.frac - self.prod_fmt.frac_bits
        e = np.asarray(e, dtype=np.int64)[..., None]
        exact = ((N << sn) >> e) + ((du[..., None] * A0 + dv[..., None] * A1) << sp)     # >> e: exact, sn >= e
        out, flag = narrow(exact, self.frac, self.out_fmt, self.rounding, Overflow.SATURATE, "bump N'")
        return out, flag.any(axis=-1)

    def _compute(self, cols):
        N = np.stack(cols[0:3], axis=-1)
        du, dv = cols[3], cols[4]
        A0 = np.stack(cols[5:8], axis=-1)
        A1 = np.stack(cols[8:11], axis=-1)
        out, sat = self.perturb(N, du, dv, A0, A1, cols[11] if self.exp_bits else 0)
        return [out[:, 0], out[:, 1], out[:, 2], sat.astype(np.int64)]

    def hard_cases(self) -> np.ndarray:
        n, d, a = self.n_fmt, self.d_fmt, self.a_fmt
        rows = []
        nvals = [n.min_code, 0, n.max_code, 1 << n.frac_bits if n.int_bits > 1 else n.max_code]
        dvals = [d.min_code, d.min_code + 1, 0, d.max_code]
        avals = [a.min_code, 0, a.max_code]
        for nx in nvals:
            for du in dvals:
                for dv in dvals:
                    for av in avals:
                        rows.append([nx, -nx if nx != n.min_code else n.max_code, 0, du, dv, av, -av if av != a.min_code
                                     else a.max_code, av, av, av, -av if av != a.min_code else a.max_code])
        rows = np.array(rows, dtype=np.int64)
        if self.exp_bits:
            rows = np.concatenate([np.column_stack([rows, np.full(len(rows), e)]) for e in (0, 1, self.e_max)])
        return np.unique(rows, axis=0)

    def _info(self):
        return {"widths": self.widths(),
                "max_error": {f"Np{c}": float(self.max_error) for c in AXES},
                "max_error_ulp": float(self.max_error / self.out_fmt.ulp)}


BumpParams.PRESETS = {
    "default": BumpParams(),
    "small": BumpParams(n_fmt=Fmt(True, 2, 10), d_fmt=Fmt(True, 1, 7), a_fmt=Fmt(True, 2, 10),
                        out_fmt=Fmt(True, 2, 10)),
    "plain": BumpParams(exp_bits=0),                    # the paper's engine: no block exponent
}
register(BumpParams)
