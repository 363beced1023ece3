"""Triangle set-up, scan conversion and interpolators (fxmodel/units/raster.py) against the float front end's coverage
and against exact rational plane equations."""

import json
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.units.raster import RasterParams, scan, setup
from host import frontend
from host.scene import load_scene

P = RasterParams.PRESETS["default"]
S = P.S


def exact_value(X, Y, v, x, y) -> Fraction:
    """The plane through the three vertex values ``v`` at pixel centre ``(x, y)``: barycentrics from the vertex
    coordinates (determinants), independent of the edge set-up under test."""
    px, py = Fraction((2 * x + 1) * S, 2), Fraction((2 * y + 1) * S, 2)

    def cross(i, j):                           # twice the area of (vertex i, vertex j, p)
        return (X[i] - px) * (Y[j] - py) - (X[j] - px) * (Y[i] - py)

    total = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0])
    lam = [cross(1, 2), cross(2, 0), cross(0, 1)]
    return sum(Fraction(lam[e]) * Fraction(float(v[e])) for e in range(3)) / total


def check_triangle(params, X, Y, values, width, height, sample=300, rng=None):
    """Coverage == the front end's; every sampled fragment within the documented bounds of the exact plane."""
    X, Y = np.asarray(X, np.int64), np.asarray(Y, np.int64)
    recs = setup(params, X[None], Y[None], {n: np.asarray(v, float)[None] for n, v in values.items()}, width,
                 height)
    res = scan(params, recs)
    px, py, _, _ = frontend.scan_triangle(X, Y, width, height)
    got = np.sort(res.codes["y"] * width + res.codes["x"])
    assert np.array_equal(got, np.sort(py * width + px)), "coverage differs from the front end"
    assert not np.any(np.diff(got) == 0)
    if not len(res):
        return res, 0.0
    # the clock count: one per covered pixel, one per empty row
    assert res.clocks.sum() >= len(res)
    rec = {k: int(v[0]) for k, v in recs.codes.items()}
    nx, ny = res.codes["x"] - rec["x0"], res.codes["y"] - rec["y0"]
    rng = rng or np.random.default_rng(0)
    pick = np.unique(np.concatenate([np.argsort(nx + ny)[-20:], np.argsort(nx + ny)[:5],
                                     rng.integers(0, len(res), min(sample, len(res)))]))
    worst = 0.0
    for name, v in values.items():
        out, acc = params.out_fmt(name), params.acc_fmt(name)
        bound = params.error_bound(name)
        for k in pick:
            x, y = int(res.codes["x"][k]), int(res.codes["y"][k])
            ex = exact_value(X.tolist(), Y.tolist(), v, x, y)
            err_acc = abs(Fraction(int(res.acc[name][k])) * acc.ulp - ex)
            assert err_acc <= params.accumulated_bound(name, int(nx[k]), int(ny[k])), (name, x, y)
            err = abs(Fraction(int(res.codes[name][k])) * out.ulp - ex)
            assert err <= bound, (name, x, y, float(err / out.ulp))
            worst = max(worst, float(err_acc / out.ulp))
    return res, worst


