"""Co-simulation of the decoupled texel cache (``rtl/texcache_decoupled.py``) against
:func:`fxmodel.units.texcache.simulate`: the four texels and the sideband of every lookup bit for bit, and the
memory traffic burst for burst (every ``AR`` address and length in order, the bytes of the ``R`` beats), at memory
latencies 1, 20 and 40 cycles with random request gaps, output backpressure and wait states on both read channels;
random walks over two surfaces (a map and its next MIP level's size) and several cache shapes, a shipped scene's
lookups through the chosen cache, that misses overlap (the rate at latency 40 against latency 0), and that the
traffic comparison can fail."""

import dataclasses

import numpy as np
import pytest

from cosim.texfetch import run
from fxmodel.units.texcache import Layout, TexCacheParams, Trace, footprints, simulate

pytestmark = pytest.mark.cosim

LATENCIES = (1, 20, 40)


def two_levels(params: TexCacheParams, h: int, w: int) -> Layout:
    """A map of ``h x w`` and a second surface of half its size (the shape of a MIP level), after three lines
    (even sizes: a repeat across an odd size is a bank conflict, which this RTL does not take)."""
    return Layout(((("m", 0), h, w), (("m", 1), -(-h // 2), -(-w // 2))), params.block, params.texel_bytes,
                  3 * params.line_bytes)


def walk(layout: Layout, n: int, seed: int) -> Trace:
    """Bilinear footprints of random walks with jumps (repeat-wrapped) on each surface, interleaved lookup by
    lookup as trilinear filtering reads two levels, so that lines hit, miss and are evicted."""
    rng = np.random.default_rng(seed)
    k = len(layout.surfaces)
    surf = np.arange(n) % k
    x0, y0 = np.zeros(n, np.int64), np.zeros(n, np.int64)
    for s, (_, h, w) in enumerate(layout.surfaces):
        rows = np.flatnonzero(surf == s)
        m = len(rows)
        x0[rows] = (np.cumsum(rng.integers(-1, 3, m)) + (rng.random(m) < 0.05) * 7) % w
        y0[rows] = (np.cumsum(rng.integers(-1, 2, m)) + (rng.random(m) < 0.1) * 5) % h
    dims = np.array([[h, w] for _, h, w in layout.surfaces])
    return Trace(np.arange(n) // k, surf, x0, (x0 + 1) % dims[surf, 1], y0, (y0 + 1) % dims[surf, 0])


def maps_for(params: TexCacheParams, layout: Layout, seed: int) -> list:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 1 << params.texel_bits, (h, w)) for _, h, w in layout.surfaces]


CASES = [
    (TexCacheParams(block=4, sets=4, ways=2, lookup_depth=16, misses=4), 12, 16),
    (TexCacheParams(block=2, sets=8, ways=2, index="linear", lookup_depth=8, misses=4), 12, 20),
    (TexCacheParams(block=4, sets=8, ways=1, lookup_depth=32, misses=4), 16, 16),
    (TexCacheParams(block=8, sets=2, ways=2, texel_bits=28, lookup_depth=64, misses=8), 24, 40),
    # LRU over three ways (its pair bits' oldest way when the ways are not a power of two)
    (TexCacheParams(block=2, sets=2, ways=3, index="linear", lookup_depth=8, misses=4), 12, 20),
    # round robin: a hit changes nothing, the victim skips the ways the lookup used (two ways; three, not a power of 2)
    (TexCacheParams(block=4, sets=4, ways=2, replacement="fifo", lookup_depth=16, misses=4), 12, 16),
    (TexCacheParams(block=2, sets=2, ways=3, replacement="fifo", index="linear", lookup_depth=8, misses=4), 12, 20),
]


def check(res):
    model = res["model"]
    assert model["self_evictions"] == 0 and model["bank_conflicts"] == 0      # what this RTL supports
    assert res["outputs"] == res["lookups"] and res["mismatches"] == 0, {k: res[k] for k in ("outputs", "mismatches")}
    assert res["bursts_equal"], (res["rtl_bursts"][:8], res["model_bursts"][:8])
    assert res["rtl_bytes"] == res["model_bytes"] == model["memory_bytes"]


@pytest.mark.parametrize("latency", LATENCIES)
@pytest.mark.parametrize("params, h, w", CASES)
def test_random_walk(params, h, w, latency):
    layout = two_levels(params, h, w)
    trace = walk(layout, 240, seed=h * w)
    res = run(params, layout, maps_for(params, layout, w), trace, latency=latency, p_valid=0.8, p_ready=0.7,
              p_pause=0.3, seed=latency, tag=f"walk_{h}_{w}_{latency}")
    assert 0 < res["model"]["hits"] and 0 < res["model"]["misses"]
    check(res)


def tin_plane(n: int):
    """The tin plane's bump-map lookups (its first ``n`` fragments from triangles at 48 pixels) and its map."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    frame = prepare(scene_path("tin-plane"), size=48)
    scan = from_triangles(frame).scan
    p = frame.params
    st = p.trace(np.stack([scan.codes[q.name] for q in p.inputs], axis=1)[:n])["st"]
    sampler = p.bump_map
    h, w = sampler.texels.shape[1:3]
    return footprints(sampler, st[:, 0], st[:, 1], 0), np.array(sampler.words, dtype=np.int64).reshape(h, w), \
        sampler.word_bits


@pytest.mark.parametrize("latency", LATENCIES)
def test_scene_lookups_chosen_cache(latency):
    """The tin plane's bump-map lookups through the chosen cache (``CHOSEN_CACHE``: 8 x 8-texel lines, 32 sets, 4
    ways, LRU): the sampler's packed texel words come back exactly, the bursts are the model's."""
    from fxmodel.units.texcache import CHOSEN_CACHE
    trace, words, bits = tin_plane(500)
    params = dataclasses.replace(CHOSEN_CACHE, texel_bits=bits)
    layout = Layout(((("bump_map", 0),) + words.shape,), params.block, params.texel_bytes)
    res = run(params, layout, [words], trace, latency=latency, p_valid=0.9, p_ready=0.8, p_pause=0.2,
              seed=latency, tag=f"tin_plane_{latency}")
    assert res["model"]["misses"] > 0
    check(res)


@pytest.mark.parametrize("replacement", ["lru", "fifo"])
def test_misses_overlap(replacement):
    """With every stream open and the lookup FIFO sized for the latency, a walk that misses often keeps at least
    90 % of its latency-0 rate at latency 40: the bursts overlap (a cache that waited for each would lose 40 clocks
    a miss). Round robin too, whose tag stage takes a second clock for each fill."""
    params, h, w = CASES[0]
    params = dataclasses.replace(params, lookup_depth=128, misses=8, replacement=replacement)
    layout = two_levels(params, h, w)
    trace = walk(layout, 240, seed=3)
    maps = maps_for(params, layout, 3)
    rates = {lat: run(params, layout, maps, trace, latency=lat, tag=f"rate_{lat}") for lat in (0, 40)}
    for r in rates.values():
        check(r)
    lost_if_blocking = 40 * rates[0]["model"]["misses"]
    assert rates[40]["cycles"] - rates[0]["cycles"] < 0.25 * lost_if_blocking, {k: r["cycles"] for k, r in
                                                                                 rates.items()}
    assert rates[40]["lookups_per_clock"] >= 0.9 * rates[0]["lookups_per_clock"]


def test_traffic_comparison_can_fail():
    """The same lookups in the model of a cache with one way less: its bursts differ from the RTL's."""
    params, h, w = CASES[0]
    layout = two_levels(params, h, w)
    trace = walk(layout, 240, seed=h * w)
    res = run(params, layout, maps_for(params, layout, w), trace, latency=20, tag="fail")
    check(res)
    other = TexCacheParams(block=params.block, sets=params.sets, ways=params.ways - 1)
    assert [a for a, _ in res["rtl_bursts"]] != simulate(other, layout, trace).burst_addresses().tolist()


def engine_fetch(scene: str, size: int, n: int, cache: TexCacheParams):
    """A scene's fragments from triangles (the first ``n``) as the texture fetch sees them: the engine with its
    maps external (``EngineParams.textures``), its layout, caches, per-map footprints and the surfaces' words."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    from rtl.texfetch import MAPS
    tframe = from_triangles(prepare(scene_path(scene), size=size))
    eng = dataclasses.replace(tframe.params, textures=cache)
    p = eng.pipeline
    st = p.trace(np.stack([tframe.scan.codes[q.name] for q in p.inputs], axis=1)[:n])["st"]
    traces = {k: footprints(getattr(p, k), st[:, 2 * j], st[:, 2 * j + 1], j) for j, k in enumerate(MAPS)}
    words = [np.array(getattr(p, k).words, np.int64).reshape(getattr(p, k).texels.shape[1:3]) for k in MAPS]
    return eng, traces, words


@pytest.mark.parametrize("latency", LATENCIES)
def test_fetch_both_maps_of_a_scene(latency):
    """The tin plane's fragments through the texture fetch (both maps' caches on one read port): every fragment's
    texels of both maps and its sideband exact, each map's bursts its cache's model (the engine's
    ``texture_traffic``), under random gaps, backpressure and wait states."""
    from cosim.texfetch import run_fetch
    eng, traces, words = engine_fetch("tin-plane", 48, 600, TexCacheParams(block=8, sets=8, ways=2))
    res = run_fetch(eng.texture_caches(), eng.texture_layout(), words, traces, latency=latency, p_valid=0.9,
                    p_ready=0.8, p_pause=0.2, seed=latency, tag=f"fetch_{latency}")
    assert res["outputs"] == res["fragments"] == 600 and res["mismatches"] == 0
    assert res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"] > 0
    assert all(v["model"]["misses"] > 0 for v in res["maps"].values())


@pytest.mark.parametrize("dram_ns", [20, 7])
def test_fetch_maps_in_sdram(dram_ns):
    """The same fragments with both maps in LiteDRAM's simulation core, as the board reads them: the fetch in the
    engine's 10 ns clock, its read channels across the board's clock crossing into the core's texture port in the
    SDRAM's clock (20 ns: the board's 50 MHz; 7 ns: faster than the engine), the maps written into the SDRAM through
    the core's other port and read back first. Texels, sideband and bursts exact, no error response; and no faster
    than the chip can deliver the bytes (one 16-bit word an SDRAM clock)."""
    from board.litedram import DATA_BITS
    from cosim.texfetch import run_fetch
    eng, traces, words = engine_fetch("tin-plane", 48, 600, TexCacheParams(block=8, sets=8, ways=2))
    res = run_fetch(eng.texture_caches(), eng.texture_layout(), words, traces, p_valid=0.9, p_ready=0.8,
                    seed=dram_ns, tag=f"dram_{dram_ns}", dram_ns=dram_ns, sim="verilator")
    assert res["outputs"] == res["fragments"] == 600 and res["mismatches"] == 0
    assert res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"] > 0 and res["mem_error"] == 0
    assert res["cycles"] * 10 >= res["rtl_bytes"] * 8 // DATA_BITS * dram_ns
