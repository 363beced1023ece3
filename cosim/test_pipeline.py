"""Co-simulation of the whole pixel pipeline RTL against the golden model, bit for bit: every shipped scene
rendered at a reduced size from its own memories (bump map, texture, two cubes), streamed through the stream
version of the pipeline under every stimulus pattern (gaps, backpressure, long stalls), with every pixel written
out and compared here too. Random fragments through the preset pipelines: ``cosim/test_stress.py``.
"""

from pathlib import Path

import numpy as np
import pytest

from cosim.stream import PATTERNS, run_stream
from fxmodel.render import prepare

SCENES = sorted((Path(__file__).resolve().parents[1] / "scenes").glob("*.toml"))


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scene_rtl_equals_model(sim, path):
    frame = prepare(path, size=40, cube_size=16)
    assert len(frame.codes) > 200
    result = run_stream(frame.params, frame.codes, sim=sim, chunk=-(-len(frame.codes) // len(PATTERNS)),
                        pattern=list(PATTERNS), dump=True)
    assert result.ok, result.describe()
    assert np.array_equal(result.rtl, frame.params.compute(frame.codes))
