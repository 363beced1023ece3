"""Co-simulation of the cube-map address RTL against the golden model, bit for bit (paper sections 2 and 4).

Every hard case of ``fxmodel/cube.py`` (ties of two and three components with all signs, corners, axis-aligned
vectors, zero components, the most negative codes, minor = +-major, the zero vector) plus random vectors, for
``default`` and ``small``; and the reflection unit's outputs fed to the cube unit (the chain of the pipeline).
``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.unit import preset


@pytest.mark.parametrize("name", ["default", "small"])
def test_cube_random_and_hard_cases(sim, name):
    params = preset("cube", name)
    rng = np.random.default_rng(404)
    fmt = params.in_fmt
    # random directions at every scale: random codes shifted right by 0..n-1 bits
    scaled = params.random_inputs(rng, 3000) >> rng.integers(0, fmt.width, size=(3000, 1))
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 8000), scaled])
    assert_bit_exact(run(params, vectors, sim=sim, tag=name))


def test_cube_on_reflect_outputs(sim):
    """The reflection unit's R (hard cases and random) addresses the cube: the pipeline's chaining of formats."""
    reflect, cube = preset("reflect"), preset("cube")
    assert reflect.r_fmt.width == cube.in_fmt.width
    rng = np.random.default_rng(505)
    r = reflect.compute(np.concatenate([reflect.special_cases(), reflect.random_inputs(rng, 2000)]))
    assert_bit_exact(run(cube, r[:, :3], sim=sim, tag="chain"))
