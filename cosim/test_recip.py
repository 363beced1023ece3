"""Co-simulation of the reciprocal and divider RTL against the golden model, bit for bit (issue: recip).

Random plus every hard case of the model's docstring for ``default``; the whole input space (2**16) of
``small``; the divider on random and hard cases. ``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


def test_recip_default_random_and_hard_cases(sim):
    params = preset("recip", "default")
    rng = np.random.default_rng(2026)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 20_000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="default"))


def test_recip_small_exhaustive(sim):
    params = preset("recip", "small")
    vectors = params.all_inputs()
    assert len(vectors) == 1 << 16
    assert_bit_exact(run(params, vectors, sim=sim, tag="exhaustive"))


@pytest.mark.parametrize("t", [1, 2, 4])
def test_recip_other_term_counts(sim, t):
    """Every Taylor-term count builds a different datapath (t = 3 is covered above)."""
    params = preset("recip", "small").replace(t=t, m=7 if t == 1 else 6)
    rng = np.random.default_rng(t)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 3000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"t{t}"))


def test_divide_random_and_hard_cases(sim):
    params = preset("divide", "default")
    rng = np.random.default_rng(7)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 20_000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="default"))
