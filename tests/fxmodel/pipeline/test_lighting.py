"""Reflectance cubes (fxmodel.pipeline.lighting): face orientation, exact Lambert/Phong values at texel centres."""

import math
from fractions import Fraction

import numpy as np
import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.pipeline.lighting import Light, Lighting, bake_cubes, face_directions
from fxmodel.units.sampler import SamplerParams
from host.reference import cube_address_float


@pytest.mark.parametrize("size", [1, 4, 5, 8])
def test_texel_directions_address_their_own_texel(size):
    dirs = face_directions(size)
    face, s, t = cube_address_float(dirs.reshape(-1, 3))
    f, j, i = np.meshgrid(np.arange(6), np.arange(size), np.arange(size), indexing="ij")
    assert np.array_equal(face, f.ravel())
    assert np.allclose(s, (i.ravel() + 0.5) / size) and np.allclose(t, (j.ravel() + 0.5) / size)
    assert np.allclose(np.linalg.norm(dirs, axis=-1), 1)


def test_face_centres_are_the_axes():
    dirs = face_directions(1)[:, 0, 0]
    axes = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    assert np.allclose(dirs, axes)


def test_one_white_light_gives_exact_lambert_and_phong_at_face_centres():
    size = 5                                           # odd: the centre texel looks exactly along the axis
    lighting = Lighting(lights=(Light((0.0, 0.0, 1.0), (1.0, 1.0, 1.0)),), ambient=(0.25, 0.25, 0.25),
                        specular=(1.0, 1.0, 1.0), shininess=8.0)
    dfmt, sfmt = Fmt(False, 2, 10), Fmt(False, 8, 4)
    diff, spec, info = bake_cubes(lighting, size, dfmt, sfmt)
    c = size // 2
    # +Z face centre: n.l = 1 -> D = 1.25 exactly, S = 255 exactly; opposite face: only the ambient term
    assert diff.codes[4, c, c].tolist() == [int(Fraction(5, 4) * 1024)] * 3
    assert spec.codes[4, c, c].tolist() == [255 * 16] * 3
    assert diff.codes[5, c, c].tolist() == [256] * 3 and spec.codes[5, c, c].tolist() == [0] * 3
    # a side face centre (n.l = 0): ambient only
    assert diff.codes[0, c, c].tolist() == [256] * 3
    # off-centre texel of +Z: n.l = 1/|(sc, tc, 1)| exactly, then half-up at 10 fraction bits
    sc = (0 + 0.5) / size * 2 - 1
    cosv = 1 / math.sqrt(sc * sc + sc * sc + 1)
    assert diff.codes[4, 0, 0, 0] == math.floor((0.25 + cosv) * 1024 + 0.5)
    assert spec.codes[4, 0, 0, 0] == math.floor(255 * cosv ** 8 * 16 + 0.5)
    assert info == {"diffuse_saturated": 0, "specular_saturated": 0}
    # the sampler reads the centre texel back exactly at s = t = 1/2 (bilinear weights 0 at a texel centre)
    smp = SamplerParams(texels=diff, channels=(dfmt,) * 3, coord_fmt=Fmt(False, 1, 16), edge="clamp")
    assert smp.compute(np.array([[4, 1 << 15, 1 << 15]]))[0].tolist() == [1280] * 3


def test_bright_lights_saturate_and_are_counted():
    lighting = Lighting(lights=(Light((0.0, 0.0, 1.0), (3.0, 3.0, 3.0)),), ambient=(1.5, 1.5, 1.5), shininess=1.0)
    _, _, info = bake_cubes(lighting, 4, Fmt(False, 2, 10), Fmt(False, 8, 4))
    assert info["diffuse_saturated"] > 0 and info["specular_saturated"] > 0


def test_bad_inputs():
    with pytest.raises(ValueError, match="no direction"):
        Light((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)).unit()
    with pytest.raises(ValueError, match="face size"):
        bake_cubes(Lighting(lights=()), 0, Fmt(False, 2, 10), Fmt(False, 8, 4))
