"""The raster-operations model (``fxmodel/units/rop.py``): the depth rule against an independent order-statistics
oracle, the depth narrowing against exact rationals, the memory image, validation, ``info``; and the RTL's address
extremes in ``amaranth.sim`` (no address outside the frame is formed)."""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.units.rop import PIXEL_BYTES, RopParams, clear_frame, draw, read_frame, write_frame

SMALL = RopParams.PRESETS["small"]


def exact_depth(params, code):
    """The stored depth of a ``z_in`` code by exact rationals: floor to ``z_fmt``'s ulp, clamped to its range."""
    v = Fraction(int(code), 1 << params.z_in.frac_bits)
    q = math.floor(v / params.z_fmt.ulp)
    return min(max(q, 0), params.z_fmt.max_code)


def oracle(params, frags):
    """Per pixel: the fragments on it whose depth beats the clear depth; the winner has the largest depth, the
    earliest of those on a tie (a statement about the set, not a replay of the loop)."""
    depth, color = clear_frame(params)
    for yy in range(params.height):
        for xx in range(params.width):
            rows = [k for k in range(len(frags)) if frags[k][0] == xx and frags[k][1] == yy]
            cands = [(exact_depth(params, frags[k][2]), -k) for k in rows
                     if exact_depth(params, frags[k][2]) > params.clear_depth]
            if cands:
                d, negk = max(cands)
                depth[yy, xx] = d
                color[yy, xx] = frags[-negk][3:]
    return depth, color


@st.composite
def fragments(draw_, params):
    k = draw_(st.integers(1, 60))
    pf, zf = params.pixel_fmt, params.z_in
    xs = st.integers(0, min(params.width + 1, pf.max_code))
    ys = st.integers(0, min(params.height + 1, pf.max_code))
    zs = st.one_of(st.integers(zf.min_code, zf.max_code), st.sampled_from([0, 1, 128, 129, 255, 256]))
    rows = [[draw_(xs), draw_(ys), draw_(zs), draw_(st.integers(0, 255)), draw_(st.integers(0, 255)),
             draw_(st.integers(0, 255)), draw_(st.integers(0, 31))] for _ in range(k)]
    return np.array(rows, dtype=np.int64)


TINY = dataclasses.replace(SMALL, width=3, height=2)


@settings(max_examples=150, deadline=None)
@given(fragments(TINY))
def test_draw_keeps_the_nearest_first_drawn_fragment(frags):
    depth, color, stats = draw(TINY, frags)
    want_d, want_c = oracle(TINY, frags)
    assert np.array_equal(depth, want_d) and np.array_equal(color, want_c)
    inside = int(np.sum((frags[:, 0] < TINY.width) & (frags[:, 1] < TINY.height)))
    assert stats["outside"] == len(frags) - inside
    assert stats["passed"] + stats["failed"] == inside
    assert stats["bytes_read"] == 4 * inside and stats["bytes_written"] == PIXEL_BYTES * stats["passed"]


@given(st.integers(-(1 << 23), (1 << 23) - 1))
def test_depth_narrowing_is_floor_then_saturate(code):
    codes, sat = SMALL.depth_codes([code])
    assert int(codes[0]) == exact_depth(SMALL, code)
    assert bool(sat[0]) == (code < 0 or math.floor(Fraction(code, 1 << 22) / SMALL.z_fmt.ulp) > SMALL.z_fmt.max_code)


def test_default_depth_word_is_exact():
    P = RopParams.PRESETS["default"]
    assert P.z_fmt == Fmt(False, 1, 22)
    codes, sat = P.depth_codes([0, 1, 1 << 22, (1 << 23) - 1])
    assert codes.tolist() == [0, 1, 1 << 22, (1 << 23) - 1] and not sat.any()


def test_ties_keep_the_first_and_clear_depth_is_infinitely_far():
    f = np.array([[1, 1, 0, 9, 9, 9, 1], [1, 1, 640, 1, 2, 3, 0], [1, 1, 640, 4, 5, 6, 0]])
    depth, color, stats = draw(SMALL, f)
    assert color[1, 1].tolist() == [1, 2, 3, 0] and depth[1, 1] == 5 and stats["passed"] == 1


def test_memory_image_round_trips_and_refuses_bad_images():
    rng = np.random.default_rng(1)
    d = rng.integers(0, SMALL.z_fmt.max_code + 1, (SMALL.height, SMALL.width))
    c = rng.integers(0, 256, (SMALL.height, SMALL.width, 4))
    img = write_frame(SMALL, d, c)
    assert len(img) == SMALL.frame_bytes == 8 * 16 * 12
    assert img[:4] == int(d[0, 0]).to_bytes(4, "little") and list(img[4:8]) == c[0, 0].tolist()
    d2, c2 = read_frame(SMALL, img)
    assert np.array_equal(d, d2) and np.array_equal(c, c2)
    with pytest.raises(ValueError, match="image"):
        read_frame(SMALL, img[:-1])
    bad = bytearray(img)
    bad[8 * 5 + 2] = 0xFF                                   # pixel 5's depth beyond z_fmt
    with pytest.raises(ValueError, match="pixel"):
        read_frame(SMALL, bytes(bad))


