"""Reciprocal golden model (fxmodel.units.recip, its bound fxmodel.units.recip_bound) against exact rational / integer
math.

The exhaustive test covers all 2**24 inputs of ``default``; hypothesis draws whole parameter sets and checks
every input of each against the documented bound; each hard case named in the module docstring has a test.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units import exact, recip_bound
from fxmodel.units.recip import TABLE_MODES, RecipParams

DEFAULT = preset("recip", "default")


def value(params, code):
    """Exact real value of the unit's result for one input code."""
    mant, exp, dbz = (int(v) for v in params.compute(np.array([code]))[0])
    return Fraction(mant, 1 << params.fo) * Fraction(2) ** exp, dbz


def errors_ulp(params, w):
    out = params.compute(w)
    return exact.recip_error_ulp(w, out[:, 0], out[:, 1], params.in_fmt.frac_bits, params.fo)


# -- exhaustive: the default preset is faithful on every one of the 2**24 inputs ----------------------------------
def test_default_is_faithful_on_all_inputs():
    w = DEFAULT.all_inputs()[:, 0]
    assert len(w) == 1 << 24
    num, den = errors_ulp(DEFAULT, w)
    assert np.all(num < den), "some output is 1 ulp or more away from the exact 1/w"
    assert np.all(exact.within(num[::997], den[::997], DEFAULT.error_bound_ulp))
    ratios = num / den
    assert ratios.max() <= float(DEFAULT.error_bound_ulp)
    assert DEFAULT.error_bound_ulp < 1 and DEFAULT.p >= 16


# -- random parameter sets: every input within the documented bound ----------------------------------------------
@st.composite
def recip_params(draw):
    n = draw(st.integers(6, 14))
    frac = draw(st.integers(0, n))
    m = draw(st.integers(2, min(n - 1, 8)))
    t = draw(st.integers(1, 4))
    p = draw(st.integers(2, 16))
    b = draw(st.integers(p, p + 6))
    guard = draw(st.integers(0, 6))
    center = draw(st.booleans())
    table = draw(st.sampled_from(TABLE_MODES))
    try:
        return RecipParams(in_fmt=Fmt(True, n - frac, frac), m=m, b=b, t=t, p=p, guard=guard, center=center,
                           table=table)
    except ValueError:
        assume(False)


@given(recip_params())
def test_every_input_within_documented_bound(params):
    w = params.all_inputs()[:, 0]
    num, den = errors_ulp(params, w)
    ok = exact.within(num, den, params.error_bound_ulp)
    assert ok.all(), f"input code {w[~ok][0]} exceeds the bound {float(params.error_bound_ulp)} ulp"
    if params.error_bound_ulp < 1:          # faithful by the bound: every mantissa normalized (module docstring)
        mag = np.abs(params.compute(w[w != 0])[:, 0])
        assert mag.min() >= 1 << params.fo and mag.max() < 2 << params.fo


@given(recip_params())
def test_negation_symmetry(params):
    w = params.all_inputs()[:, 0]
    w = w[(w != 0) & (w != params.in_fmt.min_code)]     # -w representable, w != 0
    pos, neg = params.compute(w), params.compute(-w)
    assert np.array_equal(neg[:, 0], -pos[:, 0]) and np.array_equal(neg[:, 1], pos[:, 1])


@given(recip_params())
def test_powers_of_two_are_exact(params):
    F = params.in_fmt.frac_bits
    for k in range(params.n - 1):
        for code in ((1 << k), -(1 << k)):
            v, dbz = value(params, code)
            assert v == Fraction(1 << F, code) and dbz == 0


def test_table_words_are_rounded_reciprocals_of_w_h():
    P = DEFAULT
    for i, word in enumerate(P.rom):
        wh = Fraction((1 << (P.m - 1)) + i + 1, 1 << P.m) - Fraction(1, 1 << P.n)   # m bits then all ones
        exact_b = (1 / wh) * (1 << (P.b - 1))
        want = int(exact_b + Fraction(1, 2))                                           # round half up
        assert (1 << (P.b - 1)) + word == want and 0 <= word < (1 << (P.b - 1))


# -- hard cases named in the module docstring ----------------------------------------------------------------------
F = DEFAULT.in_fmt.frac_bits


