"""Reflection-vector unit (paper section 2, EQ 1): golden model against exact integer math.

EQ 1 is recomputed here with Python integers; the exact identities ``R.N = (N.E)(N.N)`` and
``|R|**2 = |E|**2 |N|**4`` are checked on the model's pre-narrowing R; the direction after narrowing is checked
against the documented bound exactly (``sin**2`` as integers); every hard case of the module docstring has a test.
"""

import json
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units import exact
from fxmodel.units.reflect import ReflectParams, bitlen_int64
from tools.main import main as bumpmap

PRESETS = ["default", "small"]
SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def eq1(N, E):
    p, q = dot(N, E), dot(N, N)
    return [2 * n * p - e * q for n, e in zip(N, E)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def run1(params, N, E):
    return [int(c) for c in params.compute(np.array([list(N) + list(E)], dtype=np.int64))[0]]


def comps(fmt):
    return st.one_of(st.integers(fmt.min_code, fmt.max_code),
                     st.sampled_from([fmt.min_code, fmt.min_code + 1, -2, -1, 0, 1, 2, fmt.max_code]),
                     st.integers(-3, 3))


def vec(fmt):
    return st.lists(comps(fmt), min_size=3, max_size=3)


def assert_direction(params, N, E, out):
    """Output direction within the documented bound of the exact R; flags and normalization as documented."""
    R = eq1(N, E)
    r = out[:3]
    w = params.r_bits
    if R == [0, 0, 0]:
        assert out == [0, 0, 0, 1]
        return
    assert out[3] == 0
    c = cross(R, r)
    assert dot(R, r) > 0, (N, E, out)
    # sin^2 = |R x r|^2 / (|R|^2 |r|^2) <= 3 * 2**(4 - 2w)
    assert Fraction(dot(c, c), dot(R, R) * dot(r, r)) <= params.sin2_bound, (N, E, out)
    # largest output magnitude at least 1/2 (2**(w-2) codes)
    assert max(abs(x) for x in r) >= 1 << (w - 2)
    # per component: the output is the floor of R * 2**-L in output ulps, L = bitlen of the largest one's-complement
    # magnitude (documented normalization), so the error is in [0, 1) ulp
    L = max((x if x >= 0 else -x - 1).bit_length() for x in R)
    for x, y in zip(R, r):
        exact_scaled = Fraction(x) * Fraction(2) ** (w - 1 - L)
        assert 0 <= exact_scaled - y < 1, (N, E, out)


# -- properties ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", PRESETS)
def test_exact_identities_before_narrowing(name):
    params = preset("reflect", name)

    @SETTINGS
    @given(vec(params.n_fmt), vec(params.e_fmt))
    def prop(N, E):
        p, q, R = params.exact_r([np.array([c]) for c in N + E])
        p, q, R = int(p[0]), int(q[0]), [int(x[0]) for x in R]
        assert p == dot(N, E) and q == dot(N, N)
        assert R == eq1(N, E)
        assert dot(R, N) == p * q                                   # R.N = (N.E)(N.N)
        assert dot(R, R) == dot(E, E) * q * q                       # |R|^2 = |E|^2 |N|^4
    prop()


@pytest.mark.parametrize("name", PRESETS)
def test_direction_within_bound(name):
    params = preset("reflect", name)

    @SETTINGS
    @given(vec(params.n_fmt), vec(params.e_fmt))
    def prop(N, E):
        assert_direction(params, N, E, run1(params, N, E))
    prop()


@pytest.mark.parametrize("name", PRESETS)
def test_large_random_set_within_bound(name):
    params = preset("reflect", name)
    rng = np.random.default_rng(2)
    v = np.concatenate([params.random_inputs(rng, 100_000),
                        params.random_inputs(rng, 20_000) >> rng.integers(0, params.n_fmt.width, (20_000, 1))])
    report = exact.measure_reflect(params, v, params.compute(v))
    assert report["within_bound"] and report["degenerate_correct"], report
    assert report["max_cube_st_error"] <= params.st_bound


# -- the no-overflow proof at the extremes -------------------------------------------------------------------

@pytest.mark.parametrize("name", PRESETS)
def test_hard_cases(name):
    """All 5**6 extreme-code combinations and the named geometric cases: no OverflowError, right direction."""
    params = preset("reflect", name)
    v = params.hard_cases()
    out = params.compute(v)
    for row, o in zip(v.tolist(), out.tolist()):
        assert_direction(params, row[:3], row[3:], o)


@pytest.mark.parametrize("name", PRESETS)
def test_exact_width_is_derived_and_tight(name):
    """R fits 2 nN + nE + 1 bits (the identity |R| = |E| |N|^2), and some input needs the top magnitude bit."""
    params = preset("reflect", name)
    nN, nE = params.n_fmt.width, params.e_fmt.width
    assert params.exact_fmt.width == 2 * nN + nE + 1
    a, b = -params.n_fmt.min_code, -params.e_fmt.min_code
    assert math.isqrt(27 * a ** 4 * b ** 2) < 1 << (2 * nN + nE)          # the proof's bound
    R = np.array([eq1(r[:3], r[3:]) for r in params.special_cases().tolist()], dtype=object)
    top = max(abs(int(x)) for x in R.ravel())
    assert top >= 1 << (2 * nN + nE - 1)              # one bit fewer would overflow
    assert top <= (1 << (2 * nN + nE)) - 1


@pytest.mark.parametrize("name", PRESETS)
def test_every_intermediate_width_holds_at_the_corners(name):
    """Exhaustive over corner codes: each intermediate of the datapath stays inside its derived format."""
    params = preset("reflect", name)
    w = params.widths()
    nv = [params.n_fmt.min_code, params.n_fmt.max_code, 0]
    ev = [params.e_fmt.min_code, params.e_fmt.max_code, 0]
    import itertools
    for N in itertools.product(nv, repeat=3):
        for E in itertools.product(ev, repeat=3):
            p, q = dot(N, E), dot(N, N)
            assert w["N.E"].min_code <= p <= w["N.E"].max_code
            assert 0 <= q <= w["N.N"].max_code
            for n, e in zip(N, E):
                assert w["N*E"].min_code <= n * e <= w["N*E"].max_code
                assert w["2N(N.E)"].min_code <= 2 * n * p <= w["2N(N.E)"].max_code
                assert w["E(N.N)"].min_code <= e * q <= w["E(N.N)"].max_code
                assert params.exact_fmt.min_code <= 2 * n * p - e * q <= params.exact_fmt.max_code


# -- named geometric cases -----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", PRESETS)
def test_parallel_and_anti_parallel(name):
    """N parallel or anti-parallel to E: R points along E (the reflection of the normal direction is itself)."""
    params = preset("reflect", name)
    big = params.n_fmt.max_code
    for d in ([1, 0, 0], [3, -2, 1], [1, 1, 1], [-5, 7, 2]):
        for kn in (1, -1, big // 7, -(big // 7)):
            for ke in (1, -1, 2, big // 7, -(big // 7)):
                N = [kn * c for c in d]
                E = [ke * c for c in d]
                out = run1(params, N, E)
                assert_direction(params, N, E, out)
                assert dot(out[:3], E) > 0
                assert Fraction(dot(cross(out[:3], E), cross(out[:3], E)),
                                dot(out[:3], out[:3]) * dot(E, E)) <= params.sin2_bound


@pytest.mark.parametrize("name", PRESETS)
def test_grazing(name):
    """N.E = 0: R = -E |N|^2, the output points along -E."""
    params = preset("reflect", name)
    rng = np.random.default_rng(9)
    n_lim = params.n_fmt.max_code // 4
    count = 0
    for _ in range(300):
        N = [int(x) for x in rng.integers(-n_lim, n_lim, 3)]
        E = cross(N, [int(x) for x in rng.integers(-3, 4, 3)])
        g = math.gcd(*E)
        if g == 0:
            continue
        E = [x // g for x in E]
        k = params.e_fmt.max_code // max(abs(x) for x in E)
        if k == 0:
            continue
        for s in (1, k):
            E2 = [s * x for x in E]
            assert dot(N, E2) == 0
            out = run1(params, N, E2)
            assert_direction(params, N, E2, out)
            assert dot(out[:3], E2) < 0
            c = cross(out[:3], E2)
            assert Fraction(dot(c, c), dot(out[:3], out[:3]) * dot(E2, E2)) <= params.sin2_bound
            count += 1
    assert count > 200


@pytest.mark.parametrize("name", PRESETS)
def test_tiny_vectors_are_exact(name):
    """Tiny N and E (codes up to +-2): R is short, the shift is a pure left shift, the output is exactly
    R * 2**k (parallel, nothing truncated)."""
    params = preset("reflect", name)
    tiny = [[1, 0, 0], [0, -1, 0], [0, 0, 1], [1, 1, 1], [-1, -1, -1], [2, -1, 1], [-2, 2, -2], [1, -2, 0]]
    for N in tiny:
        for E in tiny:
            out = run1(params, N, E)
            R = eq1(N, E)
            assert cross(R, out[:3]) == [0, 0, 0] and dot(R, out[:3]) > 0
            k = max(abs(x) for x in out[:3]) // max(abs(x) for x in R)
            assert [x * k for x in R] == out[:3]


@pytest.mark.parametrize("name", PRESETS)
def test_tiny_with_long(name):
    params = preset("reflect", name)
    big_n, big_e = params.n_fmt.max_code, params.e_fmt.max_code
    for N, E in (([1, 0, 0], [big_e, -big_e // 3, 5]), ([1, -1, 1], [-big_e, big_e, 7]),
                 ([big_n, big_n // 2, -big_n], [0, 1, 0]), ([params.n_fmt.min_code] * 3, [1, 2, -1])):
        assert_direction(params, N, E, run1(params, N, E))


@pytest.mark.parametrize("name", PRESETS)
def test_zero_inputs_are_degenerate(name):
    params = preset("reflect", name)
    mn = params.n_fmt.min_code
    assert run1(params, [0, 0, 0], [mn, 5, -3]) == [0, 0, 0, 1]
    assert run1(params, [mn, mn, mn], [0, 0, 0]) == [0, 0, 0, 1]
    assert run1(params, [0, 0, 0], [0, 0, 0]) == [0, 0, 0, 1]
    assert run1(params, [0, 0, 1], [0, 1, 0])[3] == 0


@pytest.mark.parametrize("name", PRESETS)
def test_minus_one_components(name):
    """R = (-1, 0, 0) (bit length L = 0 of every one's-complement magnitude) becomes -1.0 exactly."""
    params = preset("reflect", name)
    mn = params.r_fmt.min_code
    assert run1(params, [1, 0, 0], [-1, 0, 0]) == [mn, 0, 0, 0]
    assert run1(params, [0, 1, 0], [0, -1, 0]) == [0, mn, 0, 0]


def test_bitlen_int64_is_exact_near_powers_of_two():
    xs = [0, 1, 2, 3] + [v for k in range(2, 62) for v in ((1 << k) - 1, 1 << k, (1 << k) + 1)]
    got = bitlen_int64(np.array(xs, dtype=np.int64)).tolist()
    assert got == [x.bit_length() for x in xs]


# -- parameters, ports, CLI, RTL elaboration -----------------------------------------------------------------

@pytest.mark.parametrize("kwargs, name", [
    (dict(n_fmt=Fmt(False, 2, 16)), "n_fmt"),
    (dict(e_fmt="s2.16"), "e_fmt"),
    (dict(r_bits=1), "r_bits"),
    (dict(r_bits=18.0), "r_bits"),
    (dict(r_bits=56), "r_bits"),
    (dict(n_fmt=Fmt(True, 2, 20), e_fmt=Fmt(True, 2, 20)), "n_fmt"),     # exact R would need 67 bits
])
def test_invalid_parameters_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}="):
        ReflectParams(**kwargs)


def test_cli_info_and_eval(tmp_path, capsys):
    assert bumpmap(["info", "reflect"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert set(info["max_error"]) == {"Rx", "Ry", "Rz", "degenerate"}
    assert info["max_error"]["Rx"] == 2.0 ** -17
    vals = np.array([[0, 0, 1, 0, 0, 1],            # E along N: R along E, normalized to 0.5
                     [0, 0, 1, 1, 0, 0],            # grazing: R = -E
                     [0, 0, 0, 1, 0, 0]])           # N = 0: degenerate
    np.save(tmp_path / "in.npy", vals)
    assert bumpmap(["eval", "reflect", str(tmp_path / "in.npy"), str(tmp_path / "out.npy")]) == 0
    out = np.load(tmp_path / "out.npy")
    assert out.tolist() == [[0, 0, 0.5, 0], [-1, 0, 0, 0], [0, 0, 0, 1]]