@pytest.mark.parametrize("change, param", [
    ({"width": 300}, "width"), ({"base": 4}, "base"), ({"addr_bits": 12, "width": 256, "height": 3}, "base"),
    ({"z_fmt": Fmt(True, 1, 15)}, "z_fmt"), ({"z_fmt": Fmt(False, 1, 23)}, "z_fmt"), ({"flag_bits": 9}, "flag_bits"),
    ({"data_bits": 96}, "data_bits"), ({"clear_depth": 1 << 16}, "clear_depth"),
    ({"clear_color": (0, 0)}, "clear_color"),
    ({"outstanding": 1}, "outstanding")])
def test_bad_parameters_are_refused_by_name(change, param):
    with pytest.raises(ValueError, match=param):
        dataclasses.replace(SMALL, **change)


def test_info_states_the_rule_formats_and_traffic():
    info = RopParams.PRESETS["default"].info()
    assert info["depth"]["stored"] == "u1.22" and info["depth"]["rounding"] == "TRUNC"
    assert "first drawn wins" in info["depth"]["rule"]
    assert info["memory"]["read_bytes_per_fragment"] == 4 and info["memory"]["write_bytes_per_passed_fragment"] == 8
    assert RopParams.PRESETS["on_chip"].cost()["frame_bits"] == 64 * 64 * (23 + 24 + 5)


def test_rtl_addresses_stay_in_the_frame_at_the_extremes():
    """``amaranth.sim``: the corners of the frame give ``base`` and ``base + 8 (width height - 1)`` on ``AR``;
    ``x = width``, ``y = height`` and the largest pixel codes are dropped (``status`` bit 0) without a read."""
    from amaranth.sim import Simulator

    from rtl.rop import Rop

    P = dataclasses.replace(SMALL, base=8 * 1000)
    dut = Rop(P)
    pf = P.pixel_fmt.max_code
    frags = [(0, 0), (P.width - 1, P.height - 1), (P.width, 0), (0, P.height), (pf, pf)]
    seen = {"ar": [], "status": 0}

    async def bench(ctx):
        ctx.set(dut.axi.arready, 1)
        for x, y in frags:
            ctx.set(dut.i.payload, {"x": x, "y": y, "z": 128, "r": 1, "g": 2, "b": 3, "flags": 0})
            ctx.set(dut.i.valid, 1)
            await ctx.tick().until(dut.i.ready)
        ctx.set(dut.i.valid, 0)
        await ctx.tick().repeat(6)
        seen["status"] = ctx.get(dut.status)

    sim = Simulator(dut)
    sim.add_clock(1e-6)

    async def watch(ctx):
        async for _, _, valid, ready, addr in ctx.tick().sample(dut.axi.arvalid, dut.axi.arready, dut.axi.araddr):
            if valid and ready:
                seen["ar"].append(addr)

    sim.add_testbench(bench)
    sim.add_process(watch)
    sim.run_until(60e-6)
    ar = sorted(set(seen["ar"]))
    assert ar == [P.base, P.base + 8 * (P.pixels - 1)] and seen["status"] & 1


def test_engine_with_depth_draws_an_overlapping_scene():
    """The model of the engine with its depth test on the overlapping shipped scene: every pixel the float front
    end shows is written, the others keep the background, some fragments fail the test, and the frame is within
    one LSB of the frame drawn from the front end's fragments except where the two surfaces cross."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    frame = prepare(scene_path("tin-sphere"), size=32, cube_size=8)
    tf = from_triangles(frame, depth=True)
    depth, color = tf.fb
    dt = tf.stats["depth_test"]
    visible = np.zeros(depth.shape, bool)
    visible.ravel()[np.asarray(frame.frags.index)] = True
    assert np.all(depth[visible] > 0) and np.all(depth[~visible] == 0)
    bg = tf.params.rop.clear_color
    assert np.all(color[~visible][:, :3] == bg)
    assert dt["failed"] > 0 and dt["passed"] + dt["failed"] == dt["fragments"] == len(tf.out)
    assert dt["bytes_read"] == 4 * dt["fragments"] and dt["bytes_written"] == 8 * dt["passed"]
    covered = int(visible.sum())
    assert dt["bytes_read_per_pixel"] == pytest.approx(dt["bytes_read"] / covered, abs=1e-3)
    assert dt["bytes_written_per_pixel"] == pytest.approx(dt["bytes_written"] / covered, abs=1e-3)


def test_engine_rop_must_match_the_raster():
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.pipeline.pixel import PipelineParams
    from fxmodel.units.raster import RasterParams
    pipe = PipelineParams.PRESETS["default"]
    raster = RasterParams.for_pipeline({"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect})
    good = RopParams(width=16, height=16, max_size=raster.max_size, z_in=raster.out_fmt("Z"))
    EngineParams(raster=raster, pipeline=pipe, rop=good)
    for change, name in (({"max_size": 1024}, "rop.max_size"), ({"flag_bits": 4}, "rop.flag_bits"),
                         ({"z_in": Fmt(True, 3, 22)}, "rop.z_in")):
        with pytest.raises(ValueError, match=name):
            EngineParams(raster=raster, pipeline=pipe, rop=dataclasses.replace(good, **change))
