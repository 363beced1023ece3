"""Co-simulation of the texel cache (``rtl/texcache.py``) against :func:`fxmodel.units.texcache.simulate`: the four
texels of every lookup bit for bit against the map, and the memory traffic burst for burst (every ``AR`` address and
length in order, the bytes of the ``R`` beats), under random request gaps, output backpressure and wait states on
the read channels of cocotbext-axi's ``AxiRam``; random walks over several cache shapes and a shipped scene's bump-map
lookups; and proof that the traffic comparison can fail."""

import numpy as np
import pytest

from cosim.texcache import run
from fxmodel.units.texcache import TexCacheParams, Trace, footprints, simulate

pytestmark = pytest.mark.cosim


def walk(h, w, n, seed):
    """Footprints of a random walk with jumps (repeat-wrapped), so that lines hit, miss and are evicted."""
    rng = np.random.default_rng(seed)
    x0 = (np.cumsum(rng.integers(-1, 3, n)) + (rng.random(n) < 0.05) * 7) % w
    y0 = (np.cumsum(rng.integers(-1, 2, n)) + (rng.random(n) < 0.1) * 5) % h
    return Trace(np.arange(n), np.zeros(n, np.int64), x0, (x0 + 1) % w, y0, (y0 + 1) % h)


CASES = [
    (TexCacheParams(block=4, sets=4, ways=2), 12, 16, dict(p_valid=0.7, p_ready=0.8, p_pause=0.3)),
    (TexCacheParams(block=2, sets=8, ways=2, index="linear"), 10, 14, dict(p_pause=0.5)),
    (TexCacheParams(block=4, sets=8, ways=1), 16, 16, dict(p_valid=0.8)),
    (TexCacheParams(block=2, sets=2, ways=4), 16, 8, dict(p_ready=0.5)),
    (TexCacheParams(block=8, sets=2, ways=2, texel_bits=28), 24, 40, dict(p_valid=0.5, p_pause=0.2)),
    (TexCacheParams(block=4, sets=1, ways=4), 8, 8, dict()),
]


@pytest.mark.parametrize("params, h, w, kw", CASES)
def test_random_walk(params, h, w, kw):
    trace = walk(h, w, 160, seed=h * w)
    words = np.random.default_rng(w).integers(0, 1 << params.texel_bits, (h, w))
    res = run(params, words, trace, base=params.line_bytes * 3, seed=5, tag=f"walk_{h}_{w}", **kw)
    model = res["model"]
    assert model["self_evictions"] == 0 and model["bank_conflicts"] == 0      # what this RTL supports
    assert 0 < model["hits"] and 0 < model["misses"]
    assert res["outputs"] == len(trace) and res["mismatches"] == 0, res
    assert res["bursts_equal"], (res["rtl_bursts"][:8], res["model_bursts"][:8])
    assert res["rtl_bytes"] == res["model_bytes"] == model["memory_bytes"]


def test_scene_bump_map_lookups():
    """The tin plane's bump-map lookups (its first 400 fragments from triangles at 48 pixels) through a small cache:
    the sampler's packed 28-bit texel words come back exactly."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    frame = prepare(scene_path("tin-plane"), size=48)
    scan = from_triangles(frame).scan
    p = frame.params
    st = p.trace(np.stack([scan.codes[q.name] for q in p.inputs], axis=1)[:400])["st"]
    sampler = p.bump_map
    trace = footprints(sampler, st[:, 0], st[:, 1], 0)
    h, w = sampler.texels.shape[1:3]
    words = np.array(sampler.words, dtype=np.int64).reshape(h, w)
    params = TexCacheParams(block=4, sets=8, ways=2, texel_bits=sampler.word_bits)
    res = run(params, words, trace, p_pause=0.2, p_ready=0.7, tag="tin_plane")
    assert res["mismatches"] == 0 and res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"]
    assert res["model"]["misses"] > 0


def test_traffic_comparison_can_fail():
    """The same lookups in the model of a cache with one way less: its bursts differ from the RTL's."""
    params, h, w, kw = CASES[0]
    trace = walk(h, w, 160, seed=h * w)
    words = np.random.default_rng(w).integers(0, 1 << params.texel_bits, (h, w))
    res = run(params, words, trace, base=params.line_bytes * 3, seed=5, tag=f"walk_{h}_{w}", **kw)
    from rtl.texcache import TexCache
    other = TexCacheParams(block=params.block, sets=params.sets, ways=params.ways - 1)
    alt = simulate(other, TexCache(other, h, w, params.line_bytes * 3).layout, trace)
    assert [a for a, _ in res["rtl_bursts"]] != alt.burst_addresses().tolist()
