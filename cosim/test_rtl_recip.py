"""Co-simulation of the reciprocal and divider RTL against the golden model, bit for bit (issue: recip).

The whole input space (2**16) of ``small`` in every table mode and term count; ``rcp24`` in the table mode its
preset does not use. Every preset on its hard cases and random vectors: ``cosim/test_stress.py``.
``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.core.unit import preset
from fxmodel.units.recip import TABLE_MODES


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


@pytest.mark.parametrize("mode", [m for m in TABLE_MODES if m != "round"])
def test_recip_small_table_modes_exhaustive(sim, mode):
    """Every table mode over the whole input space of ``small``: the minimax words and, for the midpoint modes,
    the signed-d datapath (inverted top bit, signed products and Horner terms)."""
    params = preset("recip", "small").replace(table=mode)
    assert_bit_exact(run(params, params.all_inputs(), sim=sim, tag=f"exhaustive_{mode}"))


@pytest.mark.parametrize("t", [2, 4])
def test_recip_midpoint_other_term_counts(sim, t):
    """The signed datapath with no Horner step (t = 2) and with two (t = 4)."""
    params = preset("recip", "small").replace(table="midpoint", t=t)
    rng = np.random.default_rng(10 + t)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 5000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"midpoint_t{t}"))


def test_recip_rcp24_round_mode(sim):
    """The 24-bit preset in ``round`` mode: 25-bit input, four terms, every product split into partial products
    with an unsigned d (the preset's own midpoint mode: ``cosim/test_stress.py``)."""
    params = preset("recip", "rcp24").replace(table="round")
    assert params.split_products == 4 and preset("recip", "rcp24").table != "round"
    rng = np.random.default_rng(24)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 5000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="rcp24_round"))
