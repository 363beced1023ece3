"""Co-simulation of the scan converter RTL against the model: every fragment bit for bit, the fragment count, and
the clock count (cycles with ``busy`` high equal the model's ``sum max(1, span)`` when nothing stalls), over random
triangles and the hard cases, with gaps on the input and backpressure on the output."""

import numpy as np
import pytest

from cosim.raster import pack, run, unpack
from fxmodel.raster import RasterParams, setup

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
        tris.append(((c[0] + rng.integers(-3 * S, 3 * S, 3)).tolist(), (c[1] + rng.integers(-3 * S, 3 * S, 3)).tolist()))
    X, Y = np.array([t[0] for t in tris]), np.array([t[1] for t in tris])
    vals = {}
    for name, fmt in params.attrs:
        lim = float(fmt.max_value) * 0.999
        vals[name] = rng.uniform(-lim, lim, X.shape)
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
    if p_valid == p_ready == 1.0:
        assert res["busy_cycles"] == res["clocks"], res


@pytest.mark.slow
def test_make_sim_from_triangles(sim):
    """``make sim INPUT=triangles`` on a small sphere: the engine's RTL equals the model on every output and
    clock, and the report says it started from triangles. Slow (``make exhaustive``): Yosys spends minutes on the
    whole pipeline's netlist."""
    import json

    from cosim.harness import ROOT
    from cosim.sim import main
    assert main(["--scene", "sphere", "--size", "24", "--cube-size", "8", "--input", "triangles",
                 "--sim", sim]) == 0
    report = json.loads((ROOT / "build" / "sim" / "sphere-triangles" / "report.json").read_text())
    assert report["input"] == "triangles" and report["mismatches"] == 0 and report["rtl_clocks_match_model"]
    assert report["triangles"] > 100 and report["fragments"] > 200


@pytest.mark.slow
@pytest.mark.parametrize("p_valid, p_ready", [(1.0, 1.0), (0.6, 0.3)])
def test_engine_from_triangles_with_backpressure(sim, p_valid, p_ready):
    """The engine (scan converter -> pixel pipeline stream) on random triangles of the demo pipeline, with gaps
    on the records and backpressure on the colors: every output bit equal to the model, none lost or repeated."""
    from fxmodel.pipeline import PipelineParams, TrianglePipelineParams
    pipe = PipelineParams.PRESETS["default"]
    raster = RasterParams.for_pipeline({"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect})
    recs = hard_and_random(raster, 16, 12, 6, seed=5)
    res = run(TrianglePipelineParams(raster=raster, pipeline=pipe), recs, p_valid=p_valid, p_ready=p_ready,
              sim=sim, tag=f"engine_{p_valid}_{p_ready}")
    assert res["expected"] > 100 and res["mismatches"] == 0, res
    if p_valid == p_ready == 1.0:
        assert res["busy_cycles"] == res["clocks"], res
