"""Fixed-point formats: the one type every unit uses to name a word's width and scaling.

A :class:`Fmt` is ``(signed, int_bits, frac_bits)``: ``int_bits`` counts the sign bit of a signed format, so
``Fmt(True, 8, 16)`` (written ``s8.16``) is a 24-bit two's-complement word whose code ``c`` stands for the real
value ``c * 2**-16`` in ``[-128, 128)``. ``Fmt(False, 1, 16)`` (``u1.16``) is a 17-bit unsigned word in ``[0, 2)``.

Codes travel as numpy ``int64`` arrays (two's-complement *values*, not bit patterns) wherever the width is at
most 62 bits; wider formats fall back to exact Python integers in ``object`` arrays. Conversions never round
silently: :meth:`Fmt.from_real` refuses a value that is not exactly representable and names the first bad row.
All narrowing (rounding and overflow) lives in :mod:`fxmodel.core.rounding`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

__all__ = ["Fmt", "INT64_SAFE_BITS", "as_codes"]

#: Widest word held in an ``int64`` array; products of two such words are checked by their users.
INT64_SAFE_BITS = 62

_FMT_RE = re.compile(r"^\s*([su])(-?\d+)\.(\d+)\s*$")


def as_codes(values, width: int):
    """Return ``values`` as an integer array fit for a word of ``width`` bits (int64, or object beyond 62)."""
    if width <= INT64_SAFE_BITS:
        return np.asarray(values, dtype=np.int64)
    arr = np.asarray(values, dtype=object)
    return np.vectorize(int, otypes=[object])(arr) if arr.size else arr


@dataclass(frozen=True)
class Fmt:
    """A fixed-point format.

    Parameters
    ----------
    signed : bool
        Two's complement if true, unsigned otherwise.
    int_bits : int
        Integer bits, the sign bit included for a signed format. May be zero or negative for formats whose
        values are all below 1 (``width`` must stay at least 1).
    frac_bits : int
        Fraction bits, at least 0. The weight of the least significant bit (one ulp) is ``2**-frac_bits``.

    Raises
    ------
    TypeError
        If a field has the wrong type.
    ValueError
        If the width is not positive or a signed format has no room for its sign.
    """

    signed: bool
    int_bits: int
    frac_bits: int

    def __post_init__(self):
        if not isinstance(self.signed, bool):
            raise TypeError(f"Fmt.signed must be a bool, not {self.signed!r}")
        for name in ("int_bits", "frac_bits"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool):
                raise TypeError(f"Fmt.{name} must be an int, not {value!r}")
        if self.frac_bits < 0:
            raise ValueError(f"Fmt.frac_bits must be >= 0, not {self.frac_bits}")
        if self.width < 1:
            raise ValueError(f"Fmt width (int_bits + frac_bits) must be >= 1, not {self.width}")
        if self.signed and self.width < 2:
            raise ValueError(f"a signed Fmt needs at least 2 bits, not {self.width}")

    # -- construction -------------------------------------------------------------------------------------
    @classmethod
    def parse(cls, text: str) -> Fmt:
        """Parse the short form ``s8.16`` / ``u1.16`` (see :meth:`__str__`)."""
        match = _FMT_RE.match(text)
        if not match:
            raise ValueError(f"format {text!r} is not of the form s<int>.<frac> or u<int>.<frac>")
        return cls(match.group(1) == "s", int(match.group(2)), int(match.group(3)))

    @classmethod
    def integer(cls, lo: int, hi: int) -> Fmt:
        """The narrowest integer format (``frac_bits = 0``) that holds every integer in ``[lo, hi]``."""
        if lo > hi:
            raise ValueError(f"empty integer range [{lo}, {hi}]")
        if lo >= 0:
            return cls(False, max(1, int(hi).bit_length()), 0)
        bits = max(int(hi).bit_length(), int(-lo - 1).bit_length()) + 1
        return cls(True, bits, 0)

    # -- derived facts ------------------------------------------------------------------------------------
    @property
    def width(self) -> int:
        """Total bits of the word."""
        return self.int_bits + self.frac_bits

    @property
    def min_code(self) -> int:
        return -(1 << (self.width - 1)) if self.signed else 0

    @property
    def max_code(self) -> int:
        return (1 << (self.width - 1)) - 1 if self.signed else (1 << self.width) - 1

    @property
    def ulp(self) -> Fraction:
        """Weight of one code step, exactly."""
        return Fraction(1, 1 << self.frac_bits)

    @property
    def min_value(self) -> Fraction:
        return self.min_code * self.ulp

    @property
    def max_value(self) -> Fraction:
        return self.max_code * self.ulp

    @property
    def wide(self) -> bool:
        """True if codes of this format need exact Python integers (width above 62 bits)."""
        return self.width > INT64_SAFE_BITS

    def __str__(self) -> str:
        return f"{'s' if self.signed else 'u'}{self.int_bits}.{self.frac_bits}"

    def describe(self, name: str) -> dict:
        """The JSON form used by ``bumpmap info``."""
        return {"name": name, "signed": self.signed, "int_bits": self.int_bits, "frac_bits": self.frac_bits}

    # -- code <-> value -----------------------------------------------------------------------------------
    def contains(self, codes) -> np.ndarray:
        """Boolean mask: which codes lie in this format's range."""
        codes = as_codes(codes, self.width + 1)
        return (codes >= self.min_code) & (codes <= self.max_code)

    def check(self, codes, what: str = "value"):
        """Return ``codes`` as an array, raising ``ValueError`` naming the first code out of range."""
        codes = as_codes(codes, self.width)
        bad = ~self.contains(codes)
        if np.any(bad):
            row = int(np.flatnonzero(bad.ravel())[0])
            raise ValueError(f"{what}: row {row}: code {codes.ravel()[row]} is outside {self} "
                             f"[{self.min_code}, {self.max_code}]")
        return codes

    def to_real(self, codes) -> np.ndarray:
        """Real values of ``codes`` as float64 (exact whenever the code fits in 53 bits)."""
        codes = np.asarray(codes)
        return np.ldexp(codes.astype(np.float64), -self.frac_bits)

    def to_fraction(self, code: int) -> Fraction:
        """Exact real value of one code."""
        return int(code) * self.ulp

    def from_real(self, values, what: str = "value") -> np.ndarray:
        """Codes of real ``values`` (float64), which must be exactly representable.

        Raises ``ValueError`` naming ``what`` and the first row that is not finite, not a multiple of the ulp, or
        out of range. Nothing is rounded here: rounding is a decision, made in :mod:`fxmodel.core.rounding`.
        """
        values = np.asarray(values, dtype=np.float64)
        flat = values.ravel()
        finite = np.isfinite(flat)
        scaled = np.ldexp(np.where(finite, flat, 0.0), self.frac_bits)
        integral = finite & (scaled == np.floor(scaled))
        in_range = integral & (scaled >= self.min_code) & (scaled <= self.max_code)
        if not np.all(in_range):
            row = int(np.flatnonzero(~in_range)[0])
            v = float(flat[row])
            if not finite[row]:
                why = "is not finite"
            elif not integral[row]:
                why = f"is not a multiple of the ulp 2^-{self.frac_bits}"
            else:
                why = f"is outside [{float(self.min_value)}, {float(self.max_value)}]"
            raise ValueError(f"{what}: row {row}: {v!r} {why} (format {self})")
        if self.width > 53:
            return as_codes([int(Fraction(float(v)) / self.ulp) for v in flat], self.width).reshape(values.shape)
        return scaled.astype(np.int64).reshape(values.shape)

    # -- bit patterns -------------------------------------------------------------------------------------
    def to_bits(self, codes):
        """Two's-complement bit patterns (non-negative integers below ``2**width``) of ``codes``."""
        codes = as_codes(codes, self.width + 1)
        return codes & ((1 << self.width) - 1) if not self.wide else np.vectorize(
            lambda c: int(c) & ((1 << self.width) - 1), otypes=[object])(codes)

    def from_bits(self, bits):
        """Codes from bit patterns: the inverse of :meth:`to_bits`."""
        bits = as_codes(bits, self.width + 1)
        if not self.signed:
            return bits
        top = 1 << (self.width - 1)
        return np.where(bits >= top, bits - (1 << self.width), bits) if not self.wide else np.vectorize(
            lambda b: int(b) - (1 << self.width) if int(b) >= top else int(b), otypes=[object])(bits)
