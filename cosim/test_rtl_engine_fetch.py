"""Co-simulation of the engine from the triangle with its bump map and color texture in external memory
(``rtl/engine.py`` with ``EngineParams.textures``, ``rtl/pixel_fetch.py``; :mod:`cosim.engine_fetch`): a scene's
triangles through the scan converter, the split pixel pipeline and the texture fetch, both maps in ``AxiRam``, at
memory latencies 1, 20 and 40 with random gaps in the records, backpressure on the fragments and wait states on
both read channels; every fragment equals the model's, each map's bursts its cache's model, and the traffic
comparison can fail."""

import dataclasses

import pytest

from cosim.engine_fetch import run_engine_fetch
from fxmodel.units.texcache import TexCacheParams

pytestmark = pytest.mark.cosim

#: A small cache, so that a small frame misses, evicts and refills.
SMALL = TexCacheParams(block=4, sets=4, ways=2, lookup_depth=16, misses=4)
#: The reflectance cubes stay on chip and are not what these tests check: 16-texel faces, as the pixel pipeline's
#: scene tests (``cosim/test_rtl_pixel.py``), keep each engine's build small (the default 64-texel faces tripled its
#: Verilog).
CUBE = 16


@pytest.fixture(scope="module")
def tin_plane():
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tframe = from_triangles(prepare(scene_path("tin-plane"), size=32, cube_size=CUBE))
    return dataclasses.replace(tframe.params, textures=SMALL), tframe


def test_fetch_pipeline_is_the_pipeline(tin_plane):
    """With the maps external the engine draws the same fragments: the model's frame is the on-chip engine's."""
    eng, tframe = tin_plane
    assert (eng.compute(tframe.records.matrix())[0] == tframe.out).all()
    assert repr(eng) != repr(tframe.params) and "textures" not in repr(tframe.params)


@pytest.mark.parametrize("latency", (1, 20, 40))
def test_engine_with_textures_in_memory(tin_plane, latency):
    eng, tframe = tin_plane
    res = run_engine_fetch(eng, tframe.records, latency=latency, p_valid=0.8, p_ready=0.7, p_pause=0.2,
                           seed=latency, tag=f"engine_fetch_{latency}")
    assert res["outputs"] == res["fragments"] == len(tframe.out) > 0 and res["mismatches"] == 0
    assert res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"] > 0
    assert all(v["totals"]["misses"] > 0 for v in res["maps"].values())
    assert (res["rtl"] == tframe.out).all()


def test_traffic_comparison_can_fail(tin_plane):
    """The bump map's bursts of the RTL are not those of a cache with one way less."""
    eng, tframe = tin_plane
    res = run_engine_fetch(eng, tframe.records, latency=5, tag="engine_fetch_fail")
    other = dataclasses.replace(eng, textures=dataclasses.replace(SMALL, ways=1))
    model = other.texture_traffic(tframe.records.matrix())["bump_map"].burst_addresses().tolist()
    assert res["maps"]["bump_map"]["rtl_bursts"] and [a for a, _ in res["maps"]["bump_map"]["rtl_bursts"]] != model



#: The MIP scenes: the grazing floor with its MIP preset, the Berlin wall with the default preset's MIP mapping.
MIP_SCENES = {"grazing-floor": ("grazing-floor-mip", 32), "berlin-wall": ("mip", 32)}


@pytest.fixture(scope="module", params=sorted(MIP_SCENES))
def mip_scene(request):
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    preset, size = MIP_SCENES[request.param]
    tframe = from_triangles(prepare(scene_path(request.param), size=size, preset=preset, cube_size=CUBE))
    assert tframe.params.pipeline.texture.trilinear
    return request.param, dataclasses.replace(tframe.params, textures=SMALL), tframe


@pytest.mark.parametrize("latency", (1, 20, 40))
def test_engine_with_mip_levels_in_memory(mip_scene, latency):
    """The color texture trilinear from its levels in memory: its even and odd levels through their caches (a
    level the blend does not need not looked up), every fragment the model's, each cache's bursts its model."""
    name, eng, tframe = mip_scene
    res = run_engine_fetch(eng, tframe.records, latency=latency, p_valid=0.8, p_ready=0.7, p_pause=0.2,
                           seed=latency, tag=f"engine_fetch_mip_{name}_{latency}")
    assert res["outputs"] == res["fragments"] == len(tframe.out) > 0 and res["mismatches"] == 0
    assert res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"] > 0
    assert set(res["maps"]) == {"bump_map", "texture_even", "texture_odd"}
    assert all(v["totals"]["misses"] > 0 for v in res["maps"].values())
    assert (res["rtl"] == tframe.out).all()
