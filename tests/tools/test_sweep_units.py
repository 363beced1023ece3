"""Unit-width and pipeline points of the design-space sweep (``tools/sweep_units.py``): a tiny grid, no FPGA flow.

Errors are checked against exact rational math written here (``Fraction``), not against the sweep's own code.
"""

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.units.exact import bump_error, wrapped_error
from tools import sweep as sw
from tools import sweep_units as su
from tools.main import main as bumpmap

SAMPLES = 3000


def _family(unit, family):
    return [g for g in su.default_unit_grid() if g[2].NAME == unit and g[1] == family]


# per unit: the small preset, the narrowest and the widest point of the main family
GRID = [("persp preset small", "preset", preset("persp", "small")),
        ("cube preset small", "preset", preset("cube", "small")),
        ("reflect preset small", "preset", preset("reflect", "small")),
        ("bump preset small", "preset", preset("bump", "small"))]
for _unit, _fam in (("persp", "p, t=4"), ("cube", "p, t=3"), ("reflect", "word"), ("bump", "out")):
    _pts = _family(_unit, _fam)
    GRID += [_pts[0], _pts[-1]]
PIPE = [("default", "default"), ("word 12", {"word": 12})]


@pytest.fixture(scope="module")
def result():
    return sw.sweep(GRID, pipeline=PIPE, scene_size=32, unit_samples=SAMPLES, progress=False)


def _bound(P) -> Fraction:
    """The documented bound of each unit, in its error's units."""
    return {"persp": lambda: P.error_bound(Fraction(su.S_ABS)), "cube": lambda: P.st_bound,
            "reflect": lambda: Fraction(P.direction_bound), "bump": lambda: P.max_error}[P.NAME]()


def test_unit_records_fields_and_consistency(result):
    recs = result["points"]
    assert [r["name"] for r in recs] == [g[0] for g in GRID]
    for r, (_, _, P) in zip(recs, GRID):
        assert r["unit"] == P.NAME and r["latency"] == P.latency and r["fpga"] is None
        table = {"persp": lambda P=P: P.recip.table_bits, "cube": lambda P=P: P.divide.recip.table_bits}.get(P.NAME)
        assert r["table_bits"] == (table() if table else 0)
        assert r["cost"] == r["table_bits"] + 1024 * r["dsp_blocks_est"]
        assert r["dsp_blocks_est"] == P.cost()["dsp"] and r["multipliers"] == P.cost()["multipliers"]
        assert r["within_bound"] and 0 < r["mean"] <= r["worst"] <= float(_bound(P)) * (1 + 1e-12)
        assert r["bound"] == pytest.approx(float(_bound(P)), rel=1e-12)
        assert r["correct_bits_worst"] == pytest.approx(-math.log2(r["worst"]), abs=1e-3)
        assert r["correct_bits_worst"] <= r["correct_bits_mean"]
        assert r["worst_ulp"] == pytest.approx(r["worst"] / r["ulp"]) and r["model_per_second"] > 0
        hard = len(P.hard_cases())
        if P.NAME == "bump":                        # twice the samples drawn; only unsaturated rows measured
            assert r["drawn"] == 2 * SAMPLES + hard and 0 < r["vectors"] < r["drawn"]
        else:                                       # persp: every random row is inside |U/W| <= 16
            assert r["drawn"] == SAMPLES + hard and r["vectors"] >= SAMPLES
    for unit, names in result["pareto"].items():
        assert names and all(n.startswith(unit) for n in names)


def test_narrower_is_measurably_worse(result):
    """In each family the narrowest point's measured worst error exceeds the widest point's documented bound."""
    recs = {r["name"]: r for r in result["points"]}
    for k in range(4, len(GRID), 2):
        narrow, wide = recs[GRID[k][0]], recs[GRID[k + 1][0]]
        assert narrow["worst"] > wide["bound"] and narrow["correct_bits_worst"] < wide["correct_bits_worst"]


@pytest.mark.parametrize("unit, family, width", [
    ("persp", "p, t=4", lambda P: P.recip.p), ("persp", "p, t=3", lambda P: P.recip.p),
    ("persp", "c", lambda P: P.coord_bits), ("cube", "p, t=3", lambda P: P.divide.recip.p),
    ("cube", "p, t=2", lambda P: P.divide.recip.p), ("reflect", "word", lambda P: P.r_bits),
    ("bump", "out", lambda P: P.out_fmt.frac_bits)])
def test_narrower_never_has_a_smaller_documented_bound(unit, family, width):
    pts = sorted((g[2] for g in _family(unit, family)), key=width)
    assert len(pts) >= 2
    for a, b in zip(pts, pts[1:]):
        assert width(a) < width(b) and _bound(a) >= _bound(b)


