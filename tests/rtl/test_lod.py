"""``rtl/lod.py``'s block-floating-point shift (stages 1-2 and 6-7 of the level-of-detail unit) simulated against exact
integer math: the leading-zero count of a magnitude's top bits, the shift ``max(0, L - (bits - 1))`` and the value
shifted as ``(x << lz) >> top`` equal the model's ``x >> shift`` (``fxmodel.units.lod._norm_shift``, FLOOR) on every
code of small words (the whole unit is co-simulated bit for bit in ``cosim/test_rtl_lod.py``).
"""

from __future__ import annotations

import pytest
from amaranth.hdl import Module, Signal, signed
from amaranth.sim import Simulator

from rtl.lod import group_shift, magnitude, shift_into, top_part
from rtl.recip import leading_zeros


def _exact(x: int, bits: int) -> tuple[int, int]:
    """``(shift, x >> shift)`` of the model: ``L`` the bit length of ``x`` (of ``~x`` for a negative ``x``)."""
    shift = max(0, (~x if x < 0 else x).bit_length() - (bits - 1))
    return shift, x >> shift


@pytest.mark.parametrize("width, bits", [(9, 4), (8, 7), (10, 3), (6, 5), (7, 2)])
def test_shift_into_equals_the_floor_shift_on_every_code(width, bits):
    x = Signal(signed(width))
    lz = leading_zeros(top_part(magnitude(x), bits))
    shift, out = Signal(8), Signal(signed(bits))
    m = Module()
    m.d.comb += [shift.eq(group_shift(width, lz, bits)), out.eq(shift_into(x, lz, width, bits))]
    seen = []

    async def bench(ctx):
        for code in range(-(1 << (width - 1)), 1 << (width - 1)):
            ctx.set(x, code)
            seen.append((code, ctx.get(shift), ctx.get(out)))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert len(seen) == 1 << width
    wrong = [(c, s, o, _exact(c, bits)) for c, s, o in seen if (s, o) != _exact(c, bits)]
    assert not wrong, wrong[:5]
    assert max(s for _, s, _ in seen) == width - (bits - 1) - 1      # the largest shift is reached


@pytest.mark.parametrize("width", [1, 2, 3, 5, 8, 9])
@pytest.mark.parametrize("group", [1, 2, 4, 8])
def test_leading_zeros_split_into_groups_is_the_exact_count_on_every_code(width, group):
    """The tree cut into groups (``rtl.reflect`` registers the groups, then finishes the tree a stage later)
    counts what exact integers count, on every code, whatever the group size."""
    from rtl.recip import leading_zero_groups, leading_zeros_of_groups
    x = Signal(width)
    split, whole = Signal(8), Signal(8)
    m = Module()
    m.d.comb += [split.eq(leading_zeros_of_groups(leading_zero_groups(x, group), width)),
                 whole.eq(leading_zeros(x))]
    seen = []

    async def bench(ctx):
        for code in range(1 << width):
            ctx.set(x, code)
            seen.append((width - code.bit_length(), ctx.get(split), ctx.get(whole)))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert len(seen) == 1 << width
    assert all(exact == split == whole for exact, split, whole in seen)
