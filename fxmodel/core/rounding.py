"""Every rounding and overflow rule of the project, in one place (model side; ``rtl/fixed.py`` mirrors it).

A *narrowing* turns a wide exact value into a narrower format. It always names two decisions:

* :class:`Rounding` -- what happens to the dropped fraction bits;
* :class:`Overflow` -- what happens when the value does not fit the target range.

There is no silent wrap. :attr:`Overflow.SATURATE` clamps and returns a flag that the unit exports;
:attr:`Overflow.PROVEN` is used where a proof (in the unit's docstring, tested at the extremes) shows the value
always fits: the model then *checks* the proof on every value it computes and raises ``OverflowError`` if it is
ever wrong, while the RTL keeps only the low bits, which is correct exactly when the proof holds.

All functions are vectorized over numpy ``int64`` arrays of codes and also accept ``object`` arrays of Python
ints for words wider than 62 bits. Shifts are exact integer arithmetic: ``>>`` on a numpy signed integer is an
arithmetic (floor) shift, identical to the hardware's.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from fxmodel.core.fixed import Fmt

__all__ = ["Rounding", "Overflow", "shift_round", "saturate", "narrow", "quantize"]


class Rounding(Enum):
    """How dropped fraction bits are handled.

    TRUNC
        Floor (toward minus infinity): drop the bits. Cost: nothing. Error in ``(-1, 0]`` ulp.
    HALF_UP
        Round to nearest, ties toward plus infinity: add half an ulp, then drop. Cost: one adder.
        Error in ``[-1/2, 1/2)`` ulp.
    HALF_EVEN
        Round to nearest, ties to the even code. Cost: an adder and a tie detector. Error in ``[-1/2, 1/2]`` ulp,
        unbiased on ties.
    """

    TRUNC = "trunc"
    HALF_UP = "half_up"
    HALF_EVEN = "half_even"


class Overflow(Enum):
    """What happens when a value leaves the target range.

    SATURATE
        Clamp to the nearest end of the range and raise the unit's flag for that element.
    PROVEN
        A documented proof says it cannot happen; the model raises ``OverflowError`` if it ever does.
    """

    SATURATE = "saturate"
    PROVEN = "proven"


def shift_round(x, shift: int, rounding: Rounding):
    """Exact ``x / 2**shift`` rounded to an integer by ``rounding``.

    ``shift`` is an int (``<= 0`` is an exact left shift) or an array of non-negative per-element shifts.
    """
    if not isinstance(rounding, Rounding):
        raise TypeError(f"rounding must be a Rounding, not {rounding!r}")
    if not np.isscalar(shift):
        # data-dependent shift (a barrel shifter): right shifts only
        shift = np.asarray(shift)
        if shift.size and shift.min() < 0:
            raise ValueError("a data-dependent shift must be a right shift (>= 0)")
        if rounding is Rounding.TRUNC:
            return x >> shift
        if rounding is Rounding.HALF_UP:
            return (x + ((1 << shift) >> 1)) >> shift
        raise NotImplementedError("HALF_EVEN with a data-dependent shift")
    if shift <= 0:
        return x << -shift
    if rounding is Rounding.TRUNC:
        return x >> shift
    if rounding is Rounding.HALF_UP:
        return (x + (1 << (shift - 1))) >> shift
    # HALF_EVEN
    q = x >> shift
    r = x & ((1 << shift) - 1)
    half = 1 << (shift - 1)
    up = (r > half) | ((r == half) & ((q & 1) == 1))
    return q + up.astype(q.dtype) if q.dtype != object else q + np.asarray(up, dtype=object).astype(int)


def saturate(x, fmt: Fmt, overflow: Overflow, what: str = "value"):
    """Bring integer codes ``x`` into ``fmt``'s range by ``overflow``; return ``(codes, flag)``.

    ``flag`` is a boolean array, true where the value was clamped (all false under ``PROVEN``, which raises
    instead).
    """
    if not isinstance(overflow, Overflow):
        raise TypeError(f"overflow must be an Overflow, not {overflow!r}")
    x = np.asarray(x)
    if overflow is Overflow.PROVEN:
        # two reductions instead of two masks: this check runs on every value the model computes
        if x.size and (x.max() > fmt.max_code or x.min() < fmt.min_code):
            bad = (x > fmt.max_code) | (x < fmt.min_code)
            row = int(np.flatnonzero(np.ravel(bad))[0])
            raise OverflowError(f"{what}: proven-in-range narrowing to {fmt} overflowed at row {row} "
                                f"(code {np.ravel(x)[row]}): the no-overflow proof is wrong")
        return x, np.zeros(x.shape, dtype=bool)
    hi = x > fmt.max_code
    lo = x < fmt.min_code
    return np.where(hi, fmt.max_code, np.where(lo, fmt.min_code, x)).astype(x.dtype), hi | lo


def narrow(x, from_frac: int, fmt: Fmt, rounding: Rounding, overflow: Overflow, what: str = "value"):
    """Narrow codes ``x`` with ``from_frac`` fraction bits to ``fmt``; return ``(codes, flag)``.

    Rounding happens first (at ``fmt.frac_bits``), then the range check, exactly as the RTL does it.
    """
    y = shift_round(np.asarray(x), from_frac - fmt.frac_bits, rounding)
    return saturate(y, fmt, overflow, what)


def quantize(values, fmt: Fmt, rounding: Rounding, overflow: Overflow, what: str = "value"):
    """Real (float64) ``values`` to codes of ``fmt``; return ``(codes, flag)``. The host side's one narrowing of
    float data (textures, bump maps, lighting cubes, triangle set-up) to fixed point.

    ``values * 2**frac_bits`` is exact in float64 (a power-of-two scaling); the rounding is then exact for
    magnitudes below ``2**52``. Non-finite values are refused (``ValueError`` naming ``what`` and the row).
    """
    x = np.ldexp(np.asarray(values, dtype=np.float64), fmt.frac_bits)
    if not np.all(np.isfinite(x)):
        row = int(np.flatnonzero(~np.isfinite(x).ravel())[0])
        raise ValueError(f"{what}: row {row}: {x.ravel()[row]!r} is not finite")
    if np.any(np.abs(x) >= 2.0 ** 52):
        raise ValueError(f"{what}: magnitude too large to quantize exactly")
    if not isinstance(rounding, Rounding):
        raise TypeError(f"rounding must be a Rounding, not {rounding!r}")
    # one exact rounding: floor(x) and x - floor(x) are exact below 2**52 (floor(x + 0.5) would round twice:
    # 0.49999999999999994 + 0.5 is 1.0 in float64)
    y = np.floor(x)
    frac = x - y
    if rounding is Rounding.HALF_UP:
        y += frac >= 0.5
    elif rounding is Rounding.HALF_EVEN:
        y += (frac > 0.5) | ((frac == 0.5) & (np.fmod(y, 2) != 0))
    lo, hi = float(fmt.min_code), float(fmt.max_code)
    return saturate(np.clip(y, lo - 1, hi + 1).astype(np.int64), fmt, overflow, what)
