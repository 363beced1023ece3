"""MIP pyramids, LEAN moments, screen-space derivatives and level of detail (``host.mipmap``), and the filtered
float reference (``host.filtered``)."""

import numpy as np
import pytest

from fxmodel.core.paths import ROOT
from host.frontend import rasterize
from host.mipmap import (
    downsample,
    lean_pyramid,
    level_of_detail,
    pyramid,
    sample_trilinear,
    screen_derivatives,
    texel_derivatives,
)
from host.scene import load_scene

TIN = ROOT / "scenes" / "tin-plane.toml"


def test_box_is_the_two_by_two_average_and_keeps_the_mean():
    rng = np.random.default_rng(3)
    img = rng.random((8, 6, 3))
    half = downsample(img)
    np.testing.assert_allclose(half[1, 2], img[2:4, 4:6].mean(axis=(0, 1)), atol=1e-12)
    levels = pyramid(rng.random((40, 40, 2)))
    assert [lv.shape[0] for lv in levels] == [40, 20, 10, 5, 2, 1]
    for lv in levels:
        np.testing.assert_allclose(lv.mean(axis=(0, 1)), levels[0].mean(axis=(0, 1)), atol=1e-12)


def test_lean_covariance_is_positive_semidefinite_at_every_level():
    rng = np.random.default_rng(4)
    for lv in lean_pyramid(rng.normal(size=(40, 40, 2))):
        du, dv, uu, uv, vv = np.moveaxis(lv, -1, 0)
        a, b, c = uu - du * du, uv - du * dv, vv - dv * dv
        assert (a >= -1e-12).all() and (c >= -1e-12).all() and (a * c - b * b >= -1e-9).all()


def test_screen_derivatives_match_finite_differences_and_level_zero_at_one_texel_per_pixel():
    scene = load_scene(TIN, size=64)
    frags = rasterize(scene)
    d = screen_derivatives(scene, frags)
    # finite differences between horizontally adjacent fragments of the same triangle (s is not affine in x:
    # compare to the derivative at the midpoint to second order)
    pos = {(int(x), int(y)): i for i, (x, y) in enumerate(zip(frags.x, frags.y))}
    checked = 0
    for i, (x, y) in enumerate(zip(frags.x, frags.y)):
        j = pos.get((int(x) + 1, int(y)))
        if j is None or frags.tri[j] != frags.tri[i]:
            continue
        fd = frags.uv[j] - frags.uv[i]
        np.testing.assert_allclose(fd, (d[i, :, 0] + d[j, :, 0]) / 2, rtol=2e-3, atol=1e-9)
        checked += 1
    assert checked > 1000
    dtex = texel_derivatives(d, (5, 5), (40, 40))
    lod = level_of_detail(dtex)
    np.testing.assert_allclose(level_of_detail(4 * dtex), lod + 2, atol=1e-12)      # 4 x the footprint: 2 levels
    np.testing.assert_allclose(level_of_detail(dtex, bias=-0.25), lod - 0.25, atol=1e-12)
    rho = np.maximum(np.hypot(*d[:, :, 0].T), np.hypot(*d[:, :, 1].T)) * 200           # 200 texels across the tile
    np.testing.assert_allclose(2.0 ** lod, rho, rtol=1e-12)


def test_trilinear_at_a_whole_level_is_bilinear_in_that_level():
    rng = np.random.default_rng(5)
    levels = pyramid(rng.random((16, 16, 3)))
    s, t = rng.random(50), rng.random(50)
    a = sample_trilinear(levels, s, t, np.full(50, 2.0))
    b = sample_trilinear(levels[2:], s, t, np.zeros(50))
    np.testing.assert_allclose(a, b, atol=1e-12)
    c = sample_trilinear(levels, s, t, np.full(50, 99.0))          # clamped to the 1 x 1 level: the mean
    np.testing.assert_allclose(c, np.broadcast_to(levels[0].mean(axis=(0, 1)), c.shape), atol=1e-12)


def test_bad_kernel_is_refused():
    with pytest.raises(ValueError, match="kernel"):
        downsample(np.zeros((4, 4, 1)), "gauss")


def test_lod_increments_are_the_steps_of_the_fragments_homogeneous_coordinates():
    """Uc, Vc, W are affine in screen space on a triangle (within a tile offset): the step from a fragment to its
    right (below) neighbour of the same triangle and tile is the x (y) increment, to the front end's snapping of
    the vertices to subpixels (the fragments interpolate the snapped triangle, the increments are the scene
    triangle's plane: a relative difference of about 1e-4, a ten-thousandth of a level)."""
    from host.bumpmap import scene_maps
    from host.mipmap import lod_increments
    scene = load_scene(ROOT / "scenes" / "grazing-floor.toml", size=96)
    frags = rasterize(scene)
    inc = lod_increments(scene, frags, scene_maps(scene)[0].color_repeat)
    pos = {(int(x), int(y)): i for i, (x, y) in enumerate(zip(frags.x, frags.y))}
    checked = 0
    for i, (x, y) in enumerate(zip(frags.x, frags.y)):
        for ax, (dx, dy) in (("x", (1, 0)), ("y", (0, 1))):
            j = pos.get((int(x) + dx, int(y) + dy))
            if j is None or frags.tri[j] != frags.tri[i] or (frags.tile_c[j] != frags.tile_c[i]).any() \
                    or frags.wscale[j] != frags.wscale[i]:
                continue
            for n in ("Uc", "Vc", "W"):
                step = np.asarray(getattr(frags, n))[j] - np.asarray(getattr(frags, n))[i]
                np.testing.assert_allclose(step, inc[n + ax][i], rtol=1e-3, atol=1e-7)
            checked += 1
    assert checked > 1000
