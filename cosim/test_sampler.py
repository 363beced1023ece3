"""Co-simulation of the texture sampler RTL (repeat/clamp, nearest/bilinear, 1 or 6 faces), bit for bit."""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


@pytest.mark.parametrize("name", ["default", "nearest", "cube", "border"])
def test_sampler_presets_random_and_hard_cases(sim, name):
    params = preset("sampler", name)
    rng = np.random.default_rng(21)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 4000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=name))
