"""The texel cache's LRU state as a bit per pair of ways (``rtl/texcache_tags.py``): for every order of the ways,
every set of valid ways and every way used, the victim is the lowest invalid way, else the least recently used,
and the row after the use has that way the most recently used and the others in their order. Checked
exhaustively in Amaranth's simulator against an order kept as a Python list (most recent first), not against the
model's code."""

from itertools import permutations
from types import SimpleNamespace

import pytest
from amaranth.hdl import Module, Signal
from amaranth.sim import Simulator

from fxmodel.units.texcache import TexCacheParams
from rtl.texcache_tags import lru_pairs, new_rows, row_states, state_bits, victim


def bits_of(order: list) -> list:
    """The pair bits of an order of the ways (most recently used first): bit ``(i, j)`` set when ``i`` is older."""
    return [int(order.index(i) > order.index(j)) for i, j in lru_pairs(len(order))]


@pytest.mark.parametrize("ways", [2, 3, 4])
def test_pair_bits_are_lru(ways):
    params = TexCacheParams(block=4, sets=4, ways=ways)
    assert row_states(params) == ways * (ways - 1) // 2 and state_bits(params) == 1
    m = Module()
    states = [Signal(name=f"s{k}") for k in range(row_states(params))]
    valids = [Signal(name=f"v{w}") for w in range(ways)]
    way = Signal(range(ways), name="way")
    vic = victim(m, params, valids, states, None, "t_")
    corner = SimpleNamespace(line=Signal(4), tags=[Signal(4) for _ in range(ways)], valids=valids, states=states,
                             hit=Signal(init=1), victim=vic)
    _, _, after = new_rows(m, params, 4, [corner] * 4, [way] * 4)[0]
    sim = Simulator(m)
    checked = []

    async def bench(ctx):
        for order in permutations(range(ways)):
            for mask in range(1 << ways):
                for w, bit in zip(states, bits_of(list(order))):
                    ctx.set(w, bit)
                for v in range(ways):
                    ctx.set(valids[v], mask >> v & 1)
                invalid = [v for v in range(ways) if not mask >> v & 1]
                assert ctx.get(vic) == (invalid[0] if invalid else order[-1]), (order, mask)
                for u in range(ways):
                    ctx.set(way, u)
                    want = bits_of([u] + [v for v in order if v != u])
                    assert [ctx.get(b) for b in after] == want, (order, u)
                    checked.append(u)

    sim.add_testbench(bench)
    sim.run()
    assert len(checked) == len(list(permutations(range(ways)))) * (1 << ways) * ways
