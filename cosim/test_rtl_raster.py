"""Co-simulation of the scan converter RTL against the model: every fragment bit for bit, the fragment count, and
the clock count (cycles with ``busy`` high equal the model's ``sum max(1, span)`` when the sink never stalls, and
follow one another with no gap when the source does not wait either), over random
triangles and the hard cases, with gaps on the input and backpressure on the output."""

import numpy as np
import pytest

from cosim.raster import pack, run, unpack
from cosim.stream import PATTERNS, run_records
from fxmodel.units.raster import RasterParams, scan, setup

S = 256


def hard_and_random(params, width, height, n_random, seed):
    """Slivers, long thin triangles across the viewport, vertices on pixel centres and edges, tiny triangles
    covering one pixel or none, a shared-edge pair, ``W`` at the bottom of its range, and random triangles."""
    rng = np.random.default_rng(seed)
    tris = [
        ([S // 2, S // 2 + S, S // 2], [S // 2, S // 2, S // 2 + S]),                 # one pixel, on centres
        ([10, 20, 15], [10, 10, 30]),                                                 # none
        ([S // 2, S // 2 + 1, S // 2], [S // 2, S // 2, S // 2 + 1]),                 # one pixel, top-left
        ([-3 * S, (width + 3) * S, 5], [S, 2 * S + 7, 2 * S]),                          # long and thin
        ([0, width * S, width * S], [0, height * S, height * S + 3]),                 # a diagonal sliver
        ([0, width * S, 0], [0, 0, height * S]), ([width * S, width * S, 0], [0, height * S, height * S]),  # pair
        ([S * 3, S * 3, S * 9], [S * 2, S * 9, S * 9 // 2]),                            # pixel edges
    ]
    for _ in range(n_random):
        lo, hi = -4 * S, (max(width, height) + 4) * S
        tris.append((rng.integers(lo, hi, 3).tolist(), rng.integers(lo, hi, 3).tolist()))
    for _ in range(n_random // 2):                                                    # small ones
        c = rng.integers(0, width * S, 2)
        tris.append(((c[0] + rng.integers(-3 * S, 3 * S, 3)).tolist(),
                     (c[1] + rng.integers(-3 * S, 3 * S, 3)).tolist()))
    X, Y = np.array([t[0] for t in tris]), np.array([t[1] for t in tris])
    vals = {}
    for name, fmt in params.attrs:
        lim = float(fmt.max_value) * 0.999
        vals[name] = rng.uniform(-lim, lim, X.shape)
    for name, fmt in params.consts:                                                  # e.g. Ae
        vals[name] = rng.integers(fmt.min_code, fmt.max_code, X.shape[0], endpoint=True)
    if "W" in vals:
        vals["W"][-4:] = rng.uniform(0, 3, (4, 3)) * float(params.out_fmt("W").ulp)  # W at the bottom
        vals["W"][0] = float(params.out_fmt("W").max_value)
    return setup(params, X, Y, vals, width, height)


def test_pack_round_trips():
    params = RasterParams.PRESETS["default"]
    recs = hard_and_random(params, 40, 30, 4, 1)
    assert np.array_equal(unpack(params.record, pack(params.record, recs.matrix())), recs.matrix())


@pytest.mark.parametrize("preset, p_valid, p_ready, size, n", [
    ("small", 1.0, 1.0, (48, 40), 24), ("small", 0.5, 0.5, (24, 20), 8), ("small", 0.9, 0.05, (12, 10), 4),
    ("default", 1.0, 1.0, (40, 32), 8), ("default", 0.3, 0.7, (12, 10), 4)])
def test_raster_rtl_matches_the_model(sim, preset, p_valid, p_ready, size, n):
    params = RasterParams.PRESETS[preset]
    recs = hard_and_random(params, *size, n, seed=int(p_valid * 10 + p_ready * 100))
    res = run(params, recs, p_valid=p_valid, p_ready=p_ready, sim=sim, tag=f"{preset}_{p_valid}_{p_ready}")
    assert res["expected"] > 60 and res["mismatches"] == 0, res
    if p_ready == 1.0:
        assert res["busy_cycles"] == res["clocks"], res
    if p_valid == p_ready == 1.0:                 # no clock lost between rows or triangles
        assert res["busy_span"] == res["busy_cycles"], res


@pytest.mark.parametrize("preset", ["small", "default"])
def test_saturating_increments_flag_as_the_model(sim, preset):
    """Increments at random codes (records no set-up writes, as a hostile file's may be): the accumulators leave
    the output format, the output rounding saturates and flags (each attribute's flag registered beside its
    rounded value, the fragment's flag their OR); every fragment, flags included, equal to the model."""
    params = RasterParams.PRESETS[preset]
    recs = hard_and_random(params, 24, 20, 8, seed=5)
    rng = np.random.default_rng(9)
    for p in params.record:
        if p.name.endswith("_dx"):
            recs.codes[p.name] = rng.integers(p.fmt.min_code, p.fmt.max_code, len(recs.codes[p.name]),
                                              endpoint=True)
    flags = scan(params, recs.matrix()).codes["flags"]
    assert 100 < flags.sum() < len(flags)                       # saturated and not, both many times
    res = run(params, recs, p_valid=0.7, p_ready=0.7, sim=sim, tag=f"sat_{preset}")
    assert res["expected"] == len(flags) and res["mismatches"] == 0, res


@pytest.mark.parametrize("preset, p_valid, p_ready, size, n", [
    ("small", 1.0, 1.0, (48, 40), 24), ("default", 0.5, 0.5, (40, 32), 8)])
def test_span_start_in_logic_matches_the_model(sim, preset, p_valid, p_ready, size, n):
    """``span_dsp`` off: the span start's products as a carry-save tree of shifted copies in logic (no multiplier
    block), the same sums modulo ``2**N``."""
    import dataclasses
    params = dataclasses.replace(RasterParams.PRESETS[preset], span_dsp=False)
    assert params.products() == () and params.cost()["dsp"] == 0
    recs = hard_and_random(params, *size, n, seed=5)
    res = run(params, recs, p_valid=p_valid, p_ready=p_ready, sim=sim, tag=f"logic_{preset}")
    assert res["expected"] > 60 and res["mismatches"] == 0, res


def test_raster_carries_the_triangles_slopes(sim):
    """The ``slopes`` (the increments the level of detail of MIP mapping reads, ``fxmodel/units/lod.py``): every
    fragment carries its triangle's exact steps of ``U`` and ``W`` along x and y, rounded once by the set-up (wide
    formats: a sliver's steps are large), bit for bit, under gaps and backpressure."""
    import dataclasses

    from fxmodel.core.fixed import Fmt
    slope = Fmt(True, 30, 14)
    params = dataclasses.replace(RasterParams.PRESETS["small"], slopes=(
        ("Ux", "U", "x", slope), ("Uy", "U", "y", slope), ("Wx", "W", "x", slope), ("Wy", "W", "y", slope)))
    recs = hard_and_random(params, 24, 20, 8, seed=5)
    # the set-up's step is the exact plane's rounded half-up, as the interpolator's own (which wraps modulo its
    # accumulator): both within half an ulp of the same exact step
    acc = params.acc_fmt("U")
    k = acc.frac_bits - slope.frac_bits
    diff = ((recs.codes["Ux"] << k) - recs.codes["U_dx"]) % (1 << acc.width)
    diff = np.where(diff >= 1 << (acc.width - 1), diff - (1 << acc.width), diff)
    assert np.abs(diff).max() <= (1 << (k - 1)) + 1 and len(recs) > 10
    res = run(params, recs, p_valid=0.6, p_ready=0.6, sim=sim, tag="slopes")
    assert res["expected"] > 60 and res["mismatches"] == 0, res
    frags = scan(params, recs)
    assert np.array_equal(frags.codes["Wy"], recs.codes["Wy"][frags.record])


@pytest.mark.slow
def test_make_sim_from_triangles(sim):
    """``make sim`` (from triangles) on a small sphere: the engine's RTL equals the model on every output and
    clock, and the report says it started from triangles. Slow (``make exhaustive``): Yosys spends minutes on the
    whole pipeline's netlist."""
    import json

    from cosim.sim import main, output_folder
    argv = ["--scene", "sphere", "--size", "24", "--cube-size", "8", "--input", "triangles", "--sim", sim]
    assert main(argv) == 0
    report = json.loads((output_folder(argv) / "report.json").read_text())
    assert report["input"] == "triangles" and report["mismatches"] == 0 and report["rtl_clocks_match_model"]
    assert report["triangles"] > 100 and report["fragments"] > 200


@pytest.mark.slow
@pytest.mark.parametrize("p_valid, p_ready", [(1.0, 1.0), (0.6, 0.3)])
def test_engine_from_triangles_with_backpressure(sim, p_valid, p_ready):
    """The engine (scan converter -> pixel pipeline stream) on random triangles of the demo pipeline, with gaps
    on the records and backpressure on the colors: every output bit equal to the model, none lost or repeated."""
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.pipeline.pixel import PipelineParams
    pipe = PipelineParams.PRESETS["default"]
    raster = RasterParams.for_pipeline({"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect})
    recs = hard_and_random(raster, 16, 12, 6, seed=5)
    res = run(EngineParams(raster=raster, pipeline=pipe), recs, p_valid=p_valid, p_ready=p_ready,
              sim=sim, tag=f"engine_{p_valid}_{p_ready}")
    assert res["expected"] > 100 and res["mismatches"] == 0, res
    if p_valid == p_ready == 1.0:
        assert res["busy_cycles"] == res["clocks"] == res["busy_span"], res


def stream_records(params, records, **kw):
    """:func:`cosim.stream.run_records` of the model's records, outputs, counts and clocks (``params`` a
    :class:`RasterParams` or a :class:`~fxmodel.pipeline.engine.EngineParams`)."""
    mat = records.matrix()
    if isinstance(params, RasterParams):
        res = scan(params, mat)
        out = res.matrix(params)
    else:
        out, res = params.compute(mat)
    counts = np.bincount(res.record, minlength=len(mat))
    return run_records(params, mat, out, counts, clocks=res.clocks, **kw), out, counts, res


def test_streaming_harness_draws_every_pattern(sim):
    """The streaming harness (records from files, clock and stimulus inside the wrapper) on the scan converter:
    every fragment equal to the model, in order, none lost or extra, under every stimulus pattern; without stalls
    the busy cycles are the model's clocks."""
    params = RasterParams.PRESETS["small"]
    recs = hard_and_random(params, 48, 40, 24, seed=3)
    for pattern in PATTERNS:
        result, out, _, res = stream_records(params, recs, sim=sim, pattern=pattern, chunk=300)
        assert result.ok and result["vectors"] == len(out) > 5000 and result["chunks"] > 10, result.describe()
        assert np.array_equal(result.rtl, out)
        if pattern == "none":
            assert result["busy_cycles"] == res.clocks.sum() and result["stalled"] == 0
        else:
            assert result["stalled"] > 0


def test_streaming_harness_counts_changed_missing_and_extra_outputs(sim):
    """The harness fails a run whose outputs differ from what it was told to expect: a changed fragment, one
    fragment fewer expected (the design's last one is extra), one more expected (missing)."""
    params = RasterParams.PRESETS["small"]
    recs = hard_and_random(params, 20, 16, 4, seed=7)
    mat = recs.matrix()
    res = scan(params, mat)
    out = res.matrix(params)
    counts = np.bincount(res.record, minlength=len(mat))
    changed = out.copy()
    changed[len(out) // 2, 2] += 1
    bad = run_records(params, mat, changed, counts, sim=sim)
    assert not bad.ok and bad["mismatches"] == 1 and bad["first"][0]["index"] == len(out) // 2
    last = int(np.flatnonzero(counts)[-1])
    fewer = counts.copy()
    fewer[last] -= 1
    bad = run_records(params, mat, out[:-1], fewer, sim=sim)
    assert not bad.ok and bad["extra"] == 1
    more = counts.copy()
    more[last] += 1
    bad = run_records(params, mat, np.concatenate([out, out[-1:]]), more, sim=sim)
    assert not bad.ok and bad["missing"] == 1
    # in shards (make sim's way): the changed fragment is found at its row of the whole run
    bad = run_records(params, mat, changed, counts, sim=sim, shards=3)
    assert len(bad["shards"]) == 3 and not bad.ok and bad["mismatches"] == 1
    assert bad["first"][0]["index"] == len(out) // 2


def test_shards_draw_what_one_run_draws(sim):
    """The records split into contiguous shards, simulated at once in separate simulator processes and joined:
    the same fragments in the same order as one run, and each shard's busy cycles the model's clocks of its
    records (each shard starts from reset)."""
    params = RasterParams.PRESETS["small"]
    recs = hard_and_random(params, 24, 20, 8, seed=11)
    result, out, counts, res = stream_records(params, recs, sim=sim, shards=2, chunk=200)
    parts = result["shards"]
    assert len(parts) == 2 and parts[0][0] == 0 and parts[0][1] == parts[1][0] and parts[1][1] == len(counts)
    assert result.ok and np.array_equal(result.rtl, out), result.describe()
    assert result["shard_busy_cycles"] == [int(res.clocks[a:b].sum()) for a, b in parts]
    assert result["busy_cycles"] == res.clocks.sum()


def test_engine_from_triangles_whole_path(sim):
    """The whole engine (``Engine``: scan converter and interpolators -> pixel pipeline) on a small
    scene from triangles with a steep bump map (every triangle's block exponent ``Ae = 2``), in the streaming
    harness without stalls and under the stall patterns: every output (``x, y``, bytes, flags) equal to the model,
    in order, none lost or extra; without stalls the scan converter is busy exactly the model's clocks."""
    from host.render import from_triangles, prepare
    tframe = from_triangles(prepare("tests/scenes/steep-sphere.toml", cube_size=8))
    assert tframe.records.codes["Ae"].min() == 2
    for pattern in ("none", ("bursts", "random", "stalls")):          # the second: one pattern a chunk
        result, out, _, res = stream_records(tframe.params, tframe.records, sim=sim, pattern=pattern, chunk=128)
        assert result.ok and result["vectors"] == len(out) > 400 and result["chunks"] >= 3, result.describe()
        assert np.array_equal(result.rtl, tframe.out)
        if pattern == "none":
            assert result["busy_cycles"] == res.clocks.sum()
        else:
            assert result["stalled"] > 100 and result["cycles"] > 1.5 * len(out)
