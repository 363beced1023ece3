"""Co-simulation of the cube-map address RTL against the golden model, bit for bit (paper sections 2 and 4).

Random directions at every scale, and the reflection unit's outputs fed to the cube unit (the chain of the
pipeline). Every preset on the hard cases of ``fxmodel/units/cube.py`` (ties of two and three components with all signs,
corners, axis-aligned vectors, zero components, the most negative codes, minor = +-major, the zero vector) and
random vectors: ``cosim/test_stress.py``.
``SIM=verilator`` runs the same tests on Verilator.
"""

import numpy as np

from cosim.conftest import assert_bit_exact
from cosim.harness import run
from fxmodel.core.unit import preset


def test_cube_directions_at_every_scale(sim):
    params = preset("cube", "default")
    rng = np.random.default_rng(404)
    fmt = params.in_fmt
    # random directions at every scale: random codes shifted right by 0..n-1 bits
    scaled = params.random_inputs(rng, 3000) >> rng.integers(0, fmt.width, size=(3000, 1))
    assert_bit_exact(run(params, scaled, sim=sim, tag="scaled"))


def test_cube_on_reflect_outputs(sim):
    """The reflection unit's R (hard cases and random) addresses the cube: the pipeline's chaining of formats."""
    reflect, cube = preset("reflect"), preset("cube")
    assert reflect.r_fmt.width == cube.in_fmt.width
    rng = np.random.default_rng(505)
    r = reflect.compute(np.concatenate([reflect.special_cases(), reflect.random_inputs(rng, 2000)]))
    assert_bit_exact(run(cube, r[:, :3], sim=sim, tag="chain"))
