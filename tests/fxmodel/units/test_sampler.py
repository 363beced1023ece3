"""Texture sampler (fxmodel.units.sampler) against exact rational math: addressing, wrap, clamp, bilinear blend."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units.sampler import SamplerParams, Texels


def texels_strategy():
    return st.tuples(st.integers(1, 7), st.integers(1, 9), st.integers(0, 2**31 - 1))


def make(shape, seed, **kw):
    h, w = shape
    if kw.get("edge") == "border":
        h, w = h + 2, w + 2
    codes = np.random.default_rng(seed).integers(-512, 512, size=(1, h, w, 2))
    return SamplerParams(texels=Texels(codes), channels=(Fmt(True, 1, 9),) * 2, **kw)


def exact_sample(params, face, s, t):
    """Independent exact evaluation with fractions of the documented sampling rule."""
    T = params.coord_fmt.frac_bits
    B = params.weight_bits
    tex = params.texels.codes

    border = params.border

    def axis(code, size):
        v = Fraction(code, 1 << T)
        v = v - math.floor(v) if params.edge == "repeat" else min(max(v, Fraction(0)), Fraction(1))
        if params.filter == "nearest":
            return min(math.floor(v * size), size - 1) + border, None, None
        x = v * size - Fraction(1, 2) + border
        i0 = math.floor(x)
        f = Fraction(math.floor((x - i0) * (1 << B)), 1 << B)   # weight truncated to B bits
        i1 = i0 + 1
        if params.edge == "repeat":
            i0, i1 = i0 % size, i1 % size
        elif params.edge == "clamp":
            i0, i1 = min(max(i0, 0), size - 1), min(max(i1, 0), size - 1)
        return i0, i1, f

    i0, i1, fx = axis(s, params.width)
    j0, j1, fy = axis(t, params.height)
    if params.filter == "nearest":
        return [int(v) for v in tex[face, j0, i0]], None
    out, corners = [], []
    scale = 1 << params.extra_frac                              # the output's finer grid, in texel codes
    for k in range(len(params.channels)):
        a, b, c, d = (Fraction(int(tex[face, j, i, k])) for j, i in ((j0, i0), (j0, i1), (j1, i0), (j1, i1)))
        v = (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy
        out.append(math.floor(v * scale + Fraction(1, 2)))
        corners.append(tuple(x * scale for x in (a, b, c, d)))
    return out, corners


@given(texels_strategy(), st.sampled_from(["bilinear", "nearest"]), st.sampled_from(["repeat", "clamp", "border"]),
       st.integers(1, 8), st.lists(st.tuples(st.integers(-(1 << 23), (1 << 23) - 1),
                                             st.integers(-(1 << 23), (1 << 23) - 1)), min_size=1, max_size=20),
       st.integers(0, 16))
def test_matches_exact_sampling_rule(tex, flt, edge, wb, coords, extra):
    """Every filter and edge rule against Fractions; bilinear also with ``extra_frac`` (the blend rounded half-up
    to a grid up to ``2 weight_bits`` bits finer than the texels, within the four texels' range on that grid)."""
    h, w, seed = tex
    extra = min(extra, 2 * wb) if flt == "bilinear" else 0
    params = make((h, w), seed, filter=flt, edge=edge, weight_bits=wb, extra_frac=extra)
    assert params.out_channels == tuple(Fmt(True, 1, 9 + extra) for _ in range(2))
    st_codes = np.array(coords, dtype=np.int64)
    out = params.compute(st_codes)
    for (s, t), got in zip(coords, out.tolist()):
        want, corners = exact_sample(params, 0, s, t)
        assert got == want
        if corners:        # a bilinear sample lies within the range of its four texels
            for k, (a, b, c, d) in enumerate(corners):
                assert min(a, b, c, d) <= got[k] <= max(a, b, c, d)


@given(texels_strategy(), st.integers(-(1 << 20), 1 << 20), st.integers(-(1 << 20), 1 << 20), st.integers(-5, 5))
def test_repeat_is_periodic_with_the_map(tex, s, t, k):
    h, w, seed = tex
    params = make((h, w), seed)
    one = 1 << params.coord_fmt.frac_bits
    base = params.compute(np.array([[s, t]]))
    moved = params.compute(np.array([[s + k * one, t - k * one]]))
    assert np.array_equal(base, moved)


@pytest.mark.parametrize("filt", ["bilinear", "nearest"])
def test_texel_centres_return_the_texel_exactly(filt):
    params = make((5, 7), 3, filter=filt)
    T = params.coord_fmt.frac_bits
    tex = params.texels.codes[0]
    for j in range(5):
        for i in range(7):
            # centre (i + 1/2) / W is not a multiple of 2**-T for W = 7: take the code nearest to it from above
            s = -(-((2 * i + 1) << T) // (2 * 7))
            t = -(-((2 * j + 1) << T) // (2 * 5))
            got = params.compute(np.array([[s, t]]))[0]
            if filt == "nearest":
                assert got.tolist() == tex[j, i].tolist()
            else:   # weights truncate to 8 bits: just above the centre, the weight is exactly 0
                assert got.tolist() == tex[j, i].tolist()


def test_hard_coordinates_negative_and_far_outside():
    params = preset("sampler", "default")
    one = 1 << params.coord_fmt.frac_bits
    rows = np.array([[0, 0], [one - 1, one - 1], [-1, -1], [-one, 0], [100 * one + 7, -37 * one + 7],
                     [params.coord_fmt.max_code, params.coord_fmt.min_code]])
    out = params.compute(rows)
    for (s, t), got in zip(rows.tolist(), out.tolist()):
        assert got == exact_sample(params, 0, s, t)[0]
    # -1 ulp wraps to just below 1: the same as 1 - ulp
    assert out[1].tolist() == out[2].tolist()


def test_cube_faces_and_clamped_edges():
    params = preset("sampler", "cube")
    one = 1 << params.coord_fmt.frac_bits
    tex = params.texels.codes
    for face in range(6):
        rows = np.array([[face, 0, 0], [face, one, one], [face, one, 0]])
        out = params.compute(rows)
        # clamp: s = t = 0 is the corner texel, s = t = 1 the opposite corner, exactly
        assert out[0].tolist() == tex[face, 0, 0].tolist() and out[1].tolist() == tex[face, -1, -1].tolist()
        assert out[2].tolist() == tex[face, 0, -1].tolist()


@pytest.mark.parametrize("kw, name", [(dict(filter="cubic"), "filter="), (dict(edge="mirror"), "edge="),
                                      (dict(weight_bits=0), "weight_bits="), (dict(weight_bits=30), "weight_bits="),
                                      (dict(channels=(Fmt(True, 1, 9),)), "channels="),
                                      (dict(channels=(Fmt(True, 1, 5),) * 2), "texels="),
                                      (dict(names=("a",)), "names="),
                                      (dict(extra_frac=-1), "extra_frac="), (dict(extra_frac=17), "extra_frac="),
                                      (dict(extra_frac=1, filter="nearest"), "extra_frac=")])
def test_invalid_parameters_name_the_parameter(kw, name):
    base = dict(texels=Texels(np.zeros((1, 2, 2, 2), dtype=np.int64) + 100), channels=(Fmt(True, 1, 9),) * 2)
    with pytest.raises(ValueError, match=name):
        SamplerParams(**(base | kw))


def test_extra_frac_widens_only_the_outputs():
    """``extra_frac`` changes the output ports' formats, nothing of the memory or the blend's products, and the
    default leaves the ``repr`` (the build caches' key) as it was."""
    base = make((3, 5), 1)
    wide = base.replace(extra_frac=3)
    assert [p.fmt for p in wide.outputs] == [Fmt(True, 1, 12)] * 2
    assert [p.fmt for p in base.outputs] == [Fmt(True, 1, 9)] * 2
    assert wide.memories() == base.memories() and wide.products() == base.products()
    assert "extra_frac" not in repr(base) and "extra_frac=3" in repr(wide)
    s = np.array([[0, 0], [1 << 15, 1 << 14], [12345, 54321]])
    got, want = wide.compute(s), base.compute(s)
    assert np.all(np.abs(got - (want << 3)) <= 4)        # both half-up roundings of the same exact blend


def test_texels_compare_by_content():
    a = Texels(np.ones((1, 2, 2, 1)))
    assert a == Texels(np.ones((1, 2, 2, 1))) and a != Texels(np.zeros((1, 2, 2, 1)))
    assert hash(a) == hash(Texels(np.ones((1, 2, 2, 1)))) and "sha1=" in repr(a)
    with pytest.raises(ValueError, match="shape"):
        Texels(np.ones((2, 2)))


def test_border_faces_never_clamp_and_reach_the_border_texels():
    params = preset("sampler", "border")
    one = 1 << params.coord_fmt.frac_bits
    tex = params.texels.codes
    F = params.width
    assert F == tex.shape[2] - 2
    out = params.compute(np.array([[2, 0, 0], [2, one, one], [2, one // 2, one // 2]]))
    # s = t = 0 is halfway between the first texel and the border corner: the mean of four texels, rounded
    want = [exact_sample(params, 2, s, t)[0] for s, t in ((0, 0), (one, one), (one // 2, one // 2))]
    assert out.tolist() == want
    corner_sums = tex[2, 0:2, 0:2].reshape(4, 3).sum(0)
    assert out[0].tolist() == [math.floor(Fraction(int(c), 4) + Fraction(1, 2)) for c in corner_sums]


# -- trilinear (MIP mapping) ---------------------------------------------------------------------------------------
LOD = Fmt(True, 6, 8)


def make_trilinear(shape, seed, **kw):
    from fxmodel.units.sampler import mip_texels
    codes = Texels(np.random.default_rng(seed).integers(-512, 512, size=(1, *shape, 2)))
    return SamplerParams(texels=codes, channels=(Fmt(True, 1, 9),) * 2, filter="trilinear", mips=mip_texels(codes),
                         lod_fmt=LOD, **kw)


def exact_bilinear(params, tex, s, t):
    """Exact (Fraction) bilinear value of each channel of level ``tex`` (H, W, C) and its four corners."""
    T, B = params.coord_fmt.frac_bits, params.weight_bits

    def axis(code, size):
        v = Fraction(code, 1 << T)
        v = v - math.floor(v) if params.edge == "repeat" else min(max(v, Fraction(0)), Fraction(1))
        x = v * size - Fraction(1, 2)
        i0 = math.floor(x)
        f = Fraction(math.floor((x - i0) * (1 << B)), 1 << B)
        i1 = i0 + 1
        if params.edge == "repeat":
            return i0 % size, i1 % size, f
        return min(max(i0, 0), size - 1), min(max(i1, 0), size - 1), f

    i0, i1, fx = axis(s, tex.shape[1])
    j0, j1, fy = axis(t, tex.shape[0])
    vals, corners = [], []
    for k in range(tex.shape[2]):
        a, b, c, d = (Fraction(int(tex[j, i, k])) for j, i in ((j0, i0), (j0, i1), (j1, i0), (j1, i1)))
        vals.append((a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy)
        corners.append((a, b, c, d))
    return vals, corners


def exact_trilinear(params, s, t, lod):
    """The exact rule rounded half-up once per channel, each channel's eight texels, and the values before that
    rounding."""
    F, C, top = params.lod_fmt.frac_bits, params.level_bits, params.levels - 1
    lam = Fraction(lod, 1 << F)
    L = math.floor(lam)
    g = Fraction(math.floor((lam - L) * (1 << C)), 1 << C)
    if lam < 0 or L >= top:
        L, g = min(max(L, 0), top), Fraction(0)
    v0, c0 = exact_bilinear(params, params.level_codes(L)[0], s, t)
    v1, c1 = exact_bilinear(params, params.level_codes(min(L + 1, top))[0], s, t)
    exact = [a * (1 - g) + b * g for a, b in zip(v0, v1)]
    return [math.floor(x + Fraction(1, 2)) for x in exact], [a + b for a, b in zip(c0, c1)], exact


@given(st.integers(2, 12), st.integers(1, 12), st.integers(0, 2**31 - 1), st.sampled_from(["repeat", "clamp"]),
       st.integers(1, 8), st.integers(1, 8),
       st.lists(st.tuples(st.integers(-(1 << 19), (1 << 19) - 1), st.integers(-(1 << 19), (1 << 19) - 1),
                          st.integers(LOD.min_code, LOD.max_code)), min_size=1, max_size=12))
def test_trilinear_matches_exact_rule_within_its_eight_texels(h, w, seed, edge, wb, cb, rows):
    """Odd and even sizes down to the 1 x 1 level, any LOD code (magnified, between levels, past the last): the
    exact rule in Fractions, rounded half-up once, and within the range of the eight texels."""
    params = make_trilinear((h, w), seed, edge=edge, weight_bits=wb, level_bits=cb)
    out = params.compute(np.array(rows, dtype=np.int64))
    for (s, t, lod), got in zip(rows, out.tolist()):
        want, corners, _ = exact_trilinear(params, s, t, lod)
        assert got == want
        for k, cs in enumerate(corners):
            assert min(cs) <= got[k] <= max(cs)


@given(st.integers(2, 12), st.integers(1, 12), st.integers(0, 2**31 - 1), st.sampled_from(["repeat", "clamp"]),
       st.integers(1, 12), st.data(),
       st.lists(st.tuples(st.integers(-(1 << 19), (1 << 19) - 1), st.integers(-(1 << 19), (1 << 19) - 1),
                          st.integers(LOD.min_code, LOD.max_code)), min_size=1, max_size=12))
def test_trilinear_narrowed_blends_within_their_bound(h, w, seed, edge, wb, data, rows):
    """blend_frac = k: every output within 1/2 + 2**-k codes of the exact trilinear value (Fractions, the same
    weights) and within the range of its eight texels; with k = weight_bits, the row blends are not narrowed."""
    k = data.draw(st.integers(1, wb))
    params = make_trilinear((h, w), seed, edge=edge, weight_bits=wb, blend_frac=k)
    assert params.max_error_ulps == 0.5 + 2.0 ** -k
    bound = Fraction(1, 2) + Fraction(1, 2 ** k)
    for (s, t, lod), got in zip(rows, params.compute(np.array(rows, dtype=np.int64)).tolist()):
        _, corners, exact = exact_trilinear(params, s, t, lod)
        for c, cs in enumerate(corners):
            assert abs(got[c] - exact[c]) <= bound
            assert min(cs) <= got[c] <= max(cs)


def test_trilinear_narrowed_blends_move_the_result():
    """The narrowing is not idle: over many lookups with a coarse blend_frac some outputs differ from the exact
    blend's, none by more than one code."""
    exact = make_trilinear((16, 16), 3, weight_bits=12)
    coarse = exact.replace(blend_frac=1)
    rng = np.random.default_rng(5)
    rows = np.column_stack([rng.integers(-(1 << 19), 1 << 19, size=(4000, 2)),
                            rng.integers(-(1 << 8), 5 << 8, size=4000)])
    diff = coarse.compute(rows) - exact.compute(rows)
    assert np.count_nonzero(diff) > 0 and np.abs(diff).max() == 1


@pytest.mark.parametrize("shape", [(8, 8), (40, 40), (5, 12), (1, 2)])
def test_trilinear_is_bilinear_at_integer_lod_and_level_0_when_magnified(shape):
    """An integer LOD L gives bilinear at level L exactly (level boundaries included); any negative LOD gives
    level 0; LOD at or past the last level (1 x 1) gives its single texel."""
    params = make_trilinear(shape, 7)
    rng = np.random.default_rng(1)
    st_codes = rng.integers(-(1 << 17), 1 << 17, size=(300, 2))
    F = LOD.frac_bits
    for lv in range(params.levels):
        bil = SamplerParams(texels=Texels(params.level_codes(lv)), channels=params.channels, filter="bilinear",
                            coord_fmt=params.coord_fmt, weight_bits=params.weight_bits)
        got = params.compute(np.column_stack([st_codes, np.full(300, lv << F)]))
        assert np.array_equal(got, bil.compute(st_codes))
        if lv == 0:
            for lod in (-1, -(1 << F), LOD.min_code):
                assert np.array_equal(params.compute(np.column_stack([st_codes, np.full(300, lod)])), got)
    last = params.compute(np.column_stack([st_codes, np.full(300, LOD.max_code)]))
    assert params.level_sizes[-1] == (1, 1)
    assert (last == params.level_codes(params.levels - 1)[0, 0, 0]).all()


@given(st.integers(1, 10), st.integers(2, 10), st.integers(-(1 << 18), 1 << 18), st.integers(-(1 << 18), 1 << 18),
       st.integers(LOD.min_code, LOD.max_code), st.integers(-4, 4))
def test_trilinear_repeat_is_periodic(h, w, s, t, lod, k):
    params = make_trilinear((h, w), h * 31 + w)
    one = 1 << params.coord_fmt.frac_bits
    assert np.array_equal(params.compute(np.array([[s, t, lod]])),
                          params.compute(np.array([[s + k * one, t - k * one, lod]])))


def test_trilinear_levels_alternate_between_two_memories():
    """Levels L and L + 1 always sit in different memories (even, odd), each at its base address."""
    params = make_trilinear((40, 40), 2)
    assert [s[0] for s in params.level_sizes] == [40, 20, 10, 5, 2, 1]
    even, odd = params.parity_words
    assert len(even) == 40 * 40 + 10 * 10 + 2 * 2 and len(odd) == 20 * 20 + 5 * 5 + 1
    assert params.level_bases == (0, 0, 1600, 400, 1700, 425)
    assert [m.words for m in params.memories()] == [len(even), len(odd)]
    assert len(params.hard_cases()) and params.latency > 0


@pytest.mark.parametrize("kw, name", [
    (dict(lod_fmt=None), "lod_fmt"), (dict(lod_fmt=Fmt(False, 6, 8)), "lod_fmt"), (dict(level_bits=9), "level_bits"),
    (dict(mips=(Texels(np.zeros((1, 2, 2, 2), np.int64)),)), "mips"), (dict(mips=()), "mips"),
    (dict(edge="border"), "filter"), (dict(blend_frac=9), "blend_frac"), (dict(blend_frac=-1), "blend_frac")])
def test_trilinear_bad_parameters_name_the_parameter(kw, name):
    base = make_trilinear((6, 6), 1)
    with pytest.raises(ValueError, match=name):
        base.replace(**kw)


def test_mips_only_for_trilinear():
    with pytest.raises(ValueError, match="mips"):
        make((4, 4), 1, lod_fmt=LOD)
    with pytest.raises(ValueError, match="blend_frac"):
        make((4, 4), 1, blend_frac=2)
