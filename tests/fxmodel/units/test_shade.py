"""Shading (fxmodel.units.shade) against exact rational math."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units.shade import ShadeParams

P = preset("shade")


def check(rows):
    out = P.compute(rows)
    for row, res in zip(rows.tolist(), out.tolist()):
        flag = False
        for k in range(3):
            exact = row[k] * P.diffuse_fmt.to_fraction(row[3 + k]) + P.specular_fmt.to_fraction(row[6 + k])
            code = math.floor(exact + Fraction(1, 2))
            assert res[k] == min(code, 255)
            flag |= code > 255
        assert res[3] == int(flag)


@given(st.data())
def test_random_rows_are_the_exactly_rounded_sum(data):
    cols = [data.draw(st.lists(st.integers(p.fmt.min_code, p.fmt.max_code), min_size=12, max_size=12))
            for p in P.inputs]
    check(np.array(cols, dtype=np.int64).T)


def test_hard_cases():
    rows = P.hard_cases()
    out = P.compute(rows)
    assert out[:, 3].any() and not out[:, 3].all()
    check(rows)
    # black texture, no specular: black; white with D = 1 and no specular: white, exactly
    one = 1 << P.diffuse_fmt.frac_bits
    res = P.compute(np.array([[0, 0, 0, one, one, one, 0, 0, 0], [255] * 3 + [one] * 3 + [0] * 3]))
    assert res[0, :3].tolist() == [0, 0, 0] and res[1, :3].tolist() == [255, 255, 255] and not res[:, 3].any()


def test_signed_formats_are_refused():
    with pytest.raises(ValueError, match="diffuse_fmt="):
        ShadeParams(diffuse_fmt=Fmt(True, 2, 10))
