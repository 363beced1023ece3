"""Co-simulation of the whole pixel pipeline RTL against the golden model, bit for bit: every shipped scene
rendered at a reduced size from its own memories (bump map, texture, two cubes), streamed through the stream
version of the pipeline under every stimulus pattern (gaps, backpressure, long stalls), with every pixel written
out and compared here too. Random fragments through the preset pipelines: ``cosim/test_stress.py``.
"""

import numpy as np
import pytest

from cosim.stream import PATTERNS, run_stream
from fxmodel.core.paths import SCENES as SCENE_DIR
from host.render import prepare
from host.shipped import scene_preset

SCENES = sorted(SCENE_DIR.glob("*.toml"))


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scene_rtl_equals_model(sim, path):
    frame = prepare(path, size=40, cube_size=16, preset=scene_preset(path))
    assert len(frame.codes) > 200
    result = run_stream(frame.params, frame.codes, sim=sim, chunk=-(-len(frame.codes) // len(PATTERNS)),
                        pattern=list(PATTERNS), dump=True)
    assert result.ok, result.describe()
    assert np.array_equal(result.rtl, frame.params.compute(frame.codes))


def test_mip_mapping_rtl_equals_model(sim):
    """MIP mapping of the color texture (preset ``grazing-floor-mip`` with its trilinear blends narrowed,
    ``blend_frac = 9``; the exact blends are co-simulated in the engine with its maps in memory,
    ``cosim/test_rtl_engine_fetch.py``): the LOD unit beside the perspective unit and the trilinear sampler, on the
    grazing floor (levels from magnified to the pyramid's top; at this reduced size the steepest increments are
    clamped to the LOD's formats, which changes the inputs, not the check), under every stimulus pattern."""
    from fxmodel.pipeline.presets import preset_units
    frame = prepare(SCENE_DIR / "grazing-floor.toml", size=48, cube_size=16,
                    preset={**preset_units("grazing-floor-mip"), "blend_frac": 9}, allow_clamp=True)
    P = frame.params
    assert P.lod is not None and P.texture.trilinear and P.texture.blend_frac == 9
    lod = P.trace(frame.codes)["lod"] >> P.lod.lod_frac
    assert lod.min() < 0 and lod.max() >= P.texture.levels - 1                  # magnified .. the last level
    result = run_stream(P, frame.codes, sim=sim, chunk=-(-len(frame.codes) // len(PATTERNS)),
                        pattern=list(PATTERNS), dump=True)
    assert result.ok, result.describe()
    assert np.array_equal(result.rtl, P.compute(frame.codes))


def _stream_equals_model(frame, sim):
    result = run_stream(frame.params, frame.codes, sim=sim, pattern="random", dump=True)
    assert result.ok, result.describe()
    assert np.array_equal(result.rtl, frame.params.compute(frame.codes))


def _random_frames(first: int, count: int, size: int):
    """The first ``count`` random scenes from seed ``first`` on that the default preset draws (with fragments),
    prepared at ``size`` with 4-texel cube faces (a small Verilog build per scene)."""
    from host.render import ClampError
    from host.scene import parse_scene
    from host.scenegen import random_scene
    seed = first
    while count:
        scene = parse_scene(random_scene(np.random.default_rng(seed), size=size), source=f"seed {seed}")
        seed += 1
        try:
            frame = prepare(scene, cube_size=4)
        except ClampError:
            continue
        if len(frame.codes) >= 8:
            count -= 1
            yield seed - 1, frame


def test_random_scene_rtl_equals_model(sim):
    """A random scene (block exponents, tile offsets, lights along axes) through the RTL, bit for bit."""
    for _seed, frame in _random_frames(7, 1, 10):
        _stream_equals_model(frame, sim)


@pytest.mark.slow
def test_random_scenes_rtl_equals_model_thorough(sim):
    for _seed, frame in _random_frames(100, 8, 16):
        _stream_equals_model(frame, sim)
