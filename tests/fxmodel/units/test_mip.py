"""The fixed-point MIP pyramid (fxmodel/units/mip.py) against exact area averages in Fractions."""

from fractions import Fraction
from math import floor

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fxmodel.units.mip import box_weights, mip_pyramid, mip_sizes


def _exact_level(codes, h, w):
    """Each texel of an ``h x w`` level: the exact area average of level 0 over the square it covers."""
    H, W, C = codes.shape
    out = np.zeros((h, w, C), dtype=object)
    for j in range(h):
        for i in range(w):
            y0, y1 = Fraction(j * H, h), Fraction((j + 1) * H, h)
            x0, x1 = Fraction(i * W, w), Fraction((i + 1) * W, w)
            acc = [Fraction(0)] * C
            for y in range(H):
                oy = max(Fraction(0), min(y1, y + 1) - max(y0, y))
                if not oy:
                    continue
                for x in range(W):
                    ox = max(Fraction(0), min(x1, x + 1) - max(x0, x))
                    if ox:
                        for c in range(C):
                            acc[c] += oy * ox * int(codes[y, x, c])
            area = (y1 - y0) * (x1 - x0)
            for c in range(C):
                out[j, i, c] = floor(acc[c] / area + Fraction(1, 2))          # half-up
    return out


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 13), st.integers(1, 13), st.integers(1, 2), st.integers(0, 2**32 - 1))
def test_every_level_is_the_exact_area_average_rounded_half_up(h, w, c, seed):
    """Odd and even sizes, signed codes: each stored code is the exact box average of level 0 over its square,
    rounded half-up once (no error accumulates from level to level), and within the range of the codes."""
    codes = np.random.default_rng(seed).integers(-512, 512, size=(h, w, c))
    levels = mip_pyramid(codes)
    assert [lv.shape[:2] for lv in levels] == mip_sizes(h, w)
    assert levels[-1].shape[:2] == (1, 1)
    assert np.array_equal(levels[0], codes)
    for lv in levels[1:]:
        assert np.array_equal(lv, _exact_level(codes, *lv.shape[:2]).astype(np.int64))
        assert lv.min() >= codes.min() and lv.max() <= codes.max()


def test_sizes_of_the_paper_bump_map_and_a_power_of_two():
    assert [s[0] for s in mip_sizes(40, 40)] == [40, 20, 10, 5, 2, 1]
    assert mip_sizes(64, 16) == [(64, 16), (32, 8), (16, 4), (8, 2), (4, 1), (2, 1), (1, 1)]
    assert mip_sizes(64, 64, levels=3) == [(64, 64), (32, 32), (16, 16)]


def test_box_weights_rows_sum_to_the_denominator():
    for n in range(1, 20):
        m = max(1, n // 2)
        assert all(sum(row) == n for row in box_weights(n, m))


def test_against_the_float_pyramid_of_the_study():
    """Power-of-two sizes: within half a code of host.mipmap.pyramid (box), the float pyramid of the filtering
    study (on odd sizes the study boxes each level from the one before, this one from level 0)."""
    from host.mipmap import pyramid
    codes = np.random.default_rng(3).integers(0, 256, size=(32, 8, 3))
    for fixed, flt in zip(mip_pyramid(codes), pyramid(codes.astype(np.float64))):
        assert np.abs(fixed - flt).max() <= 0.5 + 1e-9


def test_bad_input():
    with pytest.raises(ValueError, match="codes"):
        mip_pyramid(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="levels"):
        mip_pyramid(np.zeros((4, 4, 1), np.int64), levels=0)
