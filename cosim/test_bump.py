"""Co-simulation of the bump engine RTL against the golden model, bit for bit (random and hard cases)."""

import numpy as np

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


def test_bump_default_random_and_hard_cases(sim):
    params = preset("bump", "default")
    rng = np.random.default_rng(11)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 10_000)])
    out = params.compute(vectors)
    assert out[:, 3].any() and not out[:, 3].all(), "the vectors must exercise saturation and its absence"
    assert_bit_exact(run(params, vectors, sim=sim, tag="default"))


def test_bump_small_random(sim):
    params = preset("bump", "small")
    rng = np.random.default_rng(12)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 5_000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="small"))
