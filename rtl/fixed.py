"""Hardware side of :mod:`fxmodel.core.rounding`: the same narrowing rules as Amaranth expressions.

Each function here has a twin of the same name in ``fxmodel/core/rounding.py``; a unit's RTL calls exactly the
narrowings its model calls, with the same :class:`~fxmodel.core.rounding.Rounding` and
:class:`~fxmodel.core.rounding.Overflow`, so review compares them line by line. Widths come from
:class:`~fxmodel.core.fixed.Fmt`, never typed by hand.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Mux, Shape, Value, signed, unsigned

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding

__all__ = ["shape", "extend", "shift_round", "saturate", "narrow", "const_mul"]


def shape(fmt: Fmt) -> Shape:
    """Amaranth shape of a format's code."""
    return signed(fmt.width) if fmt.signed else unsigned(fmt.width)


def extend(x: Value, width: int) -> Value:
    """``x`` with at least ``width`` bits, extended by its own signedness (same value).

    Slicing ``x[:width]`` stops at ``len(x)``: without this a remainder or a low-bits view of a narrow word would
    lose its sign, or read an unsigned word's top bit as one (4 in u3 would become -4 in s5).
    """
    if len(x) >= width:
        return x
    pad = width - len(x)
    return Cat(x, x[-1].replicate(pad)).as_signed() if x.shape().signed else Cat(x, Const(0, pad))


def shift_round(x: Value, shift, rounding: Rounding) -> Value:
    """``x / 2**shift`` rounded by ``rounding``; ``shift`` an int or an unsigned Value (barrel shifter, >= 0).

    ``>>`` on a signed Amaranth value is an arithmetic shift, the same floor as numpy's.
    """
    x = Value.cast(x)
    if isinstance(shift, int):
        if shift <= 0:
            return x << -shift
        if rounding is Rounding.TRUNC:
            return x >> shift
        if rounding is Rounding.HALF_UP:
            return (x + (1 << (shift - 1))) >> shift
        x = extend(x, shift)                   # the remainder x mod 2**shift needs shift bits of x
        q = x >> shift
        r = x[:shift]
        half = 1 << (shift - 1)
        up = (r > half) | ((r == half) & q[0])
        return q + up
    shift = Value.cast(shift)
    if rounding is Rounding.TRUNC:
        return x >> shift
    if rounding is Rounding.HALF_UP:
        return (x + (Const(1, unsigned(1)) << shift >> 1)) >> shift
    raise NotImplementedError("HALF_EVEN with a data-dependent shift")


def saturate(x: Value, fmt: Fmt, overflow: Overflow):
    """``(value, flag)``: ``x`` brought into ``fmt`` (a Value of ``shape(fmt)``) by ``overflow``.

    ``PROVEN`` keeps the low bits (the model checks the proof on every value it computes); its flag is 0.
    """
    x = Value.cast(x)
    if overflow is Overflow.PROVEN:
        value = extend(x, fmt.width)[:fmt.width]
        return value.as_signed() if fmt.signed else value, Const(0, 1)
    hi = x > fmt.max_code
    lo = x < fmt.min_code
    value = Mux(hi, Const(fmt.max_code, shape(fmt)), Mux(lo, Const(fmt.min_code, shape(fmt)), x))[:fmt.width]
    return (value.as_signed() if fmt.signed else value), hi | lo


def narrow(x: Value, from_frac: int, fmt: Fmt, rounding: Rounding, overflow: Overflow):
    """Narrow ``x`` (``from_frac`` fraction bits) to ``fmt``: round first, then the range rule."""
    return saturate(shift_round(x, from_frac - fmt.frac_bits, rounding), fmt, overflow)


def const_mul(x, c: int) -> Value:
    """``x * c`` for a constant ``c >= 0``, exact, as shifted copies of ``x`` added and subtracted (the
    canonical signed-digit form of ``c``: at most ``ceil((bits + 1) / 2)`` nonzero digits, a balanced adder tree).

    No model twin (an exact product). Why not ``x * c``: Yosys maps a constant product onto a multiplier block
    like any other (``synth_ecp5`` spent five MULT18X18D on a sampler's texel addresses), and the pixel pipeline
    is short of them; a texel-address constant (a map width) has two or three nonzero digits.
    """
    x = Value.cast(x)
    if c < 0:
        raise ValueError(f"const_mul: constant {c} must be >= 0")
    terms, k = [], 0
    while c:
        if c & 1:
            digit = 2 - (c & 3)                       # +1 or -1: the non-adjacent form
            terms.append(x << k if digit > 0 else -(x << k))
            c -= digit
        c >>= 1
        k += 1
    if not terms:
        return Const(0, 1)
    while len(terms) > 1:
        terms = [terms[i] + terms[i + 1] if i + 1 < len(terms) else terms[i] for i in range(0, len(terms), 2)]
    return terms[0]
