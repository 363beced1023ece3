"""Co-simulation of the shading RTL against the golden model, bit for bit."""

import numpy as np

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


def test_shade_random_and_hard_cases(sim):
    params = preset("shade")
    rng = np.random.default_rng(41)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 8000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="default"))
