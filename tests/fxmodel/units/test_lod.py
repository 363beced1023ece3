"""The level-of-detail unit (``fxmodel.units.lod``) against the exact level of the same codes (exact fractions):
within its documented bound on random triangles, grazing, magnified, degenerate and at the far end of ``W``."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.units.lod import FLAG_BAD_W, FLAG_SATURATED, FLAG_ZERO, LodParams

P = LodParams()
NPOT = LodParams(size=(40, 24), table_bits=7, lod_frac=6, bias=-13, guard=3)      # a 40 x 24 map, a negative bias


def code(fmt: Fmt):
    """Codes of ``fmt``: anywhere, small (magnified, near zero) or at the ends of the range."""
    return st.one_of(st.integers(fmt.min_code, fmt.max_code), st.integers(-64, 64),
                     st.sampled_from([fmt.min_code, fmt.max_code, 1, -1, 0]))


def w_code(fmt: Fmt):
    """Positive ``W`` codes: anywhere, the far end (a few ulps), or exactly 1."""
    return st.one_of(st.integers(1, fmt.max_code), st.integers(1, 16), st.just(1 << fmt.frac_bits))


def pixel(p: LodParams):
    return st.tuples(code(p.uv_fmt), code(p.uv_fmt), w_code(p.w_fmt), code(p.duv_fmt), code(p.duv_fmt),
                     code(p.duv_fmt), code(p.duv_fmt), code(p.dw_fmt), code(p.dw_fmt))


def check(p: LodParams, codes):
    """The output against the exact level within the bound at the codes' own conditioning ``kappa`` (the theorem
    of the module docstring, for every ``kappa`` with ``eta kappa < 1``; beyond, nothing is claimed)."""
    out, flags = p.compute(*[[c] for c in codes])
    exact = p.exact(*codes)
    kappa = p.conditioning(*codes)
    if flags[0] & FLAG_ZERO:                    # every D lost: an exact zero, or outside any bound's domain
        assert (exact == -math.inf or p.eta * kappa >= 1) and out[0] == p.out_fmt.min_code
        return
    assert not flags[0] & FLAG_BAD_W
    lam = out[0] / (1 << p.lod_frac)
    if flags[0] & FLAG_SATURATED:               # beyond the format: at the end the exact level is beyond
        assert (out[0] == p.out_fmt.max_code and exact >= lam) or (out[0] == p.out_fmt.min_code and exact <= lam)
        return
    assert abs(lam - exact) <= p.error_bound(kappa * (1 + 1e-9)) + 1e-12, (codes, lam, exact, kappa)


def test_the_documented_bound_is_below_a_sixteenth_of_a_level():
    assert P.error_bound() <= 1 / 16 and NPOT.error_bound() <= 1 / 16
    # the domain: kappa <= 2^kappa_bits; the bound grows with kappa and ends where eta kappa = 1
    assert P.error_bound(1.0) < P.error_bound() < P.error_bound(2.0 ** 12) < math.inf == P.error_bound(1 / P.eta)
    # the table's error is about 1.44 / 2^table_bits: one bit less doubles it
    assert LodParams(table_bits=6).table_error() > 1.9 * P.table_error()


@given(pixel(P))
def test_level_within_bound_of_exact(codes):
    check(P, codes)


@given(pixel(NPOT))
def test_level_within_bound_non_power_of_two_map_and_bias(codes):
    check(NPOT, codes)


@given(st.floats(-0.45, 0.45), st.floats(0.5, 3.0), st.floats(2.0 ** -12, 1.0), st.floats(-2.0, 2.0))
def test_grazing_triangles(slope, ux, w, u):
    # a floor seen edge-on: W falls fast along y (W_y / W large), U changes along x; W from 1 down to 2^-12
    fu, fw, fdu, fdw = P.uv_fmt.frac_bits, P.w_fmt.frac_bits, P.duv_fmt.frac_bits, P.dw_fmt.frac_bits
    codes = (round(u * w * 2 ** fu), round(0.3 * w * 2 ** fu), max(1, round(w * 2 ** fw)),
             round(ux * 2 ** -6 * 2 ** fdu), round(slope * 2 ** -8 * 2 ** fdu), 0, round(0.01 * 2 ** fdu), 0,
             round(-slope * w * 2 ** fdw))
    check(P, codes)


def test_degenerate_and_bad_inputs_are_flagged():
    z = [0]
    out, flags = P.compute(z, z, [1 << 22], z, z, z, z, z, z)                # no derivative at all
    assert flags[0] == FLAG_ZERO and out[0] == P.out_fmt.min_code
    out, flags = P.compute([5], [5], [0], [1], [1], [1], [1], [1], [1])      # W = 0
    assert flags[0] & FLAG_BAD_W and out[0] == 0
    out, flags = P.compute([5], [5], [-3], [1], [1], [1], [1], [1], [1])     # W < 0
    assert flags[0] & FLAG_BAD_W


def test_one_texel_per_pixel_is_level_zero_and_doubling_adds_one():
    # s = x / 64 on a 64-texel map, W = 1: one texel per pixel; then two, four texels
    fdu = P.duv_fmt.frac_bits
    for k in range(5):
        out, flags = P.compute([0], [0], [1 << 22], [(1 << k) << (fdu - 6)], [0], [0], [0], [0], [0])
        assert flags[0] == 0 and out[0] == k << P.lod_frac


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="size"):
        LodParams(size=(0, 4))
    with pytest.raises(ValueError, match="table_bits"):
        LodParams(table_bits=0)
    with pytest.raises(ValueError, match="uv_fmt"):
        LodParams(uv_fmt=Fmt(False, 4, 4))


def test_vectorized_equals_one_at_a_time():
    rng = np.random.default_rng(7)
    cols = [rng.integers(-1 << 20, 1 << 20, 50) for _ in range(9)]
    cols[2] = rng.integers(1, 1 << 22, 50)
    out, flags = P.compute(*cols)
    for i in range(50):
        o, f = P.compute(*[[c[i]] for c in cols])
        assert o[0] == out[i] and f[0] == flags[i]


# -- the unit contract (fxmodel.core.unit.Unit): what the RTL, the harness and the cost model read ----------------
def test_unit_compute_on_a_code_matrix_equals_the_levels():
    from fxmodel.core.unit import preset
    for p in (preset("lod"), preset("lod", "npot")):
        codes = np.concatenate([p.hard_cases(), p.random_inputs(np.random.default_rng(3), 200)])
        out = p.compute(codes)
        lam, flags = p.levels(*codes.T)
        assert out.shape == (len(codes), 2) and (out[:, 0] == lam).all() and (out[:, 1] == flags).all()
        assert [q.name for q in p.inputs] == ["U", "V", "W", "Ux", "Uy", "Vx", "Vy", "Wx", "Wy"]
        # the hard cases reach a level, each flag and both ends of the format
        assert {FLAG_ZERO, FLAG_BAD_W, FLAG_SATURATED} <= {int(f) & b for f in out[:, 1] for b in (1, 2, 4)}
        assert p.out_fmt.max_code in out[:, 0] and (out[out[:, 1] == 0, 0] < 0).any()


def test_unit_rejects_codes_outside_the_formats():
    with pytest.raises(ValueError, match="lod input W"):
        P.compute(np.array([[0, 0, P.w_fmt.max_code + 1, 0, 0, 0, 0, 0, 0]]))


@given(st.lists(st.integers(-(1 << 60), 1 << 60), min_size=1, max_size=4), st.integers(4, 18))
def test_group_shift_fits_and_truncates_within_its_bound(codes, bits):
    """Step 1 and 3's shared shift: every shifted code fits ``bits`` signed bits; each loses less than
    ``2^(2 - bits)`` times the group's largest magnitude (FLOOR), nothing when the group already fits."""
    from fxmodel.units.lod import _norm_shift
    s = int(_norm_shift([np.array([c], dtype=object) for c in codes], bits, 1)[0])
    big = max(abs(c) for c in codes)
    for c in codes:
        t = c >> s
        assert -(1 << (bits - 1)) <= t < 1 << (bits - 1)
        assert 0 <= c - (t << s) < max(1, 2.0 ** (2 - bits) * big) and (s == 0 or c - (t << s) < 1 << s)
    assert s == 0 or max(abs(c >> (s - 1)) for c in codes) >= 1 << (bits - 1)     # the shift is the smallest


