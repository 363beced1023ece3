"""The texel memories' write bus (``rtl.sampler.TexelWrites``, the board's uploads) in Amaranth's simulator: a
sampler whose memories start blank, written word by word from ``SamplerParams.upload_words`` in a random order,
then looked up one input a clock, gives the model's outputs bit for bit; with the writes of one memory missing it
does not (so the comparison can fail). Also that the upload order is the memories the RTL builds, in turn."""

from __future__ import annotations

import numpy as np
import pytest
from amaranth.hdl import Module, Signal
from amaranth.sim import Simulator

from fxmodel.core.unit import preset
from rtl.sampler import Sampler, TexelPort


def _lookups(params, order, vectors):
    """Write ``upload_words`` at the indices ``order`` (one a clock, into blank memories), then offer ``vectors``
    one a clock; the outputs as codes."""
    words = params.upload_words
    en, addr, data = Signal(), Signal(range(max(2, len(words)))), Signal(params.word_bits)
    m = Module()
    m.submodules.dut = dut = Sampler(params, TexelPort(en, addr, data, blank=True))
    got = []

    async def bench(ctx):
        for a in order:
            ctx.set(en, 1)
            ctx.set(addr, int(a))
            ctx.set(data, words[a])
            await ctx.tick()
        ctx.set(en, 0)
        for _ in range(2):                                   # the write's register, then the memory
            await ctx.tick()
        for row in vectors:
            ctx.set(dut.i_valid, 1)
            for p, v in zip(params.inputs, row):
                ctx.set(getattr(dut, p.name), int(v))
            await ctx.tick()
            if ctx.get(dut.o_valid):
                got.append([ctx.get(getattr(dut, p.name)) for p in params.outputs])
        ctx.set(dut.i_valid, 0)
        for _ in range(params.latency):
            await ctx.tick()
            if ctx.get(dut.o_valid):
                got.append([ctx.get(getattr(dut, p.name)) for p in params.outputs])

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return np.array(got, dtype=np.int64).reshape(-1, len(params.outputs))


@pytest.mark.parametrize("name", ["default", "nearest", "cube", "border", "trilinear"])
def test_uploaded_words_give_the_models_lookups(name):
    """Banked (four memories, one after the other on the bus), one memory, cube faces, border, trilinear (the even
    levels' memory, then the odd levels'): every word reaches its memory and address."""
    params = preset("sampler", name)
    rng = np.random.default_rng(3)
    vectors = np.concatenate([params.hard_cases()[:60], params.random_inputs(rng, 120)])
    order = rng.permutation(len(params.upload_words))
    got = _lookups(params, order, vectors)
    assert np.array_equal(got, params.compute(vectors))
    # one memory's words missing: its texels stay zero and some lookup differs
    first = len(params.memory_words[0])
    got = _lookups(params, [a for a in order if a >= first], vectors)
    assert not np.array_equal(got, params.compute(vectors))


def test_upload_words_are_the_memories_one_after_the_other():
    """``upload_words`` against the memories the RTL builds (``memories()``: their count and sizes), and the banked
    layout against the texels: texel ``(f, j, i)`` is word ``f * rows * cols + (j // 2) * cols + i // 2`` of bank
    ``2 (j mod 2) + (i mod 2)``."""
    for name in ("default", "nearest", "cube", "border", "trilinear"):
        p = preset("sampler", name)
        mems = p.memories()
        sizes = [len(w) for w in p.memory_words]
        assert len(p.upload_words) == sum(sizes)
        assert sum(m.count for m in mems) == len(sizes)
        assert sorted(m.words for m in mems for _ in range(m.count)) == sorted(max(1, s) for s in sizes)
    p = preset("sampler", "cube")
    f, h, w, _ = p.texels.shape
    _, bh, bw = p.bank_shape
    words = p.words                                          # texel order
    for face in range(f):
        for j in range(h):
            for i in range(w):
                bank = 2 * (j % 2) + i % 2
                at = sum(len(b) for b in p.memory_words[:bank]) + face * bh * bw + (j // 2) * bw + i // 2
                assert p.upload_words[at] == words[(face * h + j) * w + i]