def test_half_gives_exactly_two():
    assert value(DEFAULT, 1 << (F - 1)) == (2, 0)


def test_one_minus_ulp_is_faithful_and_above_one():
    v, _ = value(DEFAULT, (1 << F) - 1)
    exact_v = Fraction(1 << F, (1 << F) - 1)
    assert 1 < v and abs(v - exact_v) < Fraction(1, 1 << DEFAULT.fo)


def test_every_table_boundary_and_neighbours_in_every_binade():
    P = DEFAULT
    codes = []
    for k in range(P.m, P.n):
        for i in range(P.entries):
            base = ((1 << (P.m - 1)) + i) << (k - P.m)
            codes += [base - 1, base, base + 1]
    codes = np.array(codes + [-c for c in codes], dtype=np.int64)
    codes = codes[(codes >= P.in_fmt.min_code) & (codes <= P.in_fmt.max_code)]
    num, den = errors_ulp(P, codes)
    assert len(codes) > 5000 and np.all(num < den)
    assert np.all(exact.within(num, den, P.error_bound_ulp))


def test_smallest_and_largest_magnitudes():
    P = DEFAULT
    assert value(P, 1) == (Fraction(1 << F), 0) and value(P, -1) == (-Fraction(1 << F), 0)
    for code in (P.in_fmt.max_code, -P.in_fmt.max_code):
        num, den = errors_ulp(P, np.array([code]))
        assert num[0] < den[0]


def test_most_negative_code_is_exact():
    P = DEFAULT
    code = P.in_fmt.min_code
    assert value(P, code) == (Fraction(1 << F, code), 0)


def test_zero_saturates_and_flags():
    P = DEFAULT
    mant, exp, dbz = P.compute(np.array([0]))[0]
    assert dbz == 1 and mant == P.mant_fmt.max_code and exp == P.in_fmt.frac_bits
    # larger than every finite result
    v, _ = value(P, 0)
    assert v > value(P, 1)[0]


def test_hard_cases_cover_the_named_cases():
    codes = set(DEFAULT.hard_cases()[:, 0].tolist())
    fmt = DEFAULT.in_fmt
    assert {0, 1, -1, fmt.max_code, fmt.min_code, 1 << (F - 1), (1 << F) - 1} <= codes


# -- monotonicity is reported, not required; the checker itself must detect a violation --------------------------
def test_monotonicity_checker_detects_a_violation():
    w = np.array([1, 2, 3, 4])
    mant = np.array([8, 4, 5, 2])                 # value at w=3 larger than at w=2
    rep = exact.recip_monotone(w, mant, np.zeros(4, dtype=np.int64))
    assert rep == {"monotone": False, "violations": 1, "first": 2}
    assert exact.recip_monotone(w, np.array([8, 4, 3, 2]), np.zeros(4, dtype=np.int64))["monotone"]


# -- invalid parameters name the parameter -------------------------------------------------------------------------
@pytest.mark.parametrize("changes, name", [
    (dict(m=24), "m="), (dict(m=30), "m="), (dict(m=1), "m="), (dict(t=0), "t="), (dict(t=5), "t="),
    (dict(b=16), "b="), (dict(p=1, b=4), "p="), (dict(guard=-1), "guard="), (dict(table="best"), "table="),
    (dict(in_fmt=Fmt(False, 8, 16)), "in_fmt="), (dict(center=1), "center="),
])
def test_invalid_parameters_raise_naming_the_parameter(changes, name):
    with pytest.raises(ValueError, match=name):
        DEFAULT.replace(**changes)


def test_non_integer_parameters_are_type_errors():
    with pytest.raises(TypeError, match="m must be an int"):
        DEFAULT.replace(m=7.0)


def test_out_of_range_input_code_is_refused():
    with pytest.raises(ValueError, match="recip input w: row 1"):
        DEFAULT.compute(np.array([0, 1 << 23]))


# -- table modes (module docstring, "Table modes") ------------------------------------------------------------------
def test_midpoint_words_are_rounded_reciprocals_of_the_centres():
    P = DEFAULT.replace(table="midpoint")
    assert P.signed_d and P.d_fmt.signed and P.d_fmt.width == DEFAULT.d_fmt.width
    for i, word in enumerate(P.rom):
        wh = Fraction((1 << (P.m - 1)) + i + 1, 1 << P.m) - Fraction(1, 1 << P.n)
        c = wh - Fraction(1, 1 << (P.m + 1))                                          # the interval's centre
        assert (1 << (P.b - 1)) + word == int((1 / c) * (1 << (P.b - 1)) + Fraction(1, 2))


