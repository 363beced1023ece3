"""Bump maps, quantization, color textures and the matrix A (host.bumpmap) against exact math."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from PIL import Image

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import SCENES
from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.bump import BumpParams
from host.bumpmap import (
    checker,
    chiselled_text,
    color_texture,
    graffiti,
    heights_from_image,
    material_maps,
    mexican_hat,
    perturbations,
    quantize,
    scene_maps,
    tangent_frame,
    triangle_matrix,
)
from host.meshes import quad_mesh
from host.scene import ColorSpec, load_scene

D = BumpParams().d_fmt                       # the bump engine's default


# -- central differences -----------------------------------------------------------------------------------
@given(st.integers(-50, 50), st.integers(-50, 50), st.integers(3, 12), st.integers(3, 12))
def test_ramp_differences_are_exact(a, b, w, h):
    """h = a j + b i: du = -a and dv = -b exactly away from the wrap; at the wrap the jump is seen."""
    i, j = np.mgrid[0:h, 0:w]
    du, dv = perturbations(a * j + b * i)
    assert np.all(du[:, 1:-1] == -a) and np.all(dv[1:-1, :] == -b)
    # wrap-around: column 0 differences use column w - 1, exactly
    assert np.all(du[:, 0] == -(a * 1 - a * (w - 1)) / 2) and np.all(du[:, -1] == -(0 - a * (w - 2)) / 2)
    assert np.all(dv[0, :] == -(b * 1 - b * (h - 1)) / 2)


@given(st.integers(1, 7), st.integers(0, 6), st.integers(4, 20), st.integers(4, 20))
def test_periodic_map_wraps_exactly(kx, ky, w, h):
    """A periodic height field: differences at the borders equal the analytic central differences, and
    shifting the map shifts the perturbations (the wrap has no seam)."""
    i, j = np.mgrid[0:h, 0:w].astype(float)
    hf = np.sin(2 * np.pi * kx * j / w) + np.cos(2 * np.pi * ky * i / h)
    du, dv = perturbations(hf)
    assert np.allclose(du, -np.cos(2 * np.pi * kx * j / w) * np.sin(2 * np.pi * kx / w), atol=1e-12)
    assert np.allclose(dv, np.sin(2 * np.pi * ky * i / h) * np.sin(2 * np.pi * ky / h), atol=1e-12)
    rng = np.random.default_rng(kx * 100 + ky)
    r = rng.random((h, w))
    du1, dv1 = perturbations(np.roll(r, (3, 5), axis=(0, 1)))
    du0, dv0 = perturbations(r)
    assert np.array_equal(du1, np.roll(du0, (3, 5), axis=(0, 1))) and np.array_equal(dv1, np.roll(dv0, (3, 5), (0, 1)))


def test_sign_convention():
    """Height rising toward +u (and +v): du < 0 (dv < 0) -- the normal tilts back, away from the slope."""
    i, j = np.mgrid[0:5, 0:5]
    du, dv = perturbations(0.1 * j + 0.0 * i)
    assert np.all(du[:, 1:-1] < 0) and np.all(dv == 0)
    du, dv = perturbations(0.1 * i)
    assert np.all(dv[1:-1] < 0) and np.all(du == 0)


def test_mexican_hat():
    h = mexican_hat((40, 40), 5.0)
    assert h.shape == (40, 40) and h[20, 20] == pytest.approx(1.0, abs=1e-9) and h.max() == h[20, 20]
    r2 = ((np.arange(40) - 20) / 5.0) ** 2
    ricker = (1 - r2) * np.exp(-r2 / 2)
    assert np.allclose(h[20, 10:31], ricker[10:31], atol=1e-6)                # the Ricker wavelet; at the borders
    assert np.allclose(h[20, 0], 2 * ricker[0], atol=1e-6)                    # the neighbouring tile's copy adds
    assert np.allclose(h, h.T) and np.allclose(h[1:, 1:], h[1:, 1:][::-1, ::-1])   # symmetric about (20, 20)
    # tiles smoothly: it is the sampled periodic sum of the wavelet over all tiles (here 7 x 7 of them)
    y, x = np.mgrid[0:40, 0:40]
    ref = sum((1 - q) * np.exp(-q / 2) for q in (((x - 20 + 40 * kx) ** 2 + (y - 20 + 40 * ky) ** 2) / 25.0
                                                  for kx in range(-3, 4) for ky in range(-3, 4)))
    assert np.allclose(h, ref, atol=1e-14, rtol=0)
    w = mexican_hat((30, 20))                                                  # non-square, default sigma
    assert w.shape == (20, 30) and w[10, 15] == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("sigma", [5e-324, 1e-160, 1e-10, 0.01])
def test_mexican_hat_of_a_tiny_sigma_is_one_spike(sigma):
    """Any sigma > 0 is valid in a scene file: a tiny one (sigma**2 underflows to 0) is a single spike at the
    centre, not NaN (which surfaced as an error naming no file or key) nor a numpy warning."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h = mexican_hat((8, 6), sigma)
    spike = np.zeros((6, 8))
    spike[3, 4] = 1.0
    assert np.array_equal(h, spike)


