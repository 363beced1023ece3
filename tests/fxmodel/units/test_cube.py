"""Cube-map address unit (paper sections 2 and 4): golden model against exact integer / rational math.

The face rule and the OpenGL / Vulkan table are restated here from docs/design.md ("Cube faces: table and tie rule"),
independently of the model; s and t are checked against exact ``Fraction`` quotients within the documented bound;
every hard case of the module docstring has a test.
"""

import json
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units import exact
from fxmodel.units.cube import FLIP_S, FLIP_T, CubeParams
from fxmodel.units.divide import DivideParams
from fxmodel.units.recip import RecipParams
from tools.main import main as bumpmap

PRESETS = ["default", "small"]

# docs/design.md, "The face table", verbatim: face -> (s_c, t_c) as (axis, sign), axis 0, 1, 2 = x, y, z
TABLE = {0: ((2, -1), (1, -1)),   # +x: s_c = -z, t_c = -y
         1: ((2, +1), (1, -1)),   # -x: s_c = +z, t_c = -y
         2: ((0, +1), (2, +1)),   # +y: s_c = +x, t_c = +z
         3: ((0, +1), (2, -1)),   # -y: s_c = +x, t_c = -z
         4: ((0, +1), (1, -1)),   # +z: s_c = +x, t_c = -y
         5: ((0, -1), (1, -1))}   # -z: s_c = -x, t_c = -y

SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def exact_face(v):
    """Major axis by magnitude, ties: z over y over x; negative only if < 0."""
    mags = [abs(c) for c in v]
    top = max(mags)
    axis = max(i for i in range(3) if mags[i] == top)     # the latest axis among the maxima wins
    return 2 * axis + (1 if v[axis] < 0 else 0)


