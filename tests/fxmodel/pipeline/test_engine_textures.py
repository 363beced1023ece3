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
    from fxmodel.units.texcache import footprints
    cache = TexCacheParams(block=4, sets=8, ways=2)
    eng = dataclasses.replace(tin_plane.params, textures=cache)
    got = eng.texture_traffic(tin_plane.records)
    P = tin_plane.params.pipeline
    st = P.trace(np.stack([tin_plane.scan.codes[p.name] for p in P.inputs], axis=1))["st"]
    both = Layout(tuple(((n, 0),) + tuple(getattr(P, n).texels.shape[1:3]) for n in ("bump_map", "texture")),
                  cache.block)
    for k, name in enumerate(("bump_map", "texture")):
        trace = footprints(getattr(P, name), st[:, 2 * k], st[:, 2 * k + 1], 0)
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


@pytest.fixture(scope="module")
def grazing_mip():
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tframe = from_triangles(prepare(scene_path("grazing-floor"), size=32, preset="grazing-floor-mip"))
    return dataclasses.replace(tframe.params, textures=TexCacheParams(block=4, sets=8, ways=2)), tframe


def test_mip_levels_are_surfaces_and_two_caches(grazing_mip):
    """With the color texture trilinear, each of its levels is a surface of the layout (blocked as level 0), it
    has two caches (even and odd levels), and each cache's lookups are the model's levels of the fragments."""
    eng, tframe = grazing_mip
    tex = eng.pipeline.texture
    assert tex.trilinear and not eng.pipeline.bump_map.trilinear
    layout = eng.texture_layout()
    assert [k for k, _, _ in layout.surfaces] == [("bump_map", 0)] + [("texture", lv) for lv in range(tex.levels)]
    assert [tuple(s[1:]) for s in layout.surfaces[1:]] == list(tex.level_sizes)
    assert [p for p, _, _ in eng.texture_ports()] == ["bump_map", "texture_even", "texture_odd"]
    assert list(eng.texture_caches()) == ["bump_map", "texture_even", "texture_odd"]
    lookups = eng.texture_lookups(tframe.records)
    n = len(tframe.out)
    lod = eng.pipeline.trace(np.stack([tframe.scan.codes[p.name] for p in eng.pipeline.inputs], axis=1))["lod"]
    _, _, g = tex.level(lod)
    assert len(lookups["bump_map"]) == n
    assert len(lookups["texture_even"]) + len(lookups["texture_odd"]) == n + int(np.count_nonzero(g))
    for p, port in enumerate(("texture_even", "texture_odd")):
        levels = [layout.surfaces[k][0][1] for k in lookups[port].surface.tolist()]
        assert all(lv % 2 == p for lv in levels) and len(set(levels)) >= 2
    traffic = eng.texture_traffic(tframe.records)
    for port, res in traffic.items():
        assert res.totals["lookups"] == len(lookups[port]) and res.totals["misses"] > 0
        assert res.totals["self_evictions"] == 0 and res.totals["bank_conflicts"] == 0
    assert eng.compute(tframe.records)[0].tolist() == tframe.out.tolist()


def test_mip_memories_trade_the_pyramid_for_three_caches(grazing_mip):
    eng, _ = grazing_mip
    on_chip = dataclasses.replace(eng, textures=None)
    maps = eng.pipeline.bump_map.memories() + eng.pipeline.texture.memories()
    assert not any(m in eng.memories() for m in maps)
    caches = [m for c in eng.texture_caches().values() for m in c.memories(decoupled=True)]
    assert len(eng.texture_caches()) == 3
    assert bram_blocks(eng.memories()) == bram_blocks(on_chip.memories()) - bram_blocks(maps) + bram_blocks(caches)