def test_heights_from_image_8_and_16_bit(tmp_path):
    a8 = np.array([[0, 128, 255], [1, 2, 3]], np.uint8)
    Image.fromarray(a8, "L").save(tmp_path / "a.png")
    assert np.array_equal(heights_from_image(tmp_path / "a.png"), a8 / 255.0)
    a16 = np.array([[0, 40000, 65535]], np.uint16)
    Image.fromarray(a16).save(tmp_path / "b.png")
    assert np.array_equal(heights_from_image(tmp_path / "b.png"), a16 / 65535.0)
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[..., 1] = 255
    Image.fromarray(rgb).save(tmp_path / "c.png")
    assert np.allclose(heights_from_image(tmp_path / "c.png"), 150 / 255.0)       # ITU-R 601 luma of green


def test_chiselled_text():
    h = chiselled_text((160, 64), "HI", font_size=40, depth=0.5, bevel=1.0, rot=0.0, seed=3)
    assert h.shape == (64, 160) and h.min() == 0.0 and h.max() == 1.0
    assert h[0, 0] == 1.0 and h[32, :50].min() == 1.0            # uncarved surface away from the centred text
    assert h[20:44, 60:100].min() == 0.0                          # the carving is in the middle
    a = chiselled_text((96, 48), rot=0.3, seed=7)
    assert np.array_equal(a, chiselled_text((96, 48), rot=0.3, seed=7))
    assert not np.array_equal(a, chiselled_text((96, 48), rot=0.3, seed=8))


# -- quantization -------------------------------------------------------------------------------------------
def exact_code(x: Fraction, fmt: Fmt):
    """round_half_up(x / ulp), clamped; and whether it clamped."""
    c = math.floor(x / fmt.ulp + Fraction(1, 2))
    return min(max(c, fmt.min_code), fmt.max_code), not fmt.min_code <= c <= fmt.max_code


@given(st.lists(st.floats(-3, 3, allow_nan=False), min_size=2, max_size=24),
       st.sampled_from([None, 0.25, 1.0, 1.5]), st.sampled_from([D, Fmt(True, 1, 7), Fmt(True, 2, 5)]))