def exact_st(v, face):
    ma = abs(v[face // 2])
    if ma == 0:
        return Fraction(1, 2), Fraction(1, 2)
    out = []
    for axis, sign in TABLE[face]:
        out.append((Fraction(sign * v[axis], ma) + 1) / 2)
    return tuple(out)


def run1(params, v):
    return [int(c) for c in params.compute(np.array([v], dtype=np.int64))[0]]


def vectors(params):
    """Components anywhere in the format, with ties, extremes and zeros made likely."""
    fmt = params.in_fmt
    comp = st.integers(fmt.min_code, fmt.max_code)
    special = st.sampled_from([fmt.min_code, fmt.min_code + 1, -1, 0, 1, fmt.max_code])

    @st.composite
    def vec(draw):
        a = draw(st.one_of(comp, special))
        pool = st.one_of(comp, special, st.just(a), st.just(-a).filter(lambda x: fmt.min_code <= x <= fmt.max_code))
        return [a, draw(pool), draw(pool)]
    return vec().flatmap(lambda v: st.permutations(v))


def check_row(params, v, out):
    face, s, t, deg = out
    assert face == exact_face(v), (v, out)
    f = params.st_fmt.frac_bits
    es, et = exact_st(v, face)
    for got, want in ((s, es), (t, et)):
        assert 0 <= got <= 1 << f
        assert abs(Fraction(got, 1 << f) - want) <= params.st_bound, (v, out, float(want))
    assert deg == (1 if v == [0, 0, 0] else 0)


# -- properties against exact math ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", PRESETS)
def test_face_and_st_match_exact_math(name):
    params = preset("cube", name)

    @SETTINGS
    @given(vectors(params))
    def prop(v):
        check_row(params, v, run1(params, v))
    prop()


@pytest.mark.parametrize("name", PRESETS)
def test_negation_gives_opposite_face_and_mirrored_st(name):
    """-v: face f ^ 1; per the table a coordinate whose s_c (t_c) keeps its sign rule mirrors (x -> 1 - x)."""
    params = preset("cube", name)
    one = 1 << params.st_fmt.frac_bits
    fmt = params.in_fmt

    @SETTINGS
    @given(vectors(params))
    def prop(v):
        assume(fmt.min_code not in v and any(v))
        f, s, t, _ = run1(params, v)
        g, s2, t2, _ = run1(params, [-c for c in v])
        assert g == f ^ 1
        for k, (a, b) in enumerate(((s, s2), (t, t2))):
            (ax1, sg1), (ax2, sg2) = TABLE[f][k], TABLE[g][k]
            assert ax1 == ax2
            # s_c(g)(-v) = sg2 * (-v[ax]) = -(sg2/sg1) s_c(f)(v): mirrored iff the signs agree
            assert b == (one - a if sg1 == sg2 else a)
    prop()


@pytest.mark.parametrize("name", PRESETS)
def test_power_of_two_scaling_is_invisible(name):
    """Only the direction matters: v and v * 2**k give identical outputs (docstring claim)."""
    params = preset("cube", name)
    fmt = params.in_fmt

    @SETTINGS
    @given(vectors(params), st.integers(1, fmt.width - 1))
    def prop(v, k):
        small = [c >> k for c in v]
        big = [c << k for c in small]
        assert run1(params, small) == run1(params, big) or not all(fmt.min_code <= c <= fmt.max_code for c in big)
    prop()


@pytest.mark.parametrize("name", PRESETS)
def test_large_random_set_within_bound(name):
    params = preset("cube", name)
    rng = np.random.default_rng(1)
    v = np.concatenate([params.hard_cases(), params.random_inputs(rng, 200_000),
                        params.random_inputs(rng, 50_000) >> rng.integers(0, params.in_fmt.width, (50_000, 1))])
    out = params.compute(v)
    report = exact.measure_cube(params, v, out)
    assert report["face_mismatches"] == 0
    assert report["st_in_range"] and report["degenerate_correct"]
    assert report["within_bound"], report
    assert report["max_error"] <= 2 ** -9                       # the target (half a texel of 256)


def test_default_target_is_met_with_margin():
    params = preset("cube")
    assert params.st_bound < Fraction(1, 1 << 16)
    assert preset("cube", "small").st_bound <= Fraction(1, 1 << 9)


def test_exact_table_matches_design():
    assert exact.CUBE_TABLE == TABLE
    for f in range(6):
        assert FLIP_S[f] == ((TABLE[f][0][1] < 0) != (f % 2 == 1))    # s_c/|ma| = sign * a / |ma| ...
        assert FLIP_T[f] == ((TABLE[f][1][1] < 0) != (f % 2 == 1))    # ... = -q when sign * sign(ma) < 0


# -- hard cases of the docstring -----------------------------------------------------------------------------

@pytest.mark.parametrize("name", PRESETS)
def test_hard_cases_exact(name):
    params = preset("cube", name)
    v = params.hard_cases()
    out = params.compute(v)
    for row, o in zip(v.tolist(), out.tolist()):
        check_row(params, row, o)


@pytest.mark.parametrize("name", PRESETS)
def test_zero_vector(name):
    params = preset("cube", name)
    half = 1 << params.q_fmt.frac_bits
    assert run1(params, [0, 0, 0]) == [4, half, half, 1]


@pytest.mark.parametrize("name", PRESETS)
def test_ties_of_three(name):
    """(+-a, +-a, +-a): z wins; the face is +Z or -Z by the sign of z, s and t exactly 0 or 1."""
    params = preset("cube", name)
    one = 1 << params.st_fmt.frac_bits
    fmt = params.in_fmt
    for a in (1, 5, fmt.max_code, -fmt.min_code):
        for sx in (1, -1):
            for sy in (1, -1):
                for sz in (1, -1):
                    v = [sx * a, sy * a, sz * a]
                    if not all(fmt.min_code <= c <= fmt.max_code for c in v):
                        continue
                    f, s, t, d = run1(params, v)
                    assert f == (4 if sz > 0 else 5)
                    assert s in (0, one) and t in (0, one) and d == 0


@pytest.mark.parametrize("name", PRESETS)
def test_ties_of_two(name):
    """|x| = |y| > |z| picks y; |x| = |z| or |y| = |z| (>= the other) picks z; s or t is then exactly 0 or 1."""
    params = preset("cube", name)
    one = 1 << params.st_fmt.frac_bits
    fmt = params.in_fmt
    for a in (2, 77, fmt.max_code, -fmt.min_code):
        for u in (a, -a):
            for w in (a, -a):
                for o in (0, a // 2, -(a // 2), a - 1, 1 - a):
                    for v, axis in (([u, w, o], 1), ([u, o, w], 2), ([o, u, w], 2)):
                        if not all(fmt.min_code <= c <= fmt.max_code for c in v):
                            continue
                        f, s, t, _ = run1(params, v)
                        assert f // 2 == axis, v
                        assert s in (0, one) or t in (0, one)


@pytest.mark.parametrize("name", PRESETS)
def test_minor_equals_plus_minus_major(name):
    """A minor component equal to +-major gives exactly 0 or 1 in its coordinate, per the table."""
    params = preset("cube", name)
    one = 1 << params.st_fmt.frac_bits
    fmt = params.in_fmt
    rng = np.random.default_rng(5)
    for a in [int(x) for x in rng.integers(1, fmt.max_code, 40)] + [fmt.max_code]:
        for v in ([a, 0, a], [a, 0, -a], [-a, a, 3], [3, -a, -a], [a, a // 3, 0]):
            f, s, t, _ = run1(params, v)
            es, et = exact_st(v, exact_face(v))
            for got, want in ((s, es), (t, et)):
                if want in (0, 1):
                    assert got == want * one, (v, f, s, t)


@pytest.mark.parametrize("name", PRESETS)
def test_axis_aligned_and_zero_component(name):
    params = preset("cube", name)
    half = 1 << params.q_fmt.frac_bits
    fmt = params.in_fmt
    for a in (1, 3, fmt.max_code, fmt.min_code, -1):
        for axis in range(3):
            v = [0, 0, 0]
            v[axis] = a
            assert run1(params, v) == [2 * axis + (a < 0), half, half, 0]
    # a zero minor gives exactly 1/2 in that coordinate
    f, s, t, _ = run1(params, [fmt.max_code, 1234, 0])
    assert f == 0 and s == half


@pytest.mark.parametrize("name", PRESETS)
def test_most_negative_codes(name):
    params = preset("cube", name)
    fmt = params.in_fmt
    mn, mx = fmt.min_code, fmt.max_code
    for v in ([mn, mx, mx], [mx, mn, mx], [mx, mx, mn], [mn, mn, mx], [mn, 0, 0], [mn, mn, mn], [mn, mn + 1, -mx]):
        check_row(params, v, run1(params, v))
    assert run1(params, [mn, mx, mx])[0] == 1                         # |min| > max: -X


# -- parameters, ports, CLI, RTL elaboration -----------------------------------------------------------------

def _divide(fmt, p, out_frac):
    return DivideParams(recip=RecipParams(in_fmt=fmt, m=6, b=max(p, 14), t=3, p=p, guard=4), num_fmt=fmt,
                        out_fmt=Fmt(True, 2, out_frac))


@pytest.mark.parametrize("kwargs, name", [
    (dict(divide="nope"), "divide"),
    (dict(divide=DivideParams(recip=RecipParams(in_fmt=Fmt(True, 1, 13), m=6, b=14, t=3, p=12, guard=4),
                              num_fmt=Fmt(True, 1, 15), out_fmt=Fmt(True, 2, 10))), "divide"),
    (dict(divide=_divide(Fmt(True, 1, 13), 12, 11)), "divide"),       # reciprocal error >= half an ulp of q
    (dict(divide=_divide(Fmt(True, 1, 13), 12, 10).replace(out_fmt=Fmt(True, 1, 10))), "divide"),
])
def test_invalid_parameters_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}="):
        CubeParams(**kwargs)


def test_ports_and_latency():
    params = preset("cube")
    assert [p.name for p in params.inputs] == ["x", "y", "z"]
    assert [p.name for p in params.outputs] == ["face", "s", "t", "degenerate"]
    assert params.latency == 3 + params.divide.latency
    assert preset("reflect").r_fmt.width == params.in_fmt.width
    assert preset("reflect", "small").r_fmt.width == preset("cube", "small").in_fmt.width


def test_cli_info_and_eval(tmp_path, capsys):
    assert bumpmap(["info", "cube"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert set(info["max_error"]) == {"face", "s", "t", "degenerate"}
    assert info["max_error"]["s"] == pytest.approx(float(preset("cube").st_bound))
    vals = np.array([[0.5, 0.25, -0.125], [0, 0, 0], [-1, 0.5, 0.5]])
    np.save(tmp_path / "in.npy", vals)
    assert bumpmap(["eval", "cube", str(tmp_path / "in.npy"), str(tmp_path / "out.npy")]) == 0
    out = np.load(tmp_path / "out.npy")
    assert out.shape == (3, 4)
    # +x face: s = (-z/x + 1)/2 = 0.625, t = (-y/x + 1)/2 = 0.25
    assert out[0].tolist() == [0, 0.625, 0.25, 0]
    assert out[1].tolist() == [4, 0.5, 0.5, 1]
    assert out[2].tolist() == [1, 0.75, 0.25, 0]          # -x: s_c = +z, t_c = -y
