r"""Perspective-correct texture coordinates ``s = U (1/W)``, ``t = V (1/W)`` (paper, sections 3.2, 4 and 4.1).

The rasterizer interpolates the homogeneous texture coordinates ``U = u/w``, ``V = v/w`` and ``W = 1/w`` linearly
in screen space; "by using homogenous coordinates the resulting address (u/w, v/w) is the perspectively correct
pixel index on the bump map" (section 3.2). One reciprocal of ``W`` per pixel (section 4.1) serves both.

Algorithm (bit-exact; ``rtl/persp.py`` builds the same datapath from the same :class:`PerspParams`)
----------------------------------------------------------------------------------------------------
``(mant, exp, dbz) = recip(W)``; exact products ``U mant`` and ``V mant``; each scaled by ``2**exp`` and rounded
half-up to ``coord_bits`` fraction bits by the reciprocal's barrel shifter (:meth:`RecipParams.scale`); then the
**repeat rule**: only the fraction bits are kept, ``s - floor(s)`` in ``[0, 1)``. This is the texture's repeat
(the maps are applied repeatedly, paper section 5), exact for negative ``s`` and for ``s`` far outside ``[0, 1)``,
and it is the only thing the samplers use in repeat mode: the integer part is never formed, so it cannot
overflow. ``W = 0`` (a point at infinity; the front end never sends one) gives ``s = t = 0`` and ``dbz``.

Error bound (:meth:`PerspParams.error_bound`): the distance on the unit circle (mod 1) between ``s`` and the exact
``U/W`` is at most ``|U/W| E 2**-(p-1) + 2**-(coord_bits+1)`` with ``E`` the reciprocal's bound in ulps: the error
grows with the number of repeats, ``|s|``. For the default preset and ``|s| <= 16`` that is below ``2**-17``.

Hard cases (each has a test): ``U = 0``; ``s`` exactly an integer (wraps to 0); ``s`` just below an integer
(``1 - ulp``); negative ``s``; ``|s|`` large; the smallest and largest ``W``; ``W = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Rounding
from fxmodel.core.unit import Port, Unit, register
from fxmodel.units.recip import RecipParams

__all__ = ["PerspParams"]


@dataclass(frozen=True)
class PerspParams(Unit):
    """Parameters of the perspective texture-coordinate unit.

    Parameters
    ----------
    recip : RecipParams
        The reciprocal of ``W`` (its ``in_fmt`` is ``W``'s format).
    uv_fmt : Fmt
        Signed format of ``U`` and ``V``.
    coord_bits : int
        Fraction bits of ``s`` and ``t`` (outputs ``u0.coord_bits``, already repeat-wrapped).
    color : bool
        Also a second address ``(sc, tc) = (Uc, Vc) / W`` for a color texture repeated differently from the
        bump map: two more multipliers and shifters, the same reciprocal.
    """

    NAME = "persp"

    recip: RecipParams = RecipParams.PRESETS["default"]
    uv_fmt: Fmt = Fmt(True, 8, 16)
    coord_bits: int = 16
    color: bool = False

    def __post_init__(self):
        if not isinstance(self.recip, RecipParams):
            raise ValueError(f"recip={self.recip!r}: must be a RecipParams")
        if not isinstance(self.uv_fmt, Fmt) or not self.uv_fmt.signed:
            raise ValueError(f"uv_fmt={self.uv_fmt!r}: must be a signed Fmt")
        if not isinstance(self.color, bool):
            raise ValueError(f"color={self.color!r}: must be a bool")
        if not isinstance(self.coord_bits, int) or not 1 <= self.coord_bits <= 30:
            raise ValueError(f"coord_bits={self.coord_bits!r}: must be an int in 1..30")
        pre, _ = self.recip.shift_plan(self.prod_frac, self.coord_bits)
        if self.uv_fmt.width + self.recip.mant_fmt.width + pre > INT64_SAFE_BITS:
            raise ValueError(f"coord_bits={self.coord_bits}: the scaled product would exceed 62 bits")

    @property
    def prod_frac(self) -> int:
        return self.uv_fmt.frac_bits + self.recip.fo

    @property
    def coord_fmt(self) -> Fmt:
        return Fmt(False, 0, self.coord_bits)

    @property
    def numerators(self) -> tuple:
        """``(input, output)`` port names of each coordinate."""
        pairs = (("U", "s"), ("V", "t"))
        return pairs + ((("Uc", "sc"), ("Vc", "tc")) if self.color else ())

    @property
    def inputs(self):
        return (tuple(Port(i, self.uv_fmt, f"{o} * W") for i, o in self.numerators)
                + (Port("W", self.recip.in_fmt, "1 / w"),))

    @property
    def outputs(self):
        return (tuple(Port(o, self.coord_fmt, f"{i} / W, repeat-wrapped") for i, o in self.numerators)
                + (Port("dbz", Fmt(False, 1, 0), "W was zero"),))

    def products(self) -> tuple:
        """The reciprocal's products and ``numerator * mant`` for each coordinate."""
        return (*self.recip.products(),
                self.recip.times_product(self.uv_fmt.width, "numerator*mant", count=len(self.numerators)))

    def memories(self) -> tuple:
        return self.recip.memories()

    @property
    def latency(self) -> int:
        """The reciprocal, the products (three stages when split into partial products,
        :meth:`RecipParams.times_split`), the shift, the rounding."""
        return self.recip.latency + 3 + self.recip.times_split(self.uv_fmt.width)

    def coords(self, nums, W):
        """Wrapped coordinates of each numerator code array in ``nums``, and ``dbz``."""
        mant, exp, dbz = self.recip.recip_codes(W)
        mask = (1 << self.coord_bits) - 1
        out = []
        for num in nums:
            y = self.recip.scale(num * mant, self.prod_frac, exp, self.coord_bits, Rounding.HALF_UP)
            out.append(np.where(dbz == 1, 0, y & mask))             # repeat rule: the fraction bits
        return out + [dbz]

    def _compute(self, cols):
        return self.coords(cols[:-1], cols[-1])

    def hard_cases(self) -> np.ndarray:
        uf, wf = self.uv_fmt, self.recip.in_fmt
        one_w = 1 << wf.frac_bits
        ws = [1, one_w, one_w // 2, one_w - 1, wf.max_code, 3 * one_w // 7, 0, -one_w]
        us = [0, 1 << uf.frac_bits, -(1 << uf.frac_bits), (1 << uf.frac_bits) - 1, uf.max_code, uf.min_code,
              3 << uf.frac_bits, -(5 << uf.frac_bits) + 1]
        rows = [[u, v] + ([v, u] if self.color else []) + [w] for u in us for v in us[::3] for w in ws]
        return np.array(rows, dtype=np.int64)

    def error_bound(self, s_abs: Fraction) -> Fraction:
        """Bound on the wrapped distance between ``s`` and the exact ``U/W`` for ``|U/W| <= s_abs``."""
        return s_abs * self.recip.error_bound_ulp / (1 << self.recip.fo) + Fraction(1, 1 << (self.coord_bits + 1))

    def _info(self):
        bound16 = self.error_bound(Fraction(16))
        return {"coord_bits": self.coord_bits, "recip_max_error_ulp": float(self.recip.error_bound_ulp),
                "max_error": {"s": float(bound16), "t": float(bound16)}, "max_error_for_abs_s_up_to": 16}


#: The reciprocal for texture addresses: ``W`` in ``[-2, 2)`` with 22 fraction bits (the front end scales each
#: triangle's ``W`` into ``(0, 1]``), 22-bit faithful result (bound 0.97 ulp) from 64 entries and 4 terms. Measured
#: need: a hard edge of a 512-texel texture sampled bilinearly stays within 1 LSB of the float reference only with
#: address errors near 2**-19; the 17-bit ``recip`` default gave 3 LSB on the Berlin wall.
TEXCOORD_RECIP = RecipParams(in_fmt=Fmt(True, 2, 22), m=7, b=23, t=4, p=22, guard=5)

PerspParams.PRESETS = {
    "default": PerspParams(recip=TEXCOORD_RECIP, uv_fmt=Fmt(True, 6, 20), coord_bits=22),
    "color": PerspParams(recip=TEXCOORD_RECIP, uv_fmt=Fmt(True, 6, 20), coord_bits=22, color=True),
    "small": PerspParams(recip=RecipParams.PRESETS["small"], uv_fmt=Fmt(True, 4, 12), coord_bits=12),
}
register(PerspParams)