def test_quantize_is_half_up_and_saturates_with_flag(vals, scale, fmt):
    du = np.array(vals[: len(vals) // 2])
    dv = np.array(vals[len(vals) // 2: 2 * (len(vals) // 2)])
    q = quantize(du, dv, fmt, scale)
    assert q.rounding is Rounding.HALF_UP and q.overflow is Overflow.SATURATE and q.fmt == fmt
    m = max(np.abs(du).max(), np.abs(dv).max())
    if scale is None:
        assume(m >= np.finfo(float).tiny)
        assert q.scale == m / float(fmt.max_value) and q.n_saturated == 0
        assert max(np.abs(q.du).max(), np.abs(q.dv).max()) == fmt.max_code        # uses the full range
    else:
        assert q.scale == scale
    flags = []
    for arr, codes in ((du, q.du), (dv, q.dv)):
        for x, c in zip(arr, codes):
            want, sat = exact_code(Fraction(float(x)) / Fraction(q.scale), fmt)
            assert c == want
            flags.append(sat)
    n = len(du)
    assert list(q.saturated) == [a or b for a, b in zip(flags[:n], flags[n:])]
    assert q.n_saturated == sum(q.saturated)


def test_quantize_rounds_the_exact_quotient_near_ties():
    """Values a few float ulps from a half-way point of ``d / scale``: the float quotient can land on or across
    the tie; the codes must be those of the exact quotient (a case hypothesis found once at random)."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        scale = float(rng.uniform(0.1, 3.0))
        k = rng.integers(D.min_code - 2, D.max_code + 2, size=64)
        x = (k + 0.5) * float(D.ulp) * scale
        x = x + np.spacing(x) * rng.integers(-3, 4, size=64)
        q = quantize(x, np.zeros_like(x), D, scale)
        for xi, c, sat in zip(x, q.du, q.saturated):
            want, want_sat = exact_code(Fraction(float(xi)) / Fraction(scale), D)
            assert (c, bool(sat)) == (want, want_sat), (xi, scale)


def test_quantize_ties_round_up_and_extremes():
    u = D.ulp
    vals = np.array([2.5 * float(u), -2.5 * float(u), 0.5 * float(u), -0.5 * float(u), 10.0, -10.0])
    q = quantize(vals, np.zeros(6), D, scale=1.0)
    assert list(q.du) == [3, -2, 1, 0, D.max_code, D.min_code]                    # ties toward +infinity
    assert list(q.saturated) == [False] * 4 + [True, True] and q.n_saturated == 2
    for tiny in (0.0, 5e-324):                                                     # flat (or subnormal) map
        flat = quantize(np.full((3, 3), tiny), np.zeros((3, 3)), D)
        assert flat.scale == 0.0 and not flat.du.any() and flat.n_saturated == 0
    ru, _ = quantize(vals[:4], np.zeros(4), D, scale=1.0).to_real()
    assert np.all(np.abs(ru - vals[:4]) <= float(u) / 2)
    with pytest.raises(ValueError):
        quantize(np.zeros(3), np.zeros(3), D, scale=0.0)


# -- the matrix A ---------------------------------------------------------------------------------------------
def test_matrix_of_axis_aligned_quad():
    """Wall facing +z, u to the right (+x), v down (-y): A[:, 0] along +x, A[:, 1] along -y."""
    P, N, UV = quad_mesh([-1, 1, 0], [2, 0, 0], [0, -2, 0], ((0, 0), (4, 4)), (1, 1))
    A = triangle_matrix(P, UV, strength=2.0, scale=0.25)
    assert np.allclose(A[:, :, 0], [0.5, 0, 0]) and np.allclose(A[:, :, 1], [0, -0.5, 0])
    assert np.allclose(N, [0, 0, 1])
    # a bump of du > 0 tilts N' toward +u (+x), as the paper's Fig. 4 says
    n_prime = N[0, 0] + 0.3 * A[0, :, 0]
    assert n_prime[0] > 0
    # floor facing +y (v toward +z): A[:, 1] along +z
    P, N, UV = quad_mesh([-1, 0, -1], [2, 0, 0], [0, 0, 2])
    A = triangle_matrix(P, UV, 1.0, 1.0)
    assert np.allclose(A[:, :, 0], [1, 0, 0]) and np.allclose(A[:, :, 1], [0, 0, 1]) and np.allclose(N, [0, 1, 0])


@given(st.lists(st.floats(-2, 2), min_size=6, max_size=6), st.lists(st.floats(-3, 3), min_size=6, max_size=6),
       st.lists(st.floats(-5, 5), min_size=3, max_size=3))
def test_tangent_frame_of_affine_mappings(m, uvs, origin):
    """P = O + M (u, v): T and B are the normalized columns of M whatever the triangle."""
    M = np.array(m).reshape(3, 2)
    uv = np.array(uvs).reshape(3, 2)
    assume(abs(np.linalg.det(np.c_[uv, np.ones(3)])) > 0.05)                   # non-degenerate (u, v) triangle
    n = np.cross(M[:, 0], M[:, 1])
    assume(np.linalg.norm(n) > 0.05 and np.linalg.norm(M[:, 0]) > 0.05 and np.linalg.norm(M[:, 1]) > 0.05)
    P = np.array(origin) + uv @ M.T
    T, B, ok = tangent_frame(P, uv)
    assert ok
    assert np.allclose(T, M[:, 0] / np.linalg.norm(M[:, 0]), atol=1e-7)
    assert np.allclose(B, M[:, 1] / np.linalg.norm(M[:, 1]), atol=1e-7)
    fn = n / np.linalg.norm(n)
    assert abs(T @ fn) < 1e-9 and abs(B @ fn) < 1e-9


def test_degenerate_mapping_gives_zero_matrix():
    P = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    uv = np.array([[0.0, 0], [1, 1], [2, 2]])
    T, B, ok = tangent_frame(P, uv)
    assert not ok and not T.any() and not B.any() and not triangle_matrix(P, uv, 1.0, 1.0).any()


def test_quantized_bump_reproduces_float_perturbation():
    """N + du_r A0 + dv_r A1 = N - strength (dh/du T + dh/dv B) within half a code of the map's format."""
    h = mexican_hat((40, 40), 5.0)
    du, dv = perturbations(h)
    q = quantize(du, dv, D)
    P, N, UV = quad_mesh([-1, 0, -1], [2, 0, 0], [0, 0, 2])
    strength = 2.5
    A = triangle_matrix(P[0], UV[0], strength, q.scale)
    T, B, _ = tangent_frame(P[0], UV[0])
    n = N[0, 0]
    engine = n + D.to_real(q.du)[..., None] * A[:, 0] + D.to_real(q.dv)[..., None] * A[:, 1]
    exact = n + strength * (du[..., None] * T + dv[..., None] * B)
    bound = strength * q.scale * float(D.ulp) / 2 * (1 + 1e-9)
    assert np.abs(engine - exact).max() <= 2 * bound                      # two components, each half an ulp
    assert np.abs(engine - exact).max() > 0                               # (the quantization is really there)


# -- color textures -------------------------------------------------------------------------------------------
def test_color_textures(tmp_path):
    c = color_texture(ColorSpec("rgb", rgb=(0.5, 1.0, 0.0)))
    assert c.dtype == np.uint8 and c.shape == (1, 1, 3) and list(c[0, 0]) == [128, 255, 0]   # half-up
    ch = checker((8, 4), (4, 2), ((1, 1, 1), (0, 0, 0)))
    assert ch.shape == (4, 8, 3) and list(ch[0, 0]) == [255] * 3 and list(ch[0, 2]) == [0] * 3
    assert list(ch[2, 0]) == [0] * 3 and list(ch[2, 2]) == [255] * 3
    g = graffiti((64, 32), seed=5)
    assert g.shape == (32, 64, 3) and g.dtype == np.uint8 and np.array_equal(g, graffiti((64, 32), seed=5))
    assert g.std() > 10
    rgb = np.random.default_rng(0).integers(0, 256, (5, 7, 3), dtype=np.uint8)
    Image.fromarray(rgb).save(tmp_path / "t.png")
    assert np.array_equal(color_texture(ColorSpec("file", path=tmp_path / "t.png")), rgb)


@pytest.mark.parametrize("name", ["tin-plane", "berlin-wall", "sphere"])
def test_shipped_scene_maps_fit_the_formats(name):
    scene = load_scene(SCENES / f"{name}.toml", size=64)
    a_fmt = BumpParams().a_fmt
    for mat, maps in zip(scene.materials, scene_maps(scene)):
        assert maps.color.dtype == np.uint8 and maps.color.ndim == 3
        if mat.bump is None:
            assert maps.bump is None and maps.a_gain == 0.0
            continue
        assert maps.bump.n_saturated == 0 and maps.bump.scale > 0
        assert D.contains(maps.bump.du).all() and D.contains(maps.bump.dv).all()
        assert 0 < maps.a_gain < float(a_fmt.max_value)                   # A = a_gain [T B] fits a_fmt
    tin = material_maps(load_scene(SCENES / "tin-plane.toml").materials[0])
    assert tin.bump.shape == (40, 40)                                     # the paper's Fig. 9 map size
