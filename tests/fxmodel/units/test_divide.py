"""Divider golden model (fxmodel.units.divide) against exact rational math: within its documented bound or saturated
toward the exact quotient, exact quotients of one, the bound measure, bad parameters.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units import exact
from fxmodel.units.divide import DivideParams

DIV = preset("divide", "default")


@given(st.lists(st.tuples(st.integers(DIV.num_fmt.min_code, DIV.num_fmt.max_code),
                          st.integers(DIV.recip.in_fmt.min_code, DIV.recip.in_fmt.max_code)), min_size=1, max_size=50))
def test_divide_within_bound_or_saturated(pairs):
    nd = np.array(pairs, dtype=np.int64)
    out = DIV.compute(nd)
    nf, df, of = DIV.num_fmt, DIV.recip.in_fmt, DIV.out_fmt
    for (n, d), (q, dbz, ovf) in zip(nd.tolist(), out.tolist()):
        if d == 0:
            assert dbz == 1 and q == (of.max_code if n > 0 else of.min_code if n < 0 else 0) and ovf == (n != 0)
            continue
        ratio = Fraction(n, 1 << nf.frac_bits) / Fraction(d, 1 << df.frac_bits)
        got = Fraction(q, 1 << of.frac_bits)
        if ovf:      # saturated: only when the exact quotient (within the bound) leaves the format
            assert got in (of.max_value, of.min_value) and (ratio > of.max_value - DIV.error_bound(abs(ratio))
                                                          or ratio < of.min_value + DIV.error_bound(abs(ratio)))
            assert (got > 0) == (ratio > 0)
        else:
            assert abs(got - ratio) <= DIV.error_bound(abs(ratio))


def test_divide_exact_quotients_of_one():
    d = np.array([1, 5, 1000, 1 << 13, -(1 << 14), DIV.recip.in_fmt.max_code], dtype=np.int64)
    out = DIV.compute(np.stack([d, d], 1))
    err = [abs(Fraction(int(q), 1 << DIV.out_fmt.frac_bits) - 1) for q in out[:, 0]]
    assert max(err) <= DIV.error_bound(Fraction(1)) and not out[:, 1:].any()


def test_divide_measure_reports_within_bound():
    rng = np.random.default_rng(3)
    nd = np.concatenate([DIV.hard_cases(), DIV.random_inputs(rng, 50_000)])
    rep = exact.MEASURES["divide"](DIV, nd, DIV.compute(nd))
    assert rep["vectors"] > 10_000 and rep["within_bound"] and rep["max_error"] <= rep["bound"]


def test_divide_invalid_parameters():
    with pytest.raises(ValueError, match="num_fmt="):
        DivideParams(num_fmt=Fmt(False, 2, 14))
    with pytest.raises(ValueError, match="quotient_limit="):
        DivideParams(quotient_limit=0)
