"""The board's engine system (``board/frame.py``): the display's color format (RGB565 and its expansion to bytes)
against exact integer arithmetic over every word, the displayed picture's layout, and the checks on what the
system is built from. The whole system, host bytes to DVI words, is ``cosim/test_board_system.py`` (slow)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from board.frame import EngineSystem, display_frame, expand565, rgb565
from board.video import SMALL, VGA_640x480


def test_every_rgb565_word_expands_and_narrows_back_to_itself():
    words = np.arange(1 << 16)
    rgb = expand565(words)
    assert np.array_equal(rgb565(rgb), words)
    r, g, b = words >> 11, words >> 5 & 63, words & 31
    # each channel's bits repeated from the top: the expanded byte's high bits are the channel, and it is exact at
    # both ends (0 -> 0, all ones -> 255)
    assert np.array_equal(rgb[:, 0] >> 3, r) and np.array_equal(rgb[:, 1] >> 2, g)
    assert np.array_equal(rgb[:, 2] >> 3, b)
    assert np.array_equal(rgb[:, 0], (r << 3) | (r >> 2)) and np.array_equal(rgb[:, 1], (g << 2) | (g >> 4))
    assert rgb[0].tolist() == [0, 0, 0] and rgb[-1].tolist() == [255, 255, 255]


def test_narrowing_truncates_each_channel():
    c = np.random.default_rng(1).integers(0, 256, (1000, 3))
    w = rgb565(c)
    assert np.array_equal(w >> 11, c[:, 0] // 8) and np.array_equal(w >> 5 & 63, c[:, 1] // 4)
    assert np.array_equal(w & 31, c[:, 2] // 8)


def test_the_frame_sits_at_the_top_left_with_black_around_it():
    color = np.full((3, 5, 4), 200)
    pic = display_frame(color, 8, 6)
    assert pic.shape == (6, 8, 3)
    assert (pic[:3, :5] == expand565(rgb565(np.array([200, 200, 200])))).all()
    assert not pic[3:].any() and not pic[:, 5:].any()


def test_the_system_needs_the_tile_on_chip_and_inside_the_display():
    from board.frame import board_engine
    params = board_engine(size=16)[0]
    with pytest.raises(ValueError, match="on chip"):
        EngineSystem(dataclasses.replace(params, rop=dataclasses.replace(params.rop, on_chip=False)), VGA_640x480, 25)
    with pytest.raises(ValueError, match="exceeds"):
        EngineSystem(params, SMALL, 25)
    assert EngineSystem(params, VGA_640x480, 25).record_len == -(-sum(p.fmt.width for p in
                                                                      params.raster.record) // 8)


def test_the_board_engine_draws_a_wide_scene_on_the_square_tile():
    """The frame on chip is one ``size x size`` tile: a 320 x 200 scene (the Berlin wall) is drawn at the tile's
    size, not at its width with the aspect kept (an int size keeps the aspect, ``host.scene.scene_at``)."""
    from board.frame import board_engine
    params, frame, _ = board_engine("berlin-wall", preset="default", size=16)
    assert (frame.scene.width, frame.scene.height) == (16, 16)
    assert (params.rop.width, params.rop.height) == (16, 16)


def _fragments(P, rng, k, z_lo, z_hi):
    """``k`` fragments (codes of ``P.inputs``) inside the tile, depth codes in ``[z_lo, z_hi)``."""
    idx = rng.integers(0, P.pixels, k)
    return np.stack([idx % P.width, idx // P.width, rng.integers(z_lo, z_hi, k),
                     *(rng.integers(0, 256, k) for _ in range(3)), rng.integers(0, 1 << P.flag_bits, k)], axis=1)


def _tile_system(P, **kw):
    """``(module, rop, tile copy, store)``: the on-chip depth test, its ``TileCopy`` (``kw``; quiet 8 clocks) and a
    frame store of two buffers written by the copy."""
    from amaranth import Module
    from amaranth.lib import memory, wiring

    from board.frame import TileCopy
    from rtl.rop import Rop
    m = Module()
    m.submodules.rop = rop = Rop(P)
    m.submodules.copy = tc = TileCopy(P, rop.fb.signature, quiet=8, **kw)
    m.submodules.store = store = memory.Memory(shape=16, depth=2 * P.pixels, init=[])
    wr = store.write_port()
    wiring.connect(m, tc.fb, rop.fb)
    m.d.comb += [tc.active.eq(rop.i.valid | rop.busy), wr.addr.eq(tc.w_addr), wr.data.eq(tc.w_data),
                 wr.en.eq(tc.w_en)]
    return m, rop, tc, store


async def _draw(ctx, rop, P, frags):
    """The fragments into the depth test, one a clock while it is ready."""
    from cosim.raster import pack
    for word in pack(P.inputs, frags):
        ctx.set(rop.i.valid, 1)
        ctx.set(rop.i.payload.as_value(), word)
        await ctx.tick().until(rop.i.ready)
    ctx.set(rop.i.valid, 0)


async def _pulse(ctx, sig, value=1):
    ctx.set(sig, value)
    await ctx.tick()
    ctx.set(sig, 0)


async def _clear(ctx, tc, P, place=None) -> tuple[bool, bool]:
    """FRAME_START's pulse (``place``: the place input moved to it right after the pulse, before the clear
    begins); ``(stall raised, stall fallen again: the tile cleared)``."""
    await _pulse(ctx, tc.start)
    if place is not None:
        ctx.set(tc.place, place)
    stalled = bool(ctx.get(tc.stall))
    for _ in range(10 * P.pixels):
        await ctx.tick()
        if not ctx.get(tc.stall):
            break
    return stalled, not ctx.get(tc.stall)


@pytest.mark.parametrize("gaps", [False, True], ids=["room", "gaps"])
def test_frame_start_clears_the_tile_and_swap_copies_it_in_rgb565(gaps):
    """The tile's control (``TileCopy``) with the on-chip depth test (``rtl/rop.py``) and a frame store, in
    Amaranth's simulator: frame A drawn, SWAP copies it into the back buffer; FRAME_START stalls the input and
    clears the tile; frame B, all farther than A (without the clear most of it would fail the depth test), drawn
    and copied into the other buffer. Each buffer equals the model's frame (``fxmodel.units.rop.draw``) of its
    fragments alone, through RGB565; the depth test's flags are the frame's (A's fragment outside the tile sets
    ``outside``, the clear clears it, B leaves it clear). ``gaps``: ``room`` (the SDRAM copy's FIFO) falls at
    random, half the clocks: every word is still written once, at its address."""
    from amaranth.sim import Simulator

    from fxmodel.units.rop import STATUS_BITS, RopParams, draw

    P = RopParams(width=8, height=4, on_chip=True)
    rng = np.random.default_rng(5)
    half = 1 << (P.z_in.frac_bits - 1)
    frame_a, frame_b = _fragments(P, rng, 40, half, 2 * half), _fragments(P, rng, 12, 1, half)
    frame_a[7, 0] = P.width + 1                         # one fragment of frame A outside the tile: ``outside``
    want = [rgb565(draw(P, f)[1][..., :3]).ravel() for f in (frame_a, frame_b)]
    assert not np.array_equal(want[1], rgb565(draw(P, np.concatenate([frame_a, frame_b]))[1][..., :3]).ravel())

    m, rop, tc, store = _tile_system(P)
    seen = {}

    async def bench(ctx):
        async def copy():
            before = ctx.get(tc.copied)
            await _pulse(ctx, tc.swap)
            for _ in range(20 * P.pixels):
                await ctx.tick()
                if ctx.get(tc.copied) != before:
                    break
            for _ in range(4):                            # the store's write from its registers
                await ctx.tick()

        await _draw(ctx, rop, P, frame_a)
        await copy()
        seen["status_a"] = ctx.get(rop.status)
        await _pulse(ctx, tc.shown)
        seen["stall"], seen["cleared"] = await _clear(ctx, tc, P)
        seen["status_cleared"] = ctx.get(rop.status)
        await _draw(ctx, rop, P, frame_b)
        await copy()
        seen["status_b"] = ctx.get(rop.status)
        seen["store"] = [ctx.get(store.data[a]) for a in range(2 * P.pixels)]

    async def room(ctx):
        r = np.random.default_rng(9)
        seen["writes"] = 0
        while True:
            if gaps:
                ctx.set(tc.room, int(r.random() < 0.5))
            await ctx.tick()
            seen["writes"] += ctx.get(tc.w_en)

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.add_testbench(room, background=True)
    sim.run()
    assert seen["stall"] and seen["cleared"]
    outside = 1 << STATUS_BITS["outside"]
    assert (seen["status_a"], seen["status_cleared"], seen["status_b"]) == (outside, 0, 0)   # the frame's flags
    assert seen["writes"] == 2 * P.pixels                            # each word of each copy written once
    store_words = np.array(seen["store"])
    assert np.array_equal(store_words[P.pixels:], want[0])          # the back buffer first (index 1): frame A
    assert np.array_equal(store_words[:P.pixels], want[1])          # then buffer 0: frame B on the cleared tile


@pytest.mark.parametrize("wait_every_copy", [False, True], ids=["chip", "sdram"])
def test_copy_puts_a_tile_at_its_place_and_only_swap_shows(wait_every_copy):
    """A picture of two tiles: FRAME_START at place 2, tile A, COPY; FRAME_START at place 1, tile B, SWAP. Each copy
    offers the place its tile was started with (taken with FRAME_START's pulse, though the place input has moved
    on by then) and whether it shows (COPY's no, SWAP's yes); COPY toggles no ``copied`` and leaves the back
    buffer where it is (so with the frame on chip the SWAP's tile overwrites it); with ``wait_every_copy`` (the
    frame in SDRAM, whose ``shown`` is a copy's last write) the SWAP's copy waits for COPY's ``shown``, without it
    it does not wait."""
    from amaranth.sim import Simulator

    from fxmodel.units.rop import RopParams, draw

    P = RopParams(width=4, height=2, on_chip=True)
    rng = np.random.default_rng(7)
    tiles = [_fragments(P, rng, 10, 1, 1 << P.z_in.frac_bits) for _ in range(2)]
    want = [rgb565(draw(P, f)[1][..., :3]).ravel() for f in tiles]
    m, rop, tc, store = _tile_system(P, place_bits=2, wait_every_copy=wait_every_copy)
    seen = {"copies": []}

    async def bench(ctx):
        for k, (place, end) in enumerate(((2, tc.copy), (1, tc.swap))):
            ctx.set(tc.place, place)
            await _clear(ctx, tc, P, place=3)               # moves on: the tile keeps the place of its start
            await _draw(ctx, rop, P, tiles[k])
            before = ctx.get(tc.copied)
            await _pulse(ctx, end)
            for _ in range(10 * P.pixels):
                await ctx.tick()
            seen[f"toggled_{k}"] = ctx.get(tc.copied) != before
            seen[f"store_{k}"] = [ctx.get(store.data[a]) for a in range(2 * P.pixels)]
        await _pulse(ctx, tc.shown)                          # COPY's last write (sdram): the SWAP's copy may go
        for _ in range(10 * P.pixels):
            await ctx.tick()
        seen["store"] = [ctx.get(store.data[a]) for a in range(2 * P.pixels)]

    async def watch(ctx):
        writing = False
        while True:
            await ctx.tick()
            if ctx.get(tc.w_en) and not writing:
                seen["copies"].append((ctx.get(tc.copy_place), ctx.get(tc.copy_show)))
            writing = bool(ctx.get(tc.w_en))

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.add_testbench(watch, background=True)
    sim.run()
    assert seen["copies"] == [(2, 0), (1, 1)]                       # each copy's place and show
    assert not seen["toggled_0"]                                    # COPY shows nothing
    assert seen["toggled_1"] != wait_every_copy                     # SWAP's copy waits for COPY's end (sdram)
    words = np.array(seen["store"])
    assert np.array_equal(words[P.pixels:], want[1])                # both into the back buffer (index 1)
    assert np.array_equal(np.array(seen["store_0"])[P.pixels:], want[0])   # A there before B overwrote it


def test_quiet_outlasts_the_engine_so_a_clear_begins_with_the_depth_test_idle():
    """The tile copy starts a clearing read-out once the engine's input, scan converter and depth test have been
    quiet for ``QUIET`` clocks; the pixel pipeline's fragments are not in that signal, so ``QUIET`` must outlast
    the longest a fragment can take from the scan converter's output to the depth test's last stage (its
    rounding stage and output FIFO, the pipeline's input registers, delay line and output FIFO, the depth test):
    then no fragment is in the depth test when the clear begins, the contract its proof assumes
    (``formal/rop_chip.py``, ``clear_begins_quiet``)."""
    from board.cdc import QUIET
    from board.frame import board_engine
    from fxmodel.pipeline.engine import PIPELINE_IN_STAGES
    from rtl.streams import buffer_depth

    ep, _, _ = board_engine()
    R = ep.raster
    drain = (1 + R.OUT_FIFO_DEPTH) + ep.latency + buffer_depth(ep.pipeline, PIPELINE_IN_STAGES) + ep.rop.latency
    assert drain < QUIET, (drain, QUIET)