def test_q_fits_its_register_at_the_formats_extremes():
    big = [P.uv_fmt.min_code, P.uv_fmt.min_code, P.w_fmt.max_code, P.duv_fmt.min_code, P.duv_fmt.min_code,
           P.duv_fmt.min_code, P.duv_fmt.min_code, P.dw_fmt.max_code, P.dw_fmt.max_code]
    su, sw = P._scales()
    d = (big[3] * big[2] << su) - (big[0] * big[7] << sw)
    assert abs(d) <= P.d_bound
    lo = -(1 << (P.sq_width - 1))                 # the shifted D's largest magnitude, in both terms of Q
    assert (lo * lo * (P.size[0] ** 2 + P.size[1] ** 2)).bit_length() <= P.q_bits
    out, flags = P.compute(*[[c] for c in big])
    assert flags[0] & FLAG_SATURATED or out[0] > 0


@given(st.integers(1, 1 << 20), st.integers(0, 1 << 24), st.integers(-(1 << 10), 1 << 10), st.integers(1, 1 << 16))
def test_cancellation_is_within_the_bound_at_its_conditioning(w, u, r, wx):
    """The ill-conditioned case the bound's ``kappa`` measures: ``U_x W`` and ``U W_x`` nearly cancel (a large
    texture coordinate ``s = U / W`` whose derivative is small), at every ``kappa`` within the bound's reach."""
    su, sw = P._scales()
    # U_x W << su = U W_x << sw + r: the exact D is r (a few ulps of d_frac), the terms as large as they come
    num = ((u * wx) << sw) + r
    ux = ((num >> su) + w // 2) // w
    codes = (u, u // 3, w, max(P.duv_fmt.min_code, min(P.duv_fmt.max_code, ux)), 5, 7, ux // 2, wx, -wx)
    if codes[2] > P.w_fmt.max_code or abs(codes[0]) > P.uv_fmt.max_code or abs(codes[6]) > P.duv_fmt.max_code:
        return
    check(P, codes)


def test_errors_measure_holds_the_bound_and_counts_the_flags():
    """``bumpmap errors lod`` (:func:`fxmodel.units.exact.measure_lod`): the hard cases and random pixels within
    the bound, each flag counted; an output moved by one ulp beyond the bound is caught."""
    from fxmodel.units.exact import measure_lod
    rows = np.concatenate([P.hard_cases(), P.random_inputs(np.random.default_rng(5), 3000)])
    out = P.compute(rows)
    rep = measure_lod(P, rows, out)
    assert rep["within_bound"] and 0 < rep["max_error_levels"] <= rep["bound_levels"]
    assert all(rep["flagged"][k] > 0 for k in ("zero", "bad_w", "saturated"))
    worst = next(i for i in range(len(rows)) if rows[i].tolist() == rep["worst_input_codes"])
    exact = P.exact(*rows[worst])
    bad = out.copy()
    bad[worst, 0] += int(np.sign(out[worst, 0] / (1 << P.lod_frac) - exact)) * 8    # 8 ulps further away
    assert not measure_lod(P, rows, bad)["within_bound"]
