"""The pixel pipeline split around the texture fetch (``rtl/pixel_fetch.py``): its two halves' ports and latencies
follow the parameter objects, the back keeps the flat pipeline's schedule shifted, the front's indices have the
cache request's widths, and the engine with its maps external has the texture port while the engine with them on
chip does not. (The pixels and the traffic are checked in ``cosim/test_rtl_engine_fetch.py``.)"""

from __future__ import annotations

import dataclasses

import pytest
from amaranth.hdl import Shape

from fxmodel.units.texcache import TexCacheParams
from rtl.pixel_fetch import CORNERS, BackParams, FetchPipeline, FrontParams
from rtl.sampler import texel_stages
from rtl.texcache_decoupled import request_layout
from rtl.texfetch import MAPS
from rtl.unit import build


@pytest.fixture(scope="module")
def engine():
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tframe = from_triangles(prepare(scene_path("tin-plane"), size=16, cube_size=16))
    return dataclasses.replace(tframe.params, textures=TexCacheParams(block=4, sets=4, ways=2))


def test_back_keeps_the_flat_schedule_shifted(engine):
    P = engine.pipeline
    back = BackParams(P)
    T = P.stage_latency
    shift = back.schedule["samples"] - T["samples"]
    assert all(back.schedule[k] - T[k] == shift for k in back.schedule)
    assert back.schedule["samples"] == max(s.latency - texel_stages(s) for s in (P.bump_map, P.texture))
    assert back.latency == back.schedule["out"]


def test_halves_elaborate_with_their_ports(engine):
    """Each half's component has one port per input and output (none sharing a name) and the latency its
    parameter object states (``UnitComponent.finish`` checks it when elaborated)."""
    from rtl.verilog import component_verilog
    for half in (FrontParams(engine.pipeline, engine.texture_layout()), BackParams(engine.pipeline)):
        names_in, names_out = {p.name for p in half.inputs}, {p.name for p in half.outputs}
        assert not names_in & names_out
        comp = build(half)
        assert names_in | names_out <= set(comp.signature.members)
        assert "module" in component_verilog(comp, "half")


def test_front_indices_have_the_request_widths(engine):
    req = request_layout(engine.texture_layout())
    widths = {p.name: p.fmt.width for p in FrontParams(engine.pipeline, engine.texture_layout()).outputs}
    for m in MAPS:
        for c in CORNERS:
            assert widths[f"{m}_{c}"] == Shape.cast(req.members[c]).width


def test_trilinear_texels_arrive_after_the_level_stages():
    """The trilinear sampler's both levels' words are there after its level, position, index, address and read
    stages; its blends (``rtl.sampler_mip.blends``) take the rest of its latency."""
    from fxmodel.units.sampler import SamplerParams
    from rtl.sampler_mip import TEXEL_STAGES
    smp = SamplerParams.PRESETS["trilinear"]
    assert texel_stages(smp) == TEXEL_STAGES < smp.latency


@pytest.fixture(scope="module")
def mip_engine():
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tframe = from_triangles(prepare(scene_path("grazing-floor"), size=16, preset="grazing-floor-mip",
                                    cube_size=16))
    return dataclasses.replace(tframe.params, textures=TexCacheParams(block=4, sets=4, ways=2))


def test_mip_halves_have_a_request_per_level_cache(mip_engine):
    """With MIP mapping the front starts the texture's stages when the LOD unit's level is ready, hands each
    level cache its footprint, surface and skip bit, and the back blends the two levels' texels."""
    P = mip_engine.pipeline
    front, back = FrontParams(P, mip_engine.texture_layout()), BackParams(P)
    T = P.stage_latency
    assert front.start["texture"] == max(T["persp"], T["lod"]) and front.start["bump_map"] == T["persp"]
    outs = {p.name for p in front.outputs}
    for port in ("texture_even", "texture_odd"):
        assert {f"{port}_{c}" for c in CORNERS + ("surface", "skip")} <= outs
        assert f"{port}_texels" in {p.name for p in back.inputs}
    assert back.blend_latency("texture") == P.texture.latency - texel_stages(P.texture)
    assert not {"Ucx", "Wy"} & {p.name for p in back.inputs}
    from rtl.verilog import component_verilog
    for half in (front, back):
        assert "module" in component_verilog(build(half), "half")   # finish() checks the stated latency


def test_engine_ports(engine):
    from rtl.engine import Engine
    assert "tex" in Engine(engine).signature.members
    assert "tex" not in Engine(dataclasses.replace(engine, textures=None)).signature.members
    fp = FetchPipeline(engine.pipeline, engine.texture_caches(), engine.texture_layout())
    assert fp.fetch.side_bits == fp.carry.size
    with pytest.raises(ValueError, match="^caches="):
        FetchPipeline(engine.pipeline, dict(reversed(engine.texture_caches().items())), engine.texture_layout())
    assert set(fp.carry.members) == {p.name for p in fp.back.inputs if not p.name.endswith("_texels")}



def test_the_back_registers_the_texels_as_they_arrive(engine):
    """The caches' words (block RAM outputs through the bank multiplexer) reach the back's first stage, the texel
    differences, from registers: the back's stream unit has its input registers, and its latency counts them."""
    from rtl.pixel_fetch import BACK_IN_STAGES
    fp = FetchPipeline(engine.pipeline, engine.texture_caches(), engine.texture_layout())
    back, _ = fp.elaborate(None)._named_submodules["back"]
    assert back.params == fp.back and back.in_stages == BACK_IN_STAGES >= 1
    assert back.latency == fp.back.latency + BACK_IN_STAGES
