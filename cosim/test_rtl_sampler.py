"""Co-simulation of the texture sampler RTL on texel-memory layouts the presets do not have, bit for bit (every
preset: ``cosim/test_stress.py``)."""

import numpy as np
import pytest

from cosim.conftest import assert_bit_exact
from cosim.harness import run


@pytest.mark.parametrize("shape, edge, banked", [
    ((1, 4, 6, 2), "repeat", True),          # even map, repeat: i0 = W - 1 and i1 = 0 have different parities
    ((1, 3, 5, 2), "clamp", True),           # odd map, clamp: banks padded; i0 = i1 at the edges (same texel)
    ((1, 5, 4, 2), "repeat", False),         # odd height under repeat: one memory, four read ports
    ((6, 5, 5, 2), "border", True),          # cube map with border, odd memory size
])
def test_banked_and_replicated_texel_memories(sim, shape, edge, banked):
    """The four-bank layout (by texel parity) and the replicated one, on map shapes that exercise the wraps,
    the clamps and the padding of odd sizes; the layout changes only the RTL, the model's sample is the rule."""
    from fxmodel.core.fixed import Fmt
    from fxmodel.units.sampler import SamplerParams, Texels
    rng = np.random.default_rng([*shape, len(edge)])
    coord = Fmt(True, 3, 12) if edge == "repeat" else Fmt(False, 1, 12)
    params = SamplerParams(texels=Texels(rng.integers(-512, 512, size=shape)), channels=(Fmt(True, 1, 9),) * 2,
                           coord_fmt=coord, edge=edge, weight_bits=6)
    assert params.banked == banked
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 2000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"{edge}{shape[1]}x{shape[2]}"))