def test_persp_inputs_stay_in_the_measured_domain():
    P = preset("persp")
    x, exhaustive = su.unit_inputs(P, 20000, np.random.default_rng(3))
    rnd = x[:20000]
    uf, wf = P.uv_fmt.frac_bits, P.recip.in_fmt.frac_bits
    assert not exhaustive and np.all(rnd[:, 2] != 0)
    for j in (0, 1):
        assert all(abs(Fraction(int(u), 1 << uf) / Fraction(int(w), 1 << wf)) <= su.S_ABS
                   for u, w in zip(rnd[:300, j], rnd[:300, 2]))
        assert np.all(np.abs(rnd[:, j]) * (1 << wf) <= su.S_ABS * np.abs(rnd[:, 2]) * (1 << uf))
    assert np.abs(rnd[:, 0]).max() > P.uv_fmt.max_code // 4      # the whole domain is drawn, not a corner


def _wrapped(a: Fraction, b: Fraction) -> Fraction:
    d = (a - b) - math.floor(a - b)
    return min(d, 1 - d)


@pytest.mark.parametrize("name", ["default", "small"])
def test_wrapped_error_against_fractions(name):
    P = preset("persp", name)
    rng = np.random.default_rng(7)
    rows = np.concatenate([P.hard_cases(), P.random_inputs(rng, 300)])
    out = P.compute(rows)
    uf, wf, c = P.uv_fmt, P.recip.in_fmt, P.coord_bits
    num, den = wrapped_error(rows[:, 0], rows[:, 2], out[:, 0], uf.frac_bits, wf.frac_bits, c)
    for (u, _, w), n, d, s in zip(rows.tolist(), num, den, out[:, 0].tolist()):
        want = Fraction(0) if w == 0 else _wrapped(Fraction(s, 1 << c), uf.to_fraction(u) / wf.to_fraction(w))
        assert Fraction(int(n), int(d)) == want


def test_measure_persp_worst_is_the_exact_worst():
    from fxmodel.units.exact import measure_persp
    P = preset("persp", "small")
    rows = np.concatenate([P.hard_cases(), su.unit_inputs(P, 400, np.random.default_rng(2))[0]])
    out = P.compute(rows)
    m = measure_persp(P, rows, out)
    worst, kept = Fraction(0), 0
    for row, res in zip(rows.tolist(), out.tolist()):
        u, v, w = row
        if w == 0 or any(abs(P.uv_fmt.to_fraction(n) / P.recip.in_fmt.to_fraction(w)) > su.S_ABS for n in (u, v)):
            continue
        kept += 1
        for n, s in ((u, res[0]), (v, res[1])):
            exact = P.uv_fmt.to_fraction(n) / P.recip.in_fmt.to_fraction(w)
            worst = max(worst, _wrapped(Fraction(s, 1 << P.coord_bits), exact))
    assert m["vectors"] == kept and m["max_error"] == float(worst) and m["within_bound"]


def test_bump_error_against_fractions():
    P = preset("bump").replace(out_fmt=Fmt(True, 2, 9))
    rows = np.concatenate([P.hard_cases(), P.random_inputs(np.random.default_rng(4), 300)])
    out = P.compute(rows)
    num, den = bump_error(rows[:, 0:3], rows[:, 3], rows[:, 4], rows[:, 5:8], rows[:, 8:11], out[:, :3],
                          P.n_fmt.frac_bits, P.d_fmt.frac_bits, P.a_fmt.frac_bits, P.out_fmt.frac_bits, rows[:, 11])
    n, d, a, o = P.n_fmt, P.d_fmt, P.a_fmt, P.out_fmt
    for row, res, nums in zip(rows.tolist(), out.tolist(), num.tolist()):
        for i in range(3):
            want = (n.to_fraction(row[i]) / 2 ** row[11] + d.to_fraction(row[3]) * a.to_fraction(row[5 + i])
                    + d.to_fraction(row[4]) * a.to_fraction(row[8 + i]))
            assert Fraction(int(nums[i]), den) == abs(o.to_fraction(res[i]) - want)
            if not res[3]:
                assert abs(o.to_fraction(res[i]) - want) <= o.ulp / 2


def test_dsp_estimate_matches_the_placed_presets():
    """Estimated MULT18X18D blocks of every unit preset against the ECP5 counts of ``make fpga``."""
    placed = {("persp", "default"): 22, ("persp", "small"): 5, ("persp", "color"): 30, ("cube", "default"): 5,
              ("cube", "small"): 5, ("reflect", "default"): 18, ("reflect", "small"): 18, ("bump", "default"): 6,
              ("bump", "small"): 6}
    for (unit, name), dsp in placed.items():
        assert preset(unit, name).cost()["dsp"] == dsp, (unit, name)


