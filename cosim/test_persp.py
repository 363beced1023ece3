"""Co-simulation of the perspective texture-coordinate RTL against the golden model, bit for bit."""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


@pytest.mark.parametrize("name", ["default", "small", "color"])
def test_persp_random_and_hard_cases(sim, name):
    params = preset("persp", name)
    rng = np.random.default_rng(31)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 8000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=name))
