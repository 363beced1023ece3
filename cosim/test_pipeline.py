"""Co-simulation of the whole pixel pipeline RTL against the golden model, bit for bit.

Random fragments through the demo pipeline (every stage's corner cases reach it through ``hard_cases``), and
every shipped scene rendered at a reduced size from its own memories (bump map, texture, two cubes).
"""

from pathlib import Path

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.render import prepare
from fxmodel.unit import preset

SCENES = sorted((Path(__file__).resolve().parents[1] / "scenes").glob("*.toml"))


def test_pipeline_random_fragments(sim):
    params = preset("pipeline")
    rng = np.random.default_rng(51)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 1500)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="random"))


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scene_rtl_equals_model(sim, path):
    frame = prepare(path, size=40, cube_size=16)
    assert len(frame.codes) > 200
    result = run(frame.params, frame.codes, sim=sim, tag=f"scene_{path.stem}")
    assert_bit_exact(result)
    assert np.array_equal(result.rtl, frame.params.compute(frame.codes))
