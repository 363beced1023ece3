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
    tframe = from_triangles(prepare(scene_path("tin-plane"), size=16))
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


def test_trilinear_has_no_single_texel_stage():
    from fxmodel.units.sampler import SamplerParams
    with pytest.raises(ValueError, match="trilinear"):
        texel_stages(SamplerParams.PRESETS["trilinear"])


def test_engine_ports(engine):
    from rtl.engine import Engine
    assert "tex" in Engine(engine).signature.members
    assert "tex" not in Engine(dataclasses.replace(engine, textures=None)).signature.members
    fp = FetchPipeline(engine.pipeline, engine.texture_caches(), engine.texture_layout())
    assert fp.fetch.side_bits == fp.carry.size
    assert set(fp.carry.members) == {p.name for p in fp.back.inputs if not p.name.endswith("_texels")}
