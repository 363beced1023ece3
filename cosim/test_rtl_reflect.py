"""Co-simulation of the reflection-vector RTL against the golden model, bit for bit (paper section 2, EQ 1).

Random vectors with short N and E (large normalization shifts). Every preset on the hard cases of
``fxmodel/units/reflect.py`` (all extreme-code combinations, parallel, anti-parallel, grazing, tiny, zero,
width-tight) and random vectors: ``cosim/test_stress.py``. ``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.core.unit import preset


def test_reflect_short_vectors(sim):
    params = preset("reflect", "default")
    rng = np.random.default_rng(303)
    short = rng.integers(-40, 40, size=(2000, 6), endpoint=True)          # large shifts, exact outputs
    assert_bit_exact(run(params, short, sim=sim, tag="short"))