def test_pipeline_points(result):
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS
    from tools.fit import knobs_of, units_of

    pipe = result["pipeline"]
    base, narrow = pipe["points"]
    assert [p["name"] for p in pipe["points"]] == ["default", "word 12"]
    default = BUILTIN_PRESET_UNITS["default"]
    assert base["preset"] == "default" and base["changes"] == {}
    assert narrow["preset"] is None and narrow["changes"] == {"word": [knobs_of(default)["word"], 12]}
    for p in (base, narrow):
        assert p["width"] == p["height"] == 32 and p["pixels"] > 0 and p["cube_size"] == 64
        assert p["cost"] == p["hardware"]["table_bits"] + 1024 * p["hardware"]["dsp"]
        # MSE <= max_lsb**2, so PSNR >= 20 log10(255 / max_lsb); identical frames have infinite PSNR
        for ref in ("float", "ideal"):
            lsb, db = p[f"max_lsb_vs_{ref}"], p[f"psnr_db_vs_{ref}"]
            assert (db == math.inf) if lsb == 0 else db >= 20 * math.log10(255 / lsb) - 0.01
    assert base["hardware"]["table_bits"] == (default["persp"].recip.table_bits       # two cube units: two tables
                                              + 2 * default["cube"].divide.recip.table_bits)
    units = units_of({**knobs_of(default), "word": 12}, default)
    assert base["hardware"]["dsp"] == preset("pipeline").cost()["dsp"]
    # 18 -> 12 bits: every one of those products still takes one block (narrower, not fewer)
    assert narrow["hardware"]["multiplier_bit_products"] < base["hardware"]["multiplier_bit_products"]
    narrowed = sum(units[k].cost()["dsp"] - default[k].cost()["dsp"] for k in ("bump", "reflect"))
    narrowed += 2 * (units["cube"].cost()["dsp"] - default["cube"].cost()["dsp"])
    assert narrow["hardware"]["dsp"] - base["hardware"]["dsp"] == narrowed      # only those units changed
    assert set(pipe["pareto"]) <= {"default", "word 12"} and pipe["pareto"]


def test_outputs(result, tmp_path):
    paths = sw.write_outputs(result, tmp_path)
    data = json.loads((tmp_path / "speed_vs_error.json").read_text())
    assert data["pareto"] == result["pareto"] and len(data["points"]) == len(GRID)
    assert [p["name"] for p in data["pipeline"]["points"]] == ["default", "word 12"]
    md = (tmp_path / "speed_vs_error.md").read_text()
    for section in ("## persp", "## cube", "## reflect", "## bump", "## Pipeline"):
        assert section in md
    assert all(g[0] in md for g in GRID) and "word 12" in md
    assert not (tmp_path / "pareto.png").exists()              # no reciprocal points in this grid
    assert (tmp_path / "units.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and len(paths) == 3


def test_bad_arguments():
    assert bumpmap(["sweep", "--unit-fpga-points", "4"]) == 2
    assert bumpmap(["sweep", "--unit-samples", "0"]) == 2


def test_raster_guard_points_measure_the_interpolators_against_their_bound():
    """The scan converter's sweep points: the worst output error over full-viewport triangles within the proof's
    bound, which shrinks with each guard bit, at the cost model's multiplier count."""
    import dataclasses

    from fxmodel.units.raster import RasterParams
    from tools.sweep_units import measure_raster_point
    small = RasterParams.PRESETS["small"]
    recs = [measure_raster_point(f"g{g}", "guard", dataclasses.replace(small, extra_guard=g), triangles=1)
            for g in (0, 2)]
    assert all(r["within_bound"] and r["worst_ulp"] <= r["bound_ulp"] for r in recs)
    assert recs[1]["bound_ulp"] < recs[0]["bound_ulp"] and recs[0]["vectors"] > 30_000
    assert recs[0]["dsp_blocks_est"] == small.cost()["dsp"] > 0 and recs[0]["unit"] == "raster"


def test_a_preset_that_cannot_draw_the_scene_is_a_refused_point_never_on_the_front():
    """``persp p16 c14`` cannot resolve the tin plane's bump-map addresses (``prepare`` refuses it): the sweep
    records the refusal and the clamped frame's error instead of failing, and keeps the point off the front even
    though it is cheaper than ``default`` at the same largest error."""
    from host.render import ClampError, prepare
    from host.scene import load_scene

    spec = {"coord_bits": 14, "persp_p": 16, "persp_b": 17}
    (name, units, _), = su.pipeline_grid([("persp p16 c14", spec)])
    with pytest.raises(ClampError):
        prepare(load_scene(su.SCENE).with_size(32, 32), preset=units)
    res = sw.sweep([], pipeline=[("default", "default"), (name, spec)], scene_size=32, progress=False)
    base, refused = res["pipeline"]["points"]
    assert base["refused"] is None and "U, V" in refused["refused"] and "texel" in refused["refused"]
    assert refused["cost"] < base["cost"] and refused["max_lsb_vs_float"] <= base["max_lsb_vs_float"]
    assert res["pipeline"]["pareto"] == ["default"] and not refused["pareto"]
    assert "**refused**" in sw.markdown(res)
