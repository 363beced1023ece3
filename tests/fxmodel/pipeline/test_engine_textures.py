"""The engine with its maps in external memory (``EngineParams.textures``): the caches' traffic is the texel-cache
model's on the sampler footprints of the frame's fragments (checked against ``bumpmap cache-sweep``'s path, which
takes them from the host's frame), the layout holds both maps, the memories trade the maps for the caches, and
the frame does not change."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fxmodel.core.cost import bram_blocks
from fxmodel.units.texcache import Layout, TexCacheParams, simulate


@pytest.fixture(scope="module")
def tin_plane():
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    return from_triangles(prepare(scene_path("tin-plane"), size=48))


def test_traffic_is_the_models_on_the_frames_footprints(tin_plane):
    from tools.cache_sweep import scene_traces
    cache = TexCacheParams(block=4, sets=8, ways=2)
    eng = dataclasses.replace(tin_plane.params, textures=cache)
    got = eng.texture_traffic(tin_plane.records)
    data = scene_traces("tin-plane", size=48)
    both = Layout(tuple(((n, 0),) + tuple(data["traces"][n][0].texels.shape[1:3]) for n in ("bump_map", "texture")),
                  cache.block)
    for k, name in enumerate(("bump_map", "texture")):
        _, trace = data["traces"][name]
        assert len(trace) == len(tin_plane.scan)
        want = simulate(cache, both, dataclasses.replace(trace, surface=np.full(len(trace), k)))
        assert np.array_equal(got[name].line, want.line) and np.array_equal(got[name].way, want.way)
        assert got[name].totals == want.totals and want.totals["misses"] > 0
    first = eng.texture_layout().first_line
    assert np.all(got["texture"].line >= first[1]) and np.all(got["bump_map"].line < first[1])


def test_memories_trade_the_maps_for_the_caches(tin_plane):
    eng = tin_plane.params
    ext = dataclasses.replace(eng, textures=TexCacheParams(block=8, sets=32, ways=4))
    maps = eng.pipeline.bump_map.memories() + eng.pipeline.texture.memories()
    assert not any(m in ext.memories() for m in maps)
    caches = [m for c in ext.texture_caches().values() for m in c.memories(decoupled=True)]
    assert bram_blocks(ext.memories()) == bram_blocks(eng.memories()) - bram_blocks(maps) + bram_blocks(caches)
    assert ext.compute(tin_plane.records)[0].tolist() == eng.compute(tin_plane.records)[0].tolist()


def test_textures_must_be_cache_parameters(tin_plane):
    with pytest.raises(ValueError, match="^textures="):
        dataclasses.replace(tin_plane.params, textures="external")
