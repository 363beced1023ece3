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
    out, flags = p.compute(*[[c] for c in codes])
    exact = p.exact(*codes)
    if flags[0] & FLAG_ZERO:
        assert exact == -math.inf and out[0] == p.out_fmt.min_code
        return
    assert not flags[0] & FLAG_BAD_W
    lam = out[0] / (1 << p.lod_frac)
    if flags[0] & FLAG_SATURATED:               # beyond the format: at the end the exact level is beyond
        assert (out[0] == p.out_fmt.max_code and exact >= lam) or (out[0] == p.out_fmt.min_code and exact <= lam)
        return
    assert abs(lam - exact) <= p.error_bound() + 1e-12, (codes, lam, exact)


def test_the_documented_bound_is_below_a_sixteenth_of_a_level():
    assert P.error_bound() <= 1 / 16 and NPOT.error_bound() <= 1 / 16
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


@given(st.integers(-P.d_bound, P.d_bound))
def test_square_pieces_reassemble_d_squared(d):
    """The RTL's ``D^2``: the pieces of :func:`fxmodel.core.cost.pieces`, each cross product once, doubled."""
    from fxmodel.core.cost import pieces
    cut = pieces(P.d_bits, True)
    bits = d & ((1 << P.d_bits) - 1)
    vals = []
    for lo, n, signed in cut:
        v = (bits >> lo) & ((1 << n) - 1)
        vals.append(v - (1 << n) if signed and v >> (n - 1) else v)
    total = sum((vals[i] * vals[j]) << (cut[i][0] + cut[j][0] + (i != j)) for i, j, *_ in P.square_pieces())
    assert total == d * d and abs(d) < 1 << (P.d_bits - 1)


def test_q_fits_its_register_at_the_formats_extremes():
    big = [P.uv_fmt.min_code, P.uv_fmt.min_code, P.w_fmt.min_code, P.duv_fmt.min_code, P.duv_fmt.min_code,
           P.duv_fmt.min_code, P.duv_fmt.min_code, P.dw_fmt.max_code, P.dw_fmt.max_code]
    fdu, fw = P.duv_fmt.frac_bits + P.w_fmt.frac_bits, P.uv_fmt.frac_bits + P.dw_fmt.frac_bits
    d = (big[3] * big[2] << (P.d_frac - fdu)) - (big[0] * big[7] << (P.d_frac - fw))
    assert abs(d) <= P.d_bound and (2 * d * d * P.size[0] ** 2).bit_length() <= P.q_bits


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
