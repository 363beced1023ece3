"""Co-simulation of the raster-operations unit (``rtl/rop.py``) against :func:`fxmodel.units.rop.draw`: the final frame
decoded from the memory model's image, bit for bit, and the bus traffic, with random fragment gaps, memory
latency from 1 to 20 cycles and random wait states on every AXI channel; the same-pixel hazard provoked in every
order; and proof that these tests can fail (the hazard check disabled gives a different frame)."""

import dataclasses

import numpy as np
import pytest

from cosim.rop import run
from fxmodel.units.rop import STATUS_BITS, RopParams

SMALL = RopParams.PRESETS["small"]


def random_fragments(params, k, seed, hot=6):
    """``k`` fragments, most on ``hot`` pixels (overdraw, so that depth decides), some anywhere in the frame,
    the frame's corners, a few outside it (dropped and flagged) and depths at both ends of ``z_in`` (negative:
    saturates to infinitely far)."""
    rng = np.random.default_rng(seed)
    P = params
    px = rng.integers(0, P.pixels, hot)
    idx = np.where(rng.random(k) < 0.7, px[rng.integers(0, hot, k)], rng.integers(0, P.pixels, k))
    x, y = idx % P.width, idx // P.width
    z = rng.integers(0, 1 << P.z_in.frac_bits, k)
    z[rng.random(k) < 0.1] = z[0]                                        # equal depths: ties
    corners = [(0, 0), (P.width - 1, 0), (0, P.height - 1), (P.width - 1, P.height - 1)]
    outside = [(P.width, 0), (0, P.height), (P.pixel_fmt.max_code, P.pixel_fmt.max_code)]
    for j, (cx, cy) in enumerate(corners + outside):
        x[5 + 7 * j], y[5 + 7 * j] = cx, cy
    z[3], z[11] = P.z_in.min_code, P.z_in.max_code
    rgbf = rng.integers(0, 256, (k, 3)), rng.integers(0, 1 << P.flag_bits, (k, 1))
    return np.column_stack([x, y, z, *rgbf])


