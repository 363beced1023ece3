"""The display's RTL (``board/dvi.py``) against its golden model (``board/video.py``) in Amaranth's simulator: the
TMDS encoder on random bytes with blanking between, bit for bit, and the timing generator over a whole frame."""

from __future__ import annotations

import random

from amaranth.sim import Simulator

from board.dvi import TimingGenerator, TmdsEncoder
from board.video import SMALL, VideoTiming
from board.video import TmdsEncoder as ModelEncoder


def test_encoder_matches_the_model_bit_for_bit():
    rng = random.Random(26)
    stimulus = [(int(rng.random() < 0.9), rng.randrange(256), rng.randrange(4)) for _ in range(3000)]
    stimulus += [(1, d, 0) for d in range(256)] + [(1, 0xFF, 0)] * 20 + [(1, 0, 0)] * 20
    dut, got = TmdsEncoder(), []

    async def bench(ctx):
        for de, d, c in stimulus:
            ctx.set(dut.de, de)
            ctx.set(dut.data, d)
            ctx.set(dut.ctrl, c)
            await ctx.tick()
            got.append(ctx.get(dut.word))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    model = ModelEncoder()
    want = [model.step(de, d, c) for de, d, c in stimulus]
    bad = [i for i, (a, b) in enumerate(zip(got, want)) if a != b]
    assert len(got) == len(want)
    assert not bad, f"first mismatch at {bad[:3]}: rtl {got[bad[0]]:#x} model {want[bad[0]]:#x}"


def _timing_rows(t: VideoTiming, clocks: int) -> list:
    dut, rows = TimingGenerator(t), []

    async def bench(ctx):
        for _ in range(clocks):
            rows.append(tuple(ctx.get(s) for s in (dut.x, dut.y, dut.de, dut.hsync, dut.vsync, dut.frame)))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return rows


def test_timing_generator_matches_the_model_over_two_frames():
    """From the first blanking line (where reset leaves it) through two whole frames."""
    for t in (SMALL, VideoTiming(5, 1, 1, 1, 3, 1, 1, 1, h_sync_pos=True, v_sync_pos=True)):
        rows = _timing_rows(t, 2 * t.frame_clocks + 3)
        for k, row in enumerate(rows):
            h, v = k % t.h_total, (k // t.h_total + t.v_active) % t.v_total      # out of reset: blanking
            assert row == (h, v, *t.at(h, v), int(h == 0 and v == 0)), (t, k, row)
