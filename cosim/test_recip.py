"""Co-simulation of the reciprocal and divider RTL against the golden model, bit for bit (issue: recip).

Random plus every hard case of the model's docstring for ``default``, ``rcp24`` and ``rcp32``; the whole input space
(2**16) of ``small`` in every table mode; the divider on random and hard cases. ``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.recip import TABLE_MODES
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


@pytest.mark.parametrize("mode", ["midpoint", "round"])
def test_recip_rcp24_random_and_hard_cases(sim, mode):
    """The 24-bit preset: 25-bit input, four terms, every product split into partial products (signed and, in
    ``round`` mode, unsigned d)."""
    params = preset("recip", "rcp24").replace(table=mode)
    assert params.split_products == 4
    rng = np.random.default_rng(24)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 20_000 if mode == "midpoint" else 5000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"rcp24_{mode}"))


def test_recip_rcp32_random_and_hard_cases(sim):
    """The 32-bit input preset (all 2**32 inputs: `make exhaustive-wide`)."""
    params = preset("recip", "rcp32")
    rng = np.random.default_rng(32)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 2000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="rcp32"))


def test_divide_random_and_hard_cases(sim):
    params = preset("divide", "default")
    rng = np.random.default_rng(7)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 20_000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag="default"))