def hazard_pairs(params, order, gap=0, first=0):
    """Pairs of fragments on one pixel back to back (``gap`` other fragments between them), each pair on a fresh
    pixel from index ``first`` on: ``order`` ``nearer_first``, ``farther_first`` or ``equal`` depths; different
    colors. Groups drawn one after another need their own pixels (``first``): a pair on a pixel an earlier pair
    left at the same depth is decided by that depth whether or not the hazard is handled."""
    P = params
    rows = []
    for i in range(min(P.pixels // (gap + 1), 40)):
        base = 1000 + 997 * i
        a, b = {"nearer_first": (base + 600, base), "farther_first": (base, base + 600),
                "equal": (base, base)}[order]
        x, y = (first + i) % P.width, (first + i) // P.width
        rows.append([x, y, a << 7, 10, 20, 30, 1])
        for g in range(gap):
            j = P.pixels - 1 - (i * gap + g)
            rows.append([j % P.width, j // P.width, 5 << 7, 1, 2, 3, 0])
        rows.append([x, y, b << 7, 40, 50, 60, 2])
    return np.array(rows, dtype=np.int64)


@pytest.mark.parametrize("latency, p_valid, p_pause", [(1, 1.0, 0.0), (3, 0.6, 0.3), (20, 0.9, 0.2)])
def test_rop_rtl_matches_the_model(sim, latency, p_valid, p_pause):
    frags = random_fragments(SMALL, 300, seed=latency)
    res = run(SMALL, frags, latency=latency, p_valid=p_valid, p_pause=p_pause, seed=latency, sim=sim,
              tag=f"random_{latency}")
    model = res["model"]
    assert res["mismatches"] == 0, res["first"]
    assert model["passed"] > 20 and model["failed"] > 100 and model["outside"] == 3 and model["z_saturated"] >= 1
    assert (res["rtl_bytes_read"], res["rtl_bytes_written"]) == (model["bytes_read"], model["bytes_written"])
    assert res["status"] == (1 << STATUS_BITS["outside"]) | (1 << STATUS_BITS["z_saturated"])


@pytest.mark.parametrize("order", ["nearer_first", "farther_first", "equal"])
@pytest.mark.parametrize("latency", [1, 20])
def test_same_pixel_in_flight_gives_the_sequential_frame(sim, order, latency):
    """Two fragments of one pixel back to back, and with two others between them: the second is accepted while
    the first's read or write is still in flight. Every order of their depths gives the model's frame; the pass
    and fail counts show that the second one was decided against the first one's write."""
    frags = np.concatenate([hazard_pairs(SMALL, order), hazard_pairs(SMALL, order, gap=2, first=40)[:60]])
    res = run(SMALL, frags, latency=latency, sim=sim, tag=f"hazard_{order}_{latency}")
    assert res["mismatches"] == 0, res["first"]
    pairs = len(frags) // 2
    assert res["model"]["passed"] >= (2 if order == "farther_first" else 1) * (pairs // 3)
    assert (res["rtl_bytes_read"], res["rtl_bytes_written"]) == (res["model"]["bytes_read"],
                                                                 res["model"]["bytes_written"])


@pytest.mark.parametrize("on_chip", [False, True])
def test_the_hazard_test_can_fail(sim, on_chip):
    """Without the scoreboard (port) or the forwarding (on chip) the second fragment of a pair reads the depth
    from before the first one's write: the nearer-first and equal pairs then overwrite the winner."""
    P = dataclasses.replace(RopParams.PRESETS["on_chip"] if on_chip else SMALL, hazard=False)
    frags = np.concatenate([hazard_pairs(P, "nearer_first"), hazard_pairs(P, "equal", first=40)])
    res = run(P, frags, latency=5, sim=sim, tag="nohazard")
    assert res["mismatches"] >= 20


@pytest.mark.parametrize("p_valid", [0.8, 1.0])
def test_on_chip_frame_buffer(sim, p_valid):
    """Random fragments, then pairs on one pixel back to back and with one to four fragments between them (the
    first one's write forwarded to the second's compare: ``rtl/rop.py`` forwards the five writes just ahead) and
    with five and six between them (read from the block RAM), with and without input gaps; the read-out clears
    (``fb.clear``): a second read-out is the clear frame, and the sticky flags the fragments set are clear."""
    P = RopParams.PRESETS["on_chip"]
    groups = [("nearer_first", 0, 80), ("equal", 0, 80), ("nearer_first", 1, 40), ("farther_first", 1, 40),
              ("equal", 2, 40), ("nearer_first", 3, 40), ("equal", 4, 40), ("nearer_first", 4, 40),
              ("nearer_first", 5, 40), ("equal", 6, 40)]
    frags = np.concatenate([random_fragments(P, 300, seed=3, hot=4)]
                           + [hazard_pairs(P, order, gap=gap, first=1000 + 40 * k)[:rows]
                              for k, (order, gap, rows) in enumerate(groups)])
    res = run(P, frags, p_valid=p_valid, sim=sim, tag=f"onchip_{p_valid}")
    assert res["mismatches"] == 0, res["first"]
    assert res["cleared_mismatches"] == 0           # the read-out with fb.clear left the clear frame behind
    assert res["status"] == (1 << STATUS_BITS["outside"]) | (1 << STATUS_BITS["z_saturated"])
    assert res["status_cleared"] == 0               # ... and cleared the frame's flags


def test_wide_bus_lanes_and_base(sim):
    """A 128-bit bus (two pixel words per beat: the depth read and the write strobes select the lane) and a
    frame based at an odd pixel word, over memory with older contents."""
    P = dataclasses.replace(SMALL, data_bits=128, base=8 * 13, outstanding=8)
    rng = np.random.default_rng(9)
    fb = (rng.integers(0, 1 << 10, (P.height, P.width)), rng.integers(0, 256, (P.height, P.width, 4)) & 0x1F)
    res = run(P, random_fragments(P, 200, seed=4), latency=4, p_pause=0.2, sim=sim, tag="wide", fb=fb)
    assert res["mismatches"] == 0, res["first"]


def test_one_fragment_per_clock_when_the_memory_keeps_up(sim):
    """Distinct pixels, no gaps, no wait states, 16 slots: at the largest memory latency whose round trip
    ``2 L + SLOT_OVERHEAD`` fits the slots every fragment is accepted in its own clock; one cycle of latency more
    and the slots run out (so the documented bound is the true one, not just a safe one)."""
    from rtl.rop import SLOT_OVERHEAD

    P = dataclasses.replace(SMALL, outstanding=16)
    k = 150
    i = np.arange(k)
    frags = np.stack([i % P.width, i // P.width, i * 1000 + 5, i % 256, i % 256, i % 256, i % 32], 1)
    latency = (P.outstanding - SLOT_OVERHEAD) // 2
    res = run(P, frags, latency=latency, sim=sim, tag="rate")
    assert res["mismatches"] == 0 and res["accept_cycles"] == k
    res = run(P, frags, latency=latency + 1, sim=sim, tag="rate_over")
    assert res["mismatches"] == 0 and res["accept_cycles"] > k


def overlapping_records(raster, width, height, n, seed):
    """``n`` random triangles over a ``width x height`` viewport, overlapping each other (some drawn twice, so
    that equal depths meet), with ``Z`` and ``W`` in ``(0, 1]`` and the other attributes anywhere in their
    formats."""
    from fxmodel.units.raster import setup
    rng = np.random.default_rng(seed)
    S = raster.S
    X = rng.integers(-S, (width + 1) * S, (n, 3))
    Y = rng.integers(-S, (height + 1) * S, (n, 3))
    vals = {name: rng.uniform(-0.9, 0.9, (n, 3)) * float(fmt.max_value) for name, fmt in raster.attrs}
    vals["Z"] = rng.uniform(0.05, 1.0, (n, 3))
    vals["W"] = rng.uniform(0.2, 1.0, (n, 3))
    for name, fmt in raster.consts:                                   # per-triangle constants (the bump's Ae)
        vals[name] = rng.integers(fmt.min_code, fmt.max_code + 1, n)
    X[-2:], Y[-2:] = X[:2], Y[:2]                                     # two triangles again: equal depths
    for name in vals:
        vals[name][-2:] = vals[name][:2]
    return setup(raster, X, Y, vals, width, height)


def engine_params(width, height, **rop):
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.pipeline.pixel import PipelineParams
    from fxmodel.units.raster import RasterParams
    pipe = PipelineParams.PRESETS["default"]
    raster = RasterParams.for_pipeline({"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect})
    return EngineParams(raster=raster, pipeline=pipe, rop=RopParams(
        width=width, height=height, max_size=raster.max_size, z_in=raster.out_fmt("Z"), **rop))


@pytest.mark.parametrize("latency, p_valid, p_pause", [pytest.param(1, 1.0, 0.0, marks=pytest.mark.slow),
                                                       (20, 0.7, 0.3)])
def test_engine_with_depth_draws_the_models_frame(sim, latency, p_valid, p_pause):
    """The engine from the triangle with its depth test behind the memory port, on overlapping random triangles:
    the frame read from the memory model equals the model's, and so does the bus traffic. ``make test`` runs the
    hard case (latency 20, input gaps, wait states on every channel); the netlist build (Yosys on the whole
    pipeline) costs about a minute, once. The full-size overlapping scene: ``bumpmap sim --scene
    tin-sphere --input triangles --depth --latency 20 --wait-states 0.3``."""
    from cosim.rop import run_engine
    params = engine_params(16, 12)
    recs = overlapping_records(params.raster, 16, 12, 10, seed=latency)
    res = run_engine(params, recs, latency=latency, p_valid=p_valid, p_pause=p_pause, sim=sim, tag=f"engine_{latency}")
    assert res["mismatches"] == 0, res["first"]
    assert res["model"]["failed"] > 20 and res["model"]["passed"] > 100
    assert (res["rtl_bytes_read"], res["rtl_bytes_written"]) == (res["model"]["bytes_read"],
                                                                 res["model"]["bytes_written"])