def _off_centre(P):
    """Largest ``|lo + hi| / 2`` over the intervals' exact error bands."""
    worst = Fraction(0)
    for c, code in zip(P.centers, P.table_codes):
        lo, hi = recip_bound.entry_error(P, c, int(code), pieces=16)
        worst = max(worst, abs(lo + hi) / 2)
    return worst


@pytest.mark.parametrize("mode", ["minimax", "midpoint-minimax"])
@pytest.mark.parametrize("t", [2, 3])
def test_minimax_words_centre_each_interval_within_a_word_step(mode, t):
    """Minimax leaves each interval's error band off-centre by at most half a table step times dT/dB (< 2)."""
    P = DEFAULT.replace(table=mode, t=t)
    assert _off_centre(P) <= Fraction(1, 1 << (P.b - 1))


@pytest.mark.parametrize("mode", ["round", "midpoint"])
def test_one_sided_bands_are_off_centre(mode):
    """The check above can fail: ``round`` bands, and ``midpoint`` bands for even t, are one-sided."""
    P = DEFAULT.replace(table=mode, t=2)
    assert _off_centre(P) > 4 * Fraction(1, 1 << (P.b - 1))


@pytest.mark.parametrize("t", [2, 3, 4])
def test_midpoint_buys_t_or_t_minus_one_bits_and_minimax_only_slack(t):
    from tools.tables import approx_bits
    for m in (6, 8):
        rnd, mmx, mid = (approx_bits(m, t, mode) for mode in ("round", "minimax", "midpoint"))
        gain = t if t % 2 == 0 else t - 1
        assert gain - 0.3 <= mid - rnd <= gain + 0.3, (m, rnd, mid)
        assert -0.01 <= mmx - rnd <= 0.1, (m, rnd, mmx)


@given(st.sampled_from(TABLE_MODES), st.integers(3, 8), st.integers(1, 4))
def test_rigorous_approximation_bound_covers_a_dense_sample(mode, m, t):
    """The exact band of table and series error contains a float64 sample of the same error (the bound's
    decomposition into monotone pieces is not too optimistic)."""
    from tools.tables import approx_params, sampled_bits
    P = approx_params(m, t, mode)
    assert sampled_bits(P) >= P.approx_bits - 1e-6                   # (float64 noise: ~1e-9 bits)
    assert sampled_bits(P) <= P.approx_bits + 0.02                   # and it is tight


def test_midpoint_hard_cases_include_every_centre():
    P = preset("recip", "small").replace(table="midpoint")
    codes = set(P.hard_cases()[:, 0].tolist())
    k, low = P.n - 1, P.n - 1 - P.m                                    # the top binade
    for i in range(P.entries):
        centre = (((1 << (P.m - 1)) + i) << (k - P.m)) + (1 << (k - P.m - 1)) - 1
        assert {centre - 1, centre, centre + 1, -centre} <= codes
    assert low > 0


def test_signed_d_is_zero_at_the_centre_and_changes_sign_across_it():
    """At the centre c the datapath's d is 0: with t = 2 the result there is B + B*0 = B, rounded."""
    P = preset("recip", "small").replace(table="midpoint", t=2)
    k = P.n - 1
    centre = ((1 << (P.m - 1)) << (k - P.m)) + (1 << (k - P.m - 1)) - 1     # first interval, top binade
    mant = int(P.compute(np.array([centre]))[0, 0])
    B = int(P.table_codes[0])
    want = (((B << (P.fr - (P.b - 1))) + P.bias_code + (1 << (P.fr - P.fo - 1))) >> (P.fr - P.fo))
    assert mant == want


# -- rcp24: a 24-bit faithful reciprocal from at most 128 entries ---------------------------------------------------
RCP24 = preset("recip", "rcp24")


def test_rcp24_preset_is_24_bit_faithful_by_the_bound_from_at_most_128_entries():
    assert RCP24.p == 24 and RCP24.entries <= 128 and RCP24.error_bound_ulp < 1
    assert RCP24.in_fmt.width == 25 and RCP24.input_space() <= 1 << 26