coord = st.integers(-40 * S, 72 * S)
on_grid = st.integers(-4, 70).map(lambda i: i * S // 2)          # pixel centres and pixel edges


@st.composite
def triangles(draw, width=64, height=48):
    kind = draw(st.sampled_from(["random", "grid", "sliver", "tiny", "long"]))
    if kind == "grid":
        X = [draw(on_grid) for _ in range(3)]
        Y = [draw(on_grid) for _ in range(3)]
    elif kind == "tiny":
        x, y = draw(st.integers(0, width * S)), draw(st.integers(0, height * S))
        X = [x + draw(st.integers(-S, S)) for _ in range(3)]
        Y = [y + draw(st.integers(-S, S)) for _ in range(3)]
    elif kind == "sliver":
        x0, y0, x1, y1 = (draw(coord) for _ in range(4))
        X = [x0, x1, x1 + draw(st.integers(-2, 2))]
        Y = [y0, y1, y1 + draw(st.integers(-2, 2))]
    elif kind == "long":
        X = [-3 * S, (width + 3) * S, draw(coord)]
        Y = [draw(st.integers(0, height * S)), draw(st.integers(0, height * S)), draw(coord)]
    else:
        X = [draw(coord) for _ in range(3)]
        Y = [draw(coord) for _ in range(3)]
    return X, Y


small = RasterParams.PRESETS["small"]


def attr_values(draw, params, low_w=False):
    vals = {}
    for name, fmt in params.attrs:
        lim = float(fmt.max_value) * 0.99
        vals[name] = [draw(st.floats(-lim, lim, allow_nan=False)) for _ in range(3)]
    if low_w and "W" in vals:
        ulp = float(params.out_fmt("W").ulp)
        vals["W"] = [draw(st.floats(ulp, 8 * ulp)) for _ in range(3)]
    return vals


@given(triangles(), st.data())
def test_coverage_and_interpolation_on_random_triangles(tri, data):
    X, Y = tri
    vals = attr_values(data.draw, P, low_w=data.draw(st.booleans()))
    vals = {n: vals[n] for n in ("U", "W", "Nx", "A21")}
    params = RasterParams(attrs=tuple((n, P.out_fmt(n)) for n in vals))
    check_triangle(params, X, Y, vals, 64, 48, sample=40)


def test_spans_of_2048_pixels_stay_within_the_bound():
    """A triangle across the whole 2048 x 2048 viewport: the most additions of each increment the preset allows."""
    rng = np.random.default_rng(3)
    X = [-S // 2, 2048 * S + 37, -3]
    Y = [-5, 13, 2048 * S + 101]
    names = ("U", "W", "Nx", "Ex", "A00", "Z")
    params = RasterParams(attrs=tuple((n, P.out_fmt(n)) for n in names))
    vals = {n: rng.uniform(-0.9, 0.9, 3) * float(params.out_fmt(n).max_value) for n in names}
    vals["W"] = np.array([1.0, 2.0 ** -18, 0.5])
    res, worst = check_triangle(params, X, Y, vals, 2048, 2048, sample=200, rng=rng)
    assert len(res) > 2_000_000 and (res.codes["x"].max(), res.codes["y"].max()) == (2047, 2047)


def test_pixel_centres_on_edges_and_shared_edges_cover_once():
    """A jittered grid mesh with vertices on pixel centres and pixel edges: each pixel of the union exactly once."""
    rng = np.random.default_rng(7)
    n, step = 9, 8
    gx, gy = np.meshgrid(np.arange(n + 1) * step * S, np.arange(n + 1) * step * S)
    jit = rng.integers(-6, 7, gx.shape) * (S // 2)
    gx, gy = gx + jit, gy + rng.integers(-6, 7, gy.shape) * (S // 2)
    Xs, Ys = [], []
    for i in range(n):
        for j in range(n):
            a, b, c, d = (i, j), (i, j + 1), (i + 1, j + 1), (i + 1, j)
            for t in ((a, b, c), (a, c, d)):
                Xs.append([gx[v] for v in t])
                Ys.append([gy[v] for v in t])
    vals = {"U": np.zeros((len(Xs), 3)), "W": np.ones((len(Xs), 3))}
    recs = setup(small, np.array(Xs), np.array(Ys), vals, 64, 64)
    res = scan(small, recs)
    hits = np.zeros((64, 64), int)
    np.add.at(hits, (res.codes["y"], res.codes["x"]), 1)
    assert hits.max() == 1
    union = np.zeros((64, 64), bool)
    for X, Y in zip(Xs, Ys):
        px, py, _, _ = frontend.scan_triangle(X, Y, 64, 64)
        union[py, px] = True
    assert np.array_equal(hits == 1, union) and union.sum() > 3000


@pytest.mark.parametrize("X, Y, pixels", [
    ([S // 2, S // 2 + S, S // 2], [S // 2, S // 2, S // 2 + S], 1),      # a right triangle on pixel centres
    ([10, 20, 15], [10, 10, 30], 0),                                       # inside one pixel, misses its centre
    ([S // 2, S // 2 + 1, S // 2], [S // 2, S // 2, S // 2 + 1], 1),      # a tiny triangle at a centre (top-left)
    ([S // 2 + 1, S // 2, S // 2 + 1], [S // 2, S // 2 + 1, S // 2 + 1], 0),  # its mirror: bottom-right edge
])
def test_tiny_triangles(X, Y, pixels):
    vals = {"U": [0.5, 0.25, -1.0], "W": [1.0, 0.5, 0.25]}
    res, _ = check_triangle(small, X, Y, vals, 16, 16)
    assert len(res) == pixels


def test_shipped_scenes_match_the_front_end_and_take_about_a_clock_per_pixel():
    for name in ("tin-plane", "berlin-wall", "sphere"):
        scene = load_scene(f"scenes/{name}.toml")
        recs, tri, _ = frontend.triangle_records(scene, P)
        res = scan(P, recs)
        fr = frontend.rasterize(scene)
        got = list(zip(res.codes["x"].tolist(), res.codes["y"].tolist(), tri[res.record].tolist()))
        assert len(got) == len(set(got)) == len(fr)
        assert set(got) == set(zip(fr.x.tolist(), fr.y.tolist(), fr.tri.tolist())), name
        assert res.clocks.sum() <= 1.25 * len(res), name
        assert not res.codes["flags"].any()


def test_default_formats_are_the_pipeline_inputs():
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS
    units = BUILTIN_PRESET_UNITS["default"]
    assert RasterParams.for_pipeline(units).attrs == P.attrs
    assert P.subpixel_bits == frontend.SUBPIXEL_BITS and P.guard_pixels == frontend.GUARD_PIXELS
    assert P.max_size >= 2048 and P.guard_bits == 13


@pytest.mark.parametrize("change, message", [
    (dict(max_size=1), "max_size=1"), (dict(subpixel_bits=0), "subpixel_bits=0"),
    (dict(attrs=(("U", Fmt(False, 4, 4)),)), "attrs="), (dict(attrs=()), "attrs=()"),
    (dict(extra_guard=-1), "extra_guard=-1"), (dict(attrs=(("U", Fmt(True, 30, 40)),)), "too wide"),
])
def test_bad_parameters_are_named(change, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        RasterParams(**{"attrs": small.attrs, **change})


def test_a_vertex_value_outside_its_format_is_refused_naming_the_triangle():
    X, Y = np.array([[0, 5 * S, 0], [0, 0, 0]]), np.array([[0, 0, 5 * S], [0, 0, 0]])
    vals = {"U": np.array([[0.0, 9.0, 0.0], [0, 0, 0]]), "W": np.ones((2, 3))}
    with pytest.raises(ValueError, match="triangle 0: attribute U .* outside its format s4.12"):
        setup(small, X, Y, vals, 16, 16)
    with pytest.raises(ValueError, match="viewport"):
        setup(small, X, Y, vals, 300, 16)


def test_slopes_are_the_exact_steps_rounded_once_and_refused_outside_their_format():
    """``slopes`` (MIP mapping's increments): the exact plane's step, rounded half-up, carried by every fragment;
    a step outside its format refused naming the triangle; no slopes, the ``repr`` of before (caches keyed by it)."""
    import dataclasses
    assert "slopes" not in repr(small)
    fine, coarse = Fmt(True, 4, 20), Fmt(True, 1, 6)
    X, Y = np.array([[0, 5 * S, 0]]), np.array([[0, 0, 4 * S]])
    vals = {"U": np.array([[0.0, 3.0, 1.0]]), "W": np.ones((1, 3))}
    p = dataclasses.replace(small, slopes=(("Ux", "U", "x", fine), ("Uy", "U", "y", fine)))
    assert "slopes" in repr(p) and p.record[-len(p.names) * 3 - 2].name == "Ux"
    recs = setup(p, X, Y, vals, 16, 16)
    # U = 3 x / 5 + y / 4 in pixels: steps 0.6 and 0.25, rounded half-up at 20 fraction bits
    assert recs.codes["Ux"][0] == int(Fraction(3, 5) * (1 << 20) + Fraction(1, 2)) and \
        recs.codes["Uy"][0] == 1 << 18
    frags = scan(p, recs)
    assert len(frags) == 10 and (frags.codes["Ux"] == recs.codes["Ux"][0]).all()
    with pytest.raises(ValueError, match="triangle 0: Wy = dW/dy"):
        setup(dataclasses.replace(small, slopes=(("Wy", "W", "y", coarse),)), X, np.array([[0, 0, S]]),
              {"U": vals["U"], "W": np.array([[0.1, 0.1, 1.9]])}, 16, 16)          # dW/dy = 1.8, above 1
    with pytest.raises(ValueError, match="slopes"):
        dataclasses.replace(small, slopes=(("Ux", "Q", "x", fine),))


def test_cli_info_prints_the_formats(capsys):
    from tools.main import main
    assert main(["info", "raster"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["params"]["guard_bits"] == 13
    assert info["attributes"]["U"] == {"out": "s6.20", "start_and_increments": "s7.33",
                                       "max_error_out_ulp": pytest.approx(0.5 + 4095 / 2 ** 14)}


def test_measured_error_stays_within_the_proof_on_full_viewport_spans():
    from fxmodel.units.raster_errors import measure
    rep = measure(small, triangles=2, seed=4)
    assert rep["fragments"] > 40_000
    assert rep["accumulator_worst_ulp"] <= rep["accumulator_bound_ulp"]
    assert rep["output_worst_ulp"] <= rep["output_bound_ulp"]


@pytest.mark.parametrize("name", ["tin-plane", "berlin-wall", "sphere"])
def test_shipped_scenes_from_triangles_within_one_lsb_of_reference_a(name):
    from host.render import from_triangles, prepare, render_triangles
    tframe = from_triangles(prepare(f"scenes/{name}.toml", size=64, cube_size=16))
    report = render_triangles(tframe)
    assert report["input"] == "triangles" and report["fragments"] == len(tframe.frame.frags) > 1000
    assert report["triangles_vs_fragments"]["max_lsb_vs_float"] <= 1
    assert report["clocks_per_fragment"] <= 1.25 and report["raster_saturated"] == 0


def test_grazing_floor_with_mip_mapping_draws_from_triangles():
    """MIP mapping from triangles: the scan converter hands the LOD unit its triangle's increments (``slopes``),
    which are the steps of the very planes it interpolates: ``Uc(x, y + 1) - Uc(x, y)`` on every vertical pair of a
    triangle's fragments, and the same along x for ``W``."""
    from host.render import from_triangles, prepare, render_triangles
    tframe = from_triangles(prepare("scenes/grazing-floor.toml", preset="grazing-floor-mip", cube_size=16))
    P = tframe.params
    assert P.pipeline.lod is not None and [n for n, *_ in P.raster.slopes] == ["Ucx", "Ucy", "Vcx", "Vcy", "Wx", "Wy"]
    res = tframe.scan
    c = res.codes
    at = {(int(r), int(x), int(y)): i for i, (r, x, y) in enumerate(zip(res.record, c["x"], c["y"]))}
    pairs = 0
    for attr, slope, dx, dy in (("Uc", "Ucy", 0, 1), ("Vc", "Vcy", 0, 1), ("W", "Wx", 1, 0)):
        fo, fs = P.raster.out_fmt(attr).frac_bits, dict(P.raster.carried)[slope].frac_bits
        for i in range(0, len(res), 7):
            j = at.get((int(res.record[i]), int(c["x"][i]) + dx, int(c["y"][i]) + dy))
            if j is not None:
                step = Fraction(int(c[attr][j] - c[attr][i]), 1 << fo)
                assert abs(step - Fraction(int(c[slope][i]), 1 << fs)) <= Fraction(1, 1 << fo), (attr, i)
                pairs += 1
    assert pairs > 1000
    report = render_triangles(tframe)
    assert report["input"] == "triangles" and report["raster_saturated"] == 0


def test_engine_parameters_check_the_formats():
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.pipeline.pixel import PipelineParams
    pipe = PipelineParams.PRESETS["default"]
    with pytest.raises(ValueError, match=r"raster.attrs\['U'\]"):
        EngineParams(raster=small, pipeline=pipe)
    ok = EngineParams(raster=RasterParams.for_pipeline(
        {"persp": pipe.persp, "bump": pipe.bump, "reflect": pipe.reflect}), pipeline=pipe)
    assert [p.name for p in ok.outputs] == ["x", "y", "r", "g", "b", "flags"]


@pytest.mark.parametrize("scene", ["steep-bumps", "steep-sphere"])
def test_steep_bump_maps_draw_from_triangles_with_the_block_exponent(scene):
    """``A`` beyond ``bump.a_fmt``: the set-up refuses the triangles with ``e`` held at 0 (``A W`` does not fit);
    with the per-triangle block exponent (the record's constant ``Ae``, the fragment path's ``e`` per scene
    triangle) every fragment of a triangle carries it, and the frame from triangles is within 1 LSB of (a)."""
    from host.render import from_triangles, prepare, render_triangles
    frame = prepare(f"tests/scenes/{scene}.toml", size=48, cube_size=8)
    tframe = from_triangles(frame)
    raster = tframe.params.raster
    assert ("Ae", frame.params.bump.e_fmt) in raster.consts
    with pytest.raises(ValueError, match=r"attribute A\d\d .* outside its format"):
        frontend.triangle_records(frame.scene, raster, [frame.maps])
    recs, tri, _ = frontend.triangle_records(frame.scene, raster, [frame.maps], frame.exponent)
    assert np.array_equal(recs.codes["Ae"], frame.exponent[tri])          # the fragment path's e per scene triangle
    e = tframe.records.codes["Ae"]
    assert e.min() >= 1
    assert np.array_equal(tframe.scan.codes["Ae"], e[tframe.scan.record])
    report = render_triangles(tframe)
    assert report["max_lsb_vs_float_well_conditioned"] <= 1 and report["raster_saturated"] == 0
    assert report["triangles_vs_fragments"]["max_lsb_vs_fragments"] <= 1


@settings(max_examples=40, deadline=None)
@given(triangles(), st.data(), st.integers(11, 40), st.integers(9, 30))
def test_a_tile_of_the_picture_covers_its_pixels_and_holds_the_bound(tri, data, tw, th):
    """A picture drawn a tile at a time (``setup`` with ``origin`` and ``picture``, as the board with its frame in
    SDRAM): each tile's records cover exactly the picture's covered pixels inside the tile, moved to the tile's
    coordinates (so the tiles together cover each pixel once, none past the picture's edge where the last tiles
    reach beyond it), and every attribute of every fragment stays within
    the interpolators' bound of the exact plane at its picture coordinates."""
    X, Y = (np.asarray(v, np.int64) for v in tri)
    vals = attr_values(data.draw, P)
    vals = {n: vals[n] for n in ("U", "Nx")}
    params = RasterParams(attrs=tuple((n, P.out_fmt(n)) for n in vals))
    width, height = 64, 48
    px, py, _, _ = frontend.scan_triangle(X, Y, width, height)
    whole = set(zip(px.tolist(), py.tolist()))
    covered = []
    for oy in range(0, height, th):
        for ox in range(0, width, tw):
            recs = setup(params, X[None], Y[None], {n: np.asarray(v, float)[None] for n, v in vals.items()}, tw, th,
                         origin=(ox, oy), picture=(width, height))
            res = scan(params, recs)
            got = list(zip((res.codes["x"] + ox).tolist(), (res.codes["y"] + oy).tolist()))
            assert set(got) == {(x, y) for x, y in whole if ox <= x < ox + tw and oy <= y < oy + th}
            covered += got
            for k in range(0, len(res), max(1, len(res) // 8)):
                x, y = int(res.codes["x"][k]) + ox, int(res.codes["y"][k]) + oy
                for name, v in vals.items():
                    err = abs(Fraction(int(res.codes[name][k])) * params.out_fmt(name).ulp
                              - exact_value(X.tolist(), Y.tolist(), v, x, y))
                    assert err <= params.error_bound(name), (name, x, y)
    assert sorted(covered) == sorted(whole)                          # every pixel once


def test_a_tile_needs_its_picture_and_a_place_in_it():
    X, Y = np.array([[0, 8 * S, 0]]), np.array([[0, 0, 8 * S]])
    vals = {n: np.zeros((1, 3)) for n in small.names}
    with pytest.raises(ValueError, match="origin"):
        setup(small, X, Y, vals, 4, 4, origin=(4, 0))
    with pytest.raises(ValueError, match="origin"):
        setup(small, X, Y, vals, 4, 4, origin=(16, 0), picture=(16, 16))
    with pytest.raises(ValueError, match="picture"):
        setup(small, X, Y, vals, 4, 4, origin=(0, 0), picture=(small.max_size + 1, 16))
