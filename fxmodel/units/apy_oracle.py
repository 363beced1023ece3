"""An outside oracle for the fixed-point core: the project's narrowings done by apytypes.

:mod:`fxmodel.core.rounding` is the project's own code. This module redoes its narrowings with apytypes
(``APyFixedArray.cast``, a well-kept fixed-point library with its own C++ core), so the tests
(``tests/fxmodel/units/test_apy_oracle.py``) can check bit-identity and ``make bench`` can measure the speed of both.

The one mapping of the project's modes to apytypes' (module constants :data:`QUANTIZATION` and
:data:`OVERFLOW`), and why each is right:

============================  ===============================  ====================================================
project                       apytypes                         why
============================  ===============================  ====================================================
``Rounding.TRUNC``            ``QuantizationMode.TRN``         both drop the bits: floor, toward minus infinity
                                                               (``TRN_ZERO``/``TRN_MAG`` go toward zero and differ
                                                               on every negative inexact value)
``Rounding.HALF_UP``          ``QuantizationMode.RND``         both are ``floor(x + 1/2)``: nearest, ties toward
                                                               plus infinity (``RND_INF`` sends ties away from zero:
                                                               -2.5 becomes -3, not -2)
``Rounding.HALF_EVEN``        ``QuantizationMode.RND_CONV``    nearest, ties to the even code (convergent rounding)
``Overflow.SATURATE``         ``OverflowMode.SAT``             clamp to the nearer end of the range; the flag is
                                                               "the rounded value (cast with room to spare) differs
                                                               from the clamped one"
``Overflow.PROVEN``           ``OverflowMode.WRAP``            in range both leave the value alone; out of range the
                                                               RTL keeps the low bits (``WRAP``) and the model
                                                               raises ``OverflowError`` instead
============================  ===============================  ====================================================

apytypes rounds first and then applies the range rule, as :func:`fxmodel.core.rounding.narrow` does.
apytypes' formats are all two's complement (``int_bits`` counts the sign, as :class:`~fxmodel.core.fixed.Fmt`'s
do); an unsigned ``u<i>.<f>`` is the non-negative half of ``s<i+1>.<f>``, so an unsigned target is cast to that
format and its lower end, 0, is clamped here (``SAT``) or its sign bit dropped (``WRAP``).
"""

from __future__ import annotations

import numpy as np
from apytypes import APyFixedArray, OverflowMode, QuantizationMode

from fxmodel.core.fixed import INT64_SAFE_BITS, Fmt
from fxmodel.core.rounding import Overflow, Rounding

__all__ = ["QUANTIZATION", "OVERFLOW", "to_apy", "codes_of", "narrow_apy"]

#: The project's rounding -> apytypes' quantization (see the module docstring for why).
QUANTIZATION = {
    Rounding.TRUNC: QuantizationMode.TRN,
    Rounding.HALF_UP: QuantizationMode.RND,
    Rounding.HALF_EVEN: QuantizationMode.RND_CONV,
}
#: The project's overflow rule -> apytypes' overflow mode.
OVERFLOW = {
    Overflow.SATURATE: OverflowMode.SAT,
    Overflow.PROVEN: OverflowMode.WRAP,
}


def _two_complement(fmt: Fmt) -> Fmt:
    return fmt if fmt.signed else Fmt(True, fmt.int_bits + 1, fmt.frac_bits)


def to_apy(codes, fmt: Fmt) -> APyFixedArray:
    """Codes of ``fmt`` (numpy ``int64``, or ``object`` for wide words) as an ``APyFixedArray`` of the same
    values."""
    f = _two_complement(fmt)
    codes = np.asarray(codes)
    data = codes if codes.dtype != object else [int(c) for c in codes.ravel()]
    arr = APyFixedArray(data, int_bits=f.int_bits, frac_bits=f.frac_bits)
    return arr if codes.dtype != object else arr.reshape(codes.shape)


def codes_of(arr: APyFixedArray) -> np.ndarray:
    """Signed codes (``int64``, or ``object`` beyond 62 bits) of an ``APyFixedArray``'s bit patterns."""
    w = arr.int_bits + arr.frac_bits
    if w <= INT64_SAFE_BITS:
        bits = arr.to_bits(numpy=True).astype(np.int64)
    else:
        bits = np.array(arr.to_bits(), dtype=object).reshape(arr.shape)
    return np.where(((bits >> (w - 1)) & 1) == 1, bits - (1 << w), bits)


def narrow_apy(arr: APyFixedArray, fmt: Fmt, rounding: Rounding, overflow: Overflow):
    """``(codes, flag)``: ``arr`` narrowed to ``fmt`` by apytypes, the twin of :func:`fxmodel.core.rounding.narrow`.

    ``flag`` is true where the value was clamped (``SATURATE``) or does not fit (``PROVEN``: the model raises
    there, the codes are the RTL's low bits).
    """
    f = _two_complement(fmt)
    q = QUANTIZATION[rounding]
    codes = codes_of(arr.cast(int_bits=f.int_bits, frac_bits=f.frac_bits, quantization=q, overflow=OVERFLOW[overflow]))
    if not fmt.signed:
        codes = np.maximum(codes, 0) if overflow is Overflow.SATURATE else codes & ((1 << fmt.width) - 1)
    # rounded with room to spare: rounding moves a value at most up to 2**(int_bits - 1), one integer bit more
    rounded = codes_of(arr.cast(int_bits=max(arr.int_bits, 1) + 1, frac_bits=f.frac_bits, quantization=q,
                                overflow=OverflowMode.WRAP))
    if overflow is Overflow.SATURATE:
        return codes, rounded != codes
    return codes, (rounded < fmt.min_code) | (rounded > fmt.max_code)
