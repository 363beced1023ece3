"""Formats (fxmodel.core.fixed) and rounding/overflow rules (fxmodel.core.rounding) against exact rational math."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow, saturate, shift_round
from fxmodel.units.exact import round_exact

fmts = st.one_of(st.builds(Fmt, st.just(True), st.integers(2, 20), st.integers(0, 30)),
                 st.builds(Fmt, st.just(False), st.integers(1, 20), st.integers(0, 30)))


def test_format_ranges_and_names():
    f = Fmt(True, 8, 16)
    assert (f.width, f.min_code, f.max_code) == (24, -(1 << 23), (1 << 23) - 1)
    assert f.min_value == -128 and f.max_value == Fraction((1 << 23) - 1, 1 << 16)
    assert str(f) == "s8.16" and Fmt.parse("s8.16") == f and Fmt.parse("u1.16") == Fmt(False, 1, 16)
    assert Fmt(False, -3, 10).width == 7          # values below 2**-3 only
    assert Fmt.integer(-5, 20) == Fmt(True, 6, 0) and Fmt.integer(0, 20) == Fmt(False, 5, 0)
    assert Fmt.integer(-16, 15) == Fmt(True, 5, 0) and Fmt.integer(-17, 15) == Fmt(True, 6, 0)


@pytest.mark.parametrize("args, word", [((True, 1, -1), "frac_bits"), ((True, 0, 0), "width"),
                                        ((True, 1, 0), "signed"), ((1, 2, 3), "signed"), ((True, 2.0, 3), "int_bits")])
def test_bad_formats_name_the_field(args, word):
    with pytest.raises((ValueError, TypeError), match=word):
        Fmt(*args)


def test_parse_rejects_garbage():
    with pytest.raises(ValueError, match="s<int>.<frac>"):
        Fmt.parse("q8.16")


@given(fmts, st.data())
def test_real_code_round_trip_and_bits(fmt, data):
    codes = np.array(data.draw(st.lists(st.integers(fmt.min_code, fmt.max_code), min_size=1, max_size=20)))
    reals = fmt.to_real(codes)
    assert all(Fraction(float(r)) == c * fmt.ulp for r, c in zip(reals, codes))
    assert np.array_equal(fmt.from_real(reals), codes)
    bits = fmt.to_bits(codes)
    assert np.all((bits >= 0) & (bits < (1 << fmt.width)))
    assert np.array_equal(fmt.from_bits(bits), codes)


def test_from_real_names_the_first_bad_row():
    f = Fmt(True, 2, 2)
    with pytest.raises(ValueError, match=r"w: row 2: 0\.3 is not a multiple of the ulp 2\^-2"):
        f.from_real([0.25, -2.0, 0.3, 0.1], what="w")
    with pytest.raises(ValueError, match=r"row 1: 2\.0 is outside"):
        f.from_real([1.75, 2.0])
    with pytest.raises(ValueError, match="row 0: nan is not finite"):
        f.from_real([float("nan")])


@given(st.lists(st.integers(-(1 << 40), 1 << 40), min_size=1, max_size=30), st.integers(-5, 20),
       st.sampled_from(list(Rounding)))
def test_shift_round_matches_exact_rounding(xs, shift, mode):
    got = shift_round(np.array(xs, dtype=np.int64), shift, mode)
    want = [round_exact(Fraction(x, 1) / Fraction(2) ** shift, mode) for x in xs]
    assert got.tolist() == want


@given(st.lists(st.tuples(st.integers(-(1 << 30), 1 << 30), st.integers(0, 20)), min_size=1, max_size=30),
       st.sampled_from([Rounding.TRUNC, Rounding.HALF_UP]))
def test_data_dependent_shift_matches_exact_rounding(pairs, mode):
    xs = np.array([p[0] for p in pairs], dtype=np.int64)
    sh = np.array([p[1] for p in pairs], dtype=np.int64)
    got = shift_round(xs, sh, mode)
    assert got.tolist() == [round_exact(Fraction(x, 1 << s), mode) for x, s in pairs]


def test_saturate_flags_and_clamps():
    f = Fmt(True, 3, 0)                       # [-4, 3]
    y, flag = saturate(np.array([-9, -4, 0, 3, 4]), f, Overflow.SATURATE)
    assert y.tolist() == [-4, -4, 0, 3, 3] and flag.tolist() == [True, False, False, False, True]


def test_proven_overflow_raises_naming_the_value():
    with pytest.raises(OverflowError, match=r"q: .* row 1 .*code 8"):
        saturate(np.array([1, 8]), Fmt(False, 3, 0), Overflow.PROVEN, what="q")


def test_narrow_rounds_before_the_range_check():
    # 7.75 -> half-up at 0 fraction bits = 8 -> saturates to 7 in Fmt(False, 3, 0) with the flag
    y, flag = narrow(np.array([31]), 2, Fmt(False, 3, 0), Rounding.HALF_UP, Overflow.SATURATE)
    assert y.tolist() == [7] and flag.tolist() == [True]
    y, flag = narrow(np.array([31]), 2, Fmt(False, 3, 0), Rounding.TRUNC, Overflow.SATURATE)
    assert y.tolist() == [7] and flag.tolist() == [False]


def test_rounding_arguments_are_typed():
    with pytest.raises(TypeError, match="rounding"):
        shift_round(np.array([1]), 1, "half_up")
    with pytest.raises(TypeError, match="overflow"):
        saturate(np.array([1]), Fmt(False, 2, 0), "saturate")


@given(st.lists(st.floats(-300, 300, allow_nan=False), min_size=1, max_size=30),
       st.sampled_from(list(Rounding)))
def test_quantize_matches_exact_rounding_and_saturates(values, mode):
    from fxmodel.core.rounding import quantize
    f = Fmt(True, 8, 6)
    codes, flag = quantize(np.array(values), f, mode, Overflow.SATURATE)
    for v, c, fl in zip(values, codes.tolist(), flag.tolist()):
        want = round_exact(Fraction(v) * 64, mode)
        assert c == min(max(want, f.min_code), f.max_code) and fl == (want != c)


def test_quantize_refuses_non_finite():
    from fxmodel.core.rounding import quantize
    with pytest.raises(ValueError, match="tex: row 1"):
        quantize(np.array([0.0, np.inf]), Fmt(True, 8, 6), Rounding.HALF_UP, Overflow.SATURATE, "tex")


def test_quantize_rounds_once():
    from fxmodel.core.rounding import quantize
    codes, _ = quantize(np.array([0.49999999999999994, 0.5, -0.5, 2.5, 3.5]), Fmt(True, 8, 0), Rounding.HALF_UP,
                        Overflow.SATURATE)
    assert codes.tolist() == [0, 1, 0, 3, 4]
    codes, _ = quantize(np.array([0.5, 1.5, 2.5, -0.5, -1.5]), Fmt(True, 8, 0), Rounding.HALF_EVEN, Overflow.SATURATE)
    assert codes.tolist() == [0, 2, 2, 0, -2]