def test_default_products_fit_one_dsp_block_each_and_rcp24_splits_its_four():
    """Latency counts one extra stage per product wider than a MULT18X18D (the RTL registers its partial
    products), and one more for a split ``B*d`` (its sum feeds the next product: registered twice); the default's
    three products fit one block each."""
    assert DEFAULT.split_products == 0 and DEFAULT.settled_products == 0 and DEFAULT.latency == 2 * DEFAULT.t + 4
    assert all(max(a, b) <= RecipParams.DSP_BITS for _, a, b in DEFAULT.product_operands())
    assert [name for name, _, _ in RCP24.product_operands()] == ["B*d", "q*q", "q*g", "B*g"]
    assert RCP24.split_products == 4 and RCP24.settled_products == 1 and RCP24.latency == 2 * 4 + 4 + 4 + 1


def test_rcp24_hard_cases_and_random_are_faithful():
    rng = np.random.default_rng(24)
    w = np.concatenate([RCP24.hard_cases()[:, 0], RCP24.random_inputs(rng, 1_000_000)[:, 0]])
    num, den = errors_ulp(RCP24, w)
    assert np.all(num < den) and np.all(exact.within(num, den, RCP24.error_bound_ulp))


@pytest.mark.slow
def test_rcp24_is_faithful_on_all_inputs():
    total = RCP24.input_space()
    assert total == 1 << 25
    step = 1 << 23
    for start in range(0, total, step):
        w = RCP24.all_inputs(start, start + step)[:, 0]
        num, den = errors_ulp(RCP24, w)
        assert np.all(num < den) and np.all(exact.within(num, den, RCP24.error_bound_ulp)), start


# -- rcp32: a 32-bit input; all 2**32 inputs are checked by `make exhaustive-wide` (tools.exhaustive) ----------
RCP32 = preset("recip", "rcp32")


def test_rcp32_preset_is_24_bit_faithful_by_the_bound_from_64_entries():
    assert RCP32.in_fmt == Fmt(True, 16, 16) and RCP32.p == 24 and RCP32.entries == 64
    assert RCP32.error_bound_ulp < 1
    # one Taylor term fewer, or half the entries, is not faithful by the bound (why the preset needs both)
    assert RCP32.replace(t=3).error_bound_ulp >= 1 and RCP32.replace(m=6).error_bound_ulp >= 1


def test_rcp32_hard_cases_and_random_are_faithful():
    rng = np.random.default_rng(32)
    w = np.concatenate([RCP32.hard_cases()[:, 0], RCP32.random_inputs(rng, 500_000)[:, 0]])
    num, den = errors_ulp(RCP32, w)
    assert np.all(num < den) and np.all(exact.within(num, den, RCP32.error_bound_ulp))


@given(recip_params())
def test_lookup_table_path_equals_direct_datapath(params):
    """The memoized datapath (``_lut``) is the datapath: same codes on every input."""
    w = params.all_inputs()[:, 0]
    fast, direct = params._recip_chunk(w), params._recip_chunk(w, direct=True)
    assert params._lut is not None
    assert all(np.array_equal(a, b) for a, b in zip(fast, direct))


def test_with_table_rebuilds_the_model_from_the_given_words():
    """Fault injection: the same words give the same outputs on every input; one word off by one changes the
    outputs of some inputs (and only some), keeps the centring constant, and is refused when malformed."""
    small = preset("recip", "small")
    inputs = small.all_inputs()
    want = small.compute(inputs)
    same = small.with_table(small.table_codes)
    assert np.array_equal(same.compute(inputs), want)
    codes = np.array(small.table_codes)
    codes[5] += 1
    bad = small.with_table(codes)
    assert bad.rom[5] == small.rom[5] + 1 and bad.bias_code == small.bias_code
    changed = np.any(bad.compute(inputs) != want, axis=1)
    assert 0 < changed.sum() < len(inputs) // small.entries * 2
    assert np.array_equal(small.compute(inputs), want)           # the original is untouched
    with pytest.raises(ValueError, match="codes"):
        small.with_table(codes[:-1])
    with pytest.raises(ValueError, match="codes"):
        small.with_table(np.full(small.entries, small.b_fmt.max_code + 1))
