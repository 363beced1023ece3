"""Co-simulation of the reflection-vector RTL against the golden model, bit for bit (paper section 2, EQ 1).

Every hard case of ``fxmodel/reflect.py`` (all extreme-code combinations, parallel, anti-parallel, grazing, tiny,
zero, width-tight) plus random vectors, for ``default`` and ``small``; random vectors with short N and E too
(large normalization shifts). ``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


@pytest.mark.parametrize("name", ["default", "small"])
def test_reflect_random_and_hard_cases(sim, name):
    params = preset("reflect", name)
    rng = np.random.default_rng(303)
    short = rng.integers(-40, 40, size=(2000, 6), endpoint=True)          # large shifts, exact outputs
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 8000), short])
    assert_bit_exact(run(params, vectors, sim=sim, tag=name))
