"""Helpers of the parameter objects: the shapes of Amaranth expressions (Amaranth's shape rules, so a unit's declared
products, :meth:`fxmodel.core.unit.Unit.products`, have the operand widths its RTL builds; the sampler's blends,
paper section 4) and a ``repr`` that leaves out optional fields at their defaults."""

from __future__ import annotations

import dataclasses

from fxmodel.core.cost import Product, pieces

__all__ = ["repr_without_defaults", "unify_shape", "add_shape", "sub_shape", "shl_shape", "interleave_shape",
           "is_split", "product_shape"]


def repr_without_defaults(obj, names) -> str:
    """``repr`` of a dataclass with the fields ``names`` left out where they hold their defaults."""
    parts = [f"{f.name}={getattr(obj, f.name)!r}" for f in dataclasses.fields(obj)
             if f.repr and not (f.name in names and getattr(obj, f.name) == f.default)]
    return f"{type(obj).__qualname__}({', '.join(parts)})"


def unify_shape(a: tuple, b: tuple) -> tuple:
    """Amaranth's common shape ``(width, signed)`` of two operands: an unsigned one gains a bit next to a signed
    one."""
    if a[1] == b[1]:
        return max(a[0], b[0]), a[1]
    return max(a[0] + (not a[1]), b[0] + (not b[1])), True


def add_shape(a: tuple, b: tuple) -> tuple:
    """Shape of an Amaranth sum ``a + b``."""
    w, s = unify_shape(a, b)
    return w + 1, s


def sub_shape(a: tuple, b: tuple) -> tuple:
    """Shape of an Amaranth difference ``a - b`` (always signed)."""
    return unify_shape(a, b)[0] + 1, True


def shl_shape(a: tuple, c: int) -> tuple:
    """Shape of an Amaranth shift ``a << c`` by a constant: the constant is a ``Const`` of ``bit_length(c)``
    bits, and the shape allows its largest value, ``2**bits - 1`` (wider than ``c`` itself; Yosys trims the
    constant-zero bits)."""
    return a[0] + (1 << max(1, c.bit_length())) - 1, a[1]


def interleave_shape(a: tuple, b: tuple) -> tuple:
    """``(a_bits, b_bits, a_signed, b_signed)`` of two shapes (the order of :class:`~fxmodel.core.cost.Product`)."""
    return a[0], b[0], a[1], b[1]


def is_split(p: Product) -> bool:
    """Whether ``p`` has an operand of more than one :func:`~fxmodel.core.cost.pieces`."""
    return len(pieces(p.a_bits, p.a_signed)) > 1 or len(pieces(p.b_bits, p.b_signed)) > 1


def product_shape(p: Product, cut: bool) -> tuple:
    """Shape of one product ``p`` as the RTL forms it: the registered product, or, when its
    ``rtl.recip.split_products`` call cuts (``cut``: some product of the call is wider than one block), the
    sum ``0 + sum(partial << shift)`` of its registered partial products."""
    if not cut:
        return p.a_bits + p.b_bits, p.a_signed or p.b_signed
    total = (1, False)                                                  # Python's sum starts from 0
    for lo_a, wa, sa in pieces(p.a_bits, p.a_signed):
        for lo_b, wb, sb in pieces(p.b_bits, p.b_signed):
            total = add_shape(total, shl_shape((wa + wb, sa or sb), lo_a + lo_b))
    return total
