"""Bump engine model (fxmodel.units.bump) against exact rational math: bound, saturation, hard cases."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Rounding
from fxmodel.core.unit import preset
from fxmodel.units.bump import BumpParams

P = preset("bump")


def exact_np(params, row):
    """Exact N 2^-e + du A0 + dv A1 (fractions) for one input row of codes."""
    n, d, a = params.n_fmt, params.d_fmt, params.a_fmt
    e = row[11] if params.exp_bits else 0
    N = [n.to_fraction(c) / 2 ** e for c in row[0:3]]
    du, dv = d.to_fraction(row[3]), d.to_fraction(row[4])
    A0 = [a.to_fraction(c) for c in row[5:8]]
    A1 = [a.to_fraction(c) for c in row[8:11]]
    return [N[i] + du * A0[i] + dv * A1[i] for i in range(3)]


def check_rows(params, rows):
    """Every output equals the exact sum rounded once and clamped; the flag says exactly when it clamped."""
    import math
    out = params.compute(rows)
    o = params.out_fmt
    for row, res in zip(rows.tolist(), out.tolist()):
        flag = False
        for i, w in enumerate(exact_np(params, row)):
            scaled = w / o.ulp
            code = math.floor(scaled + (Fraction(1, 2) if params.rounding is Rounding.HALF_UP else 0))
            clamped = min(max(code, o.min_code), o.max_code)
            flag |= clamped != code
            assert res[i] == clamped
            if clamped == code:
                assert abs(o.to_fraction(res[i]) - w) <= params.max_error
        assert res[3] == int(flag)


@given(st.data())
def test_random_inputs_within_bound_or_flagged(data):
    params = data.draw(st.sampled_from([P, preset("bump", "small"), preset("bump", "plain"),
                                        P.replace(rounding=Rounding.TRUNC)]))
    cols = [data.draw(st.lists(st.integers(p.fmt.min_code, p.fmt.max_code), min_size=8, max_size=8))
            for p in params.inputs]
    check_rows(params, np.array(cols, dtype=np.int64).T)


def test_hard_cases_within_bound_or_flagged():
    rows = P.hard_cases()
    out = P.compute(rows)
    assert out[:, 3].any() and not out[:, 3].all()
    check_rows(P, rows)


def test_extreme_perturbations_saturate_both_ways():
    d, a, n = P.d_fmt, P.a_fmt, P.n_fmt
    up = [n.max_code, n.max_code, n.max_code, d.min_code, d.min_code, a.min_code, a.min_code, a.min_code,
          a.min_code, a.min_code, a.min_code, 0]              # (-1)(-2) + (-1)(-2) added to ~2: far above
    down = [n.min_code] * 3 + [d.max_code, d.max_code] + [a.min_code] * 6 + [0]
    out = P.compute(np.array([up, down]))
    o = P.out_fmt
    assert out[0, :3].tolist() == [o.max_code] * 3 and out[1, :3].tolist() == [o.min_code] * 3
    assert out[:, 3].tolist() == [1, 1]


def test_zero_perturbation_is_exact():
    rng = np.random.default_rng(0)
    rows = P.random_inputs(rng, 200)
    rows[:, 3:5] = 0
    rows[:, 11] = 0
    out = P.compute(rows)
    assert np.array_equal(out[:, :3], rows[:, :3]) and not out[:, 3].any()


@pytest.mark.parametrize("e", range(8))
def test_block_exponent_scales_n_exactly_before_the_one_rounding(e):
    """Zero perturbation: N' = N 2^-e rounded half-up once (the shift itself loses nothing)."""
    rows = P.random_inputs(np.random.default_rng(e), 300)
    rows[:, 3:5] = 0
    rows[:, 11] = e
    out = P.compute(rows)
    want = [[int((Fraction(int(c), 2 ** e) + Fraction(1, 2)) // 1) for c in r] for r in rows[:, :3].tolist()]
    assert out[:, :3].tolist() == want and P.e_max == 7


def test_exp_bits_is_checked_and_zero_drops_the_input():
    with pytest.raises(ValueError, match="exp_bits="):
        BumpParams(exp_bits=5)
    assert [p.name for p in preset("bump", "plain").inputs][-1] == "A21" and P.inputs[-1].name == "Ae"


def test_widths_fit_18x18_and_int64():
    w = P.widths()
    assert P.d_fmt.width <= 18 and P.a_fmt.width <= 18 and w["sum"] <= 62
    # the sum format really holds the extreme sums (interval bound is attained)
    n, p = P.n_fmt, P.prod_fmt
    assert P.sum_fmt.max_code >= (n.max_code << (P.frac - n.frac_bits)) + 2 * (p.max_code << (P.frac - p.frac_bits))


@pytest.mark.parametrize("field", ["n_fmt", "d_fmt", "a_fmt", "out_fmt"])
def test_unsigned_formats_are_refused(field):
    with pytest.raises(ValueError, match=f"{field}="):
        BumpParams(**{field: Fmt(False, 2, 8)})


def test_rounding_must_be_a_rounding():
    with pytest.raises(ValueError, match="rounding="):
        BumpParams(rounding="half_up")
