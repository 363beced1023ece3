"""The on-chip depth test (``rtl/rop.py``) in Amaranth's simulator, with reads of its frame (``fb.read``) falling
between fragments: its two input stages hold the fragments they have while the read-out has the read port, so
none is lost or taken twice and the frame is the model's (``fxmodel.units.rop.draw``)."""

from __future__ import annotations

import numpy as np
import pytest

from fxmodel.units.rop import STATUS_BITS, RopParams, draw


def _frame_words(P, depth, color) -> list:
    """The model's frame as the on-chip words: depth in the low bits, then ``r, g, b`` and ``flags``."""
    words = []
    for d, (r, g, b, f) in zip(depth.ravel().tolist(), color.reshape(-1, 4).tolist()):
        c = r | g << 8 | b << 16 | f << 24
        words.append(d | c << P.z_fmt.width)
    return words


@pytest.mark.parametrize("seed", [1, 2])
def test_reads_between_fragments_lose_none(seed):
    """200 fragments on a 8 x 4 frame (pixels recur: the forwarding is busy), one outside the frame, a fragment
    offered at random clocks; ``fb.read`` raised at random, for one to three clocks at a random address, while
    they flow. Once the depth test is idle, the frame read through ``fb`` equals the model's frame of the
    fragments in order, and ``status`` has ``outside`` alone."""
    from amaranth.sim import Simulator

    from cosim.raster import pack
    from rtl.rop import Rop

    P = RopParams(width=8, height=4, on_chip=True)
    rng = np.random.default_rng(seed)
    k = 200
    idx = rng.integers(0, P.pixels, k)
    frags = np.stack([idx % P.width, idx // P.width, rng.integers(1, 1 << P.z_in.frac_bits, k),
                      *(rng.integers(0, 256, k) for _ in range(3)), rng.integers(0, 1 << P.flag_bits, k)], axis=1)
    frags[50, 1] = P.height                                  # one fragment below the frame: ``outside``
    depth, color, _ = draw(P, frags)
    want = _frame_words(P, depth, color)
    dut = Rop(P)
    seen = {"reads": 0}

    async def fragments(ctx):
        r = np.random.default_rng(seed + 100)
        for word in pack(P.inputs, frags):
            while r.random() < 0.3:                          # a gap in the stream
                ctx.set(dut.i.valid, 0)
                await ctx.tick()
            ctx.set(dut.i.payload.as_value(), word)
            ctx.set(dut.i.valid, 1)
            await ctx.tick().until(dut.i.ready)
        ctx.set(dut.i.valid, 0)
        seen["sent"] = True

    async def reads(ctx):
        r = np.random.default_rng(seed + 200)
        while "sent" not in seen:
            if r.random() < 0.2:
                ctx.set(dut.fb.read, 1)
                for _ in range(int(r.integers(1, 4))):
                    ctx.set(dut.fb.addr, int(r.integers(0, P.pixels)))
                    await ctx.tick()
                    seen["reads"] += 1
                ctx.set(dut.fb.read, 0)
            await ctx.tick()
        while ctx.get(dut.busy):
            await ctx.tick()
        words = []
        ctx.set(dut.fb.read, 1)
        for a in range(P.pixels + P.readout_latency):
            ctx.set(dut.fb.addr, min(a, P.pixels - 1))
            await ctx.tick()
            if a >= P.readout_latency - 1 and len(words) < P.pixels:
                words.append(ctx.get(dut.fb.data))
        ctx.set(dut.fb.read, 0)
        seen["words"], seen["status"] = words, ctx.get(dut.status)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(fragments)
    sim.add_testbench(reads)
    sim.run()
    assert seen["reads"] > 20                                # the read-out did fall between fragments
    assert seen["words"] == want
    assert seen["status"] == 1 << STATUS_BITS["outside"]
