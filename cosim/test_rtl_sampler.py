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


@pytest.mark.parametrize("shape, edge, blend", [
    ((1, 40, 40, 2), "repeat", 0),        # the paper's 40 x 40 bump map: levels 40, 20, 10, 5, 2, 1 (odd sizes)
    ((1, 6, 16, 2), "repeat", 0),         # non-square: the last levels 1 wide
    ((1, 5, 3, 2), "clamp", 0),           # odd, clamped at the edges
    ((1, 40, 40, 2), "repeat", 2),        # blend_frac: the row and column blends rounded
    ((1, 5, 3, 2), "clamp", 6),           # blend_frac = weight_bits: the row blends exact, the column blend rounded
])
def test_trilinear_level_memories(sim, shape, edge, blend):
    """Trilinear (MIP mapping): the even and odd level memories, every level boundary, magnified (negative LOD),
    the last level (1 x 1) and past it, each level's blends exact or narrowed (``blend_frac``), against the model
    bit for bit."""
    from fxmodel.core.fixed import Fmt
    from fxmodel.units.sampler import SamplerParams, Texels, mip_texels
    rng = np.random.default_rng([*shape, len(edge), 3])
    coord = Fmt(True, 3, 12) if edge == "repeat" else Fmt(False, 1, 12)
    tex = Texels(rng.integers(-512, 512, size=shape))
    params = SamplerParams(texels=tex, channels=(Fmt(True, 1, 9),) * 2, coord_fmt=coord, edge=edge, weight_bits=6,
                           filter="trilinear", mips=mip_texels(tex), lod_fmt=Fmt(True, 5, 6), level_bits=5,
                           blend_frac=blend)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 2000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"tri{edge}{shape[1]}x{shape[2]}b{blend}"))


@pytest.mark.parametrize("extra, edge", [(2, "border"), (3, "border"), (3, "repeat")])
def test_blend_kept_finer_than_the_texels(sim, extra, edge):
    """``extra_frac``: the blend rounded to ``extra`` more fraction bits than the texels (the pipeline's diffuse
    cube: the default shading unit's ``diffuse_fmt`` texels, a bordered cube map, 8-bit weights; and a one-memory map
    under repeat), bit for bit."""
    from fxmodel.core.fixed import Fmt
    from fxmodel.units.sampler import SamplerParams, Texels
    from fxmodel.units.shade import ShadeParams
    rng = np.random.default_rng([extra, len(edge), 5])
    shape, coord = ((6, 6, 6, 3), Fmt(False, 1, 16)) if edge == "border" else ((1, 5, 4, 3), Fmt(True, 3, 12))
    fmt = ShadeParams().diffuse_fmt
    params = SamplerParams(texels=Texels(rng.integers(0, 1 << fmt.width, size=shape)), channels=(fmt,) * 3,
                           coord_fmt=coord, edge=edge, extra_frac=extra, names=("r", "g", "b"))
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 2000)])
    assert_bit_exact(run(params, vectors, sim=sim, tag=f"fine{extra}{edge}"))
