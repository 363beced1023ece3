"""Perspective texture coordinates (fxmodel.units.persp) against exact rational math."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units.persp import PerspParams

P = preset("persp")


def wrapped_distance(a: Fraction, b: Fraction) -> Fraction:
    d = (a - b) - math.floor(a - b)
    return min(d, 1 - d)


def check(params, rows):
    out = params.compute(rows)
    uf, wf = params.uv_fmt, params.recip.in_fmt
    for row, res in zip(rows.tolist(), out.tolist()):
        nums, w, coords, dbz = row[:-1], row[-1], res[:-1], res[-1]
        if w == 0:
            assert coords == [0] * len(coords) and dbz == 1
            continue
        assert dbz == 0 and all(0 <= c < (1 << params.coord_bits) for c in coords)
        for num, got in zip(nums, coords):
            exact = uf.to_fraction(num) / wf.to_fraction(w)
            d = wrapped_distance(Fraction(got, 1 << params.coord_bits), exact)
            assert d <= params.error_bound(abs(exact)), (num, w, got, float(exact))


@given(st.sampled_from(["default", "small", "color"]), st.data())
def test_random_within_bound(name, data):
    params = preset("persp", name)
    cols = [data.draw(st.lists(st.integers(p.fmt.min_code, p.fmt.max_code), min_size=10, max_size=10))
            for p in params.inputs]
    check(params, np.array(cols, dtype=np.int64).T)


def test_hard_cases_within_bound():
    rows = P.hard_cases()
    assert (rows[:, 2] == 0).any() and (rows[:, 0] < 0).any()
    check(P, rows)


def test_integer_coordinates_wrap_to_zero_and_one_minus_ulp_stays():
    one = 1 << P.uv_fmt.frac_bits
    w1 = 1 << P.recip.in_fmt.frac_bits                      # W = 1: 1/W exact
    rows = np.array([[3 * one, -2 * one, w1], [one - 1, -1, w1], [0, 0, 12345]])
    out = P.compute(rows)
    top = 1 << P.coord_bits
    ulp = top >> P.uv_fmt.frac_bits                          # one input ulp in output codes
    assert out[0, :2].tolist() == [0, 0]
    assert out[1, :2].tolist() == [top - ulp, top - ulp]    # 1 - ulp and -ulp (= 1 - ulp mod 1)
    assert out[2, :2].tolist() == [0, 0]


def test_invalid_parameters():
    with pytest.raises(ValueError, match="uv_fmt="):
        PerspParams(uv_fmt=Fmt(False, 8, 16))
    with pytest.raises(ValueError, match="coord_bits="):
        PerspParams(coord_bits=0)
