"""The design-space sweep (``tools/sweep.py``) on a tiny grid: 16-bit inputs, three points, no FPGA flow."""

import json
import math

import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.units.recip import RecipParams
from tools import sweep as sw
from tools.main import main as bumpmap

IN16 = Fmt(True, 4, 12)
GRID = [
    ("cheap", "test", sw.faithful_p(5, 2, "round", p_max=14, in_fmt=IN16)),      # p = 7 by the bound
    ("sloppy", "test", RecipParams(in_fmt=IN16, m=4, b=12, t=2, p=12, guard=0, center=False)),
    ("mid", "test", RecipParams(in_fmt=IN16, m=6, b=15, t=3, p=12, guard=4, table="midpoint")),
]


@pytest.fixture(scope="module")
def result():
    return sw.sweep(GRID, progress=False)


def test_fields_and_errors(result):
    assert [r["name"] for r in result["points"]] == [g[0] for g in GRID]
    for r, (_, _, P) in zip(result["points"], GRID):
        assert r["exhaustive"] and r["vectors"] == 1 << 16
        assert r["table_bits"] == P.table_bits and r["multipliers"] == P.multipliers and r["latency"] == P.latency
        assert r["worst_ulp"] >= r["mean_ulp"] > 0
        assert r["within_bound"]                                  # exact comparison in measure_point
        assert r["worst_ulp"] <= float(P.error_bound_ulp) * (1 + 1e-12)
        assert r["correct_bits_worst"] == pytest.approx(P.p - 1 - math.log2(r["worst_ulp"]), abs=1e-3)
        assert r["correct_bits_worst"] <= r["correct_bits_mean"]
        assert r["model_per_second"] > 0 and r["fpga"] is None
    # faithful by the bound (cheap, mid) means faithful on every input; the uncentred 4-bit index is far off
    assert [r["faithful"] for r in result["points"]] == [True, False, True]
    assert [P.error_bound_ulp < 1 for _, _, P in GRID] == [True, False, True]
    assert result["points"][1]["worst_ulp"] > 2


def test_worst_matches_model(result):
    """The recorded worst error is the model's: recompute it independently on every input."""
    from fxmodel.units.exact import as_float, recip_error_ulp

    for r, (_, _, P) in zip(result["points"], GRID):
        w = P.all_inputs()[:, 0]
        out = P.compute(w[:, None])
        err = as_float(*recip_error_ulp(w, out[:, 0], out[:, 1], P.in_fmt.frac_bits, P.fo))
        assert r["worst_ulp"] == pytest.approx(err.max(), rel=1e-12)
        assert r["mean_ulp"] == pytest.approx(err.mean(), rel=1e-9)


def test_pareto_front_non_dominated(result):
    recs = result["points"]
    front = [r for r in recs if r["pareto"]]
    assert front and result["pareto"]["recip"] == [r["name"] for r in sorted(front, key=lambda r: r["cost"])]
    for f in front:
        for r in recs:
            assert not (r["cost"] <= f["cost"] and r["correct_bits_worst"] >= f["correct_bits_worst"]
                        and (r["cost"] < f["cost"] or r["correct_bits_worst"] > f["correct_bits_worst"]))
    for r in recs:                    # every point off the front is dominated by one on it
        if not r["pareto"]:
            assert any(f["cost"] <= r["cost"] and f["correct_bits_worst"] >= r["correct_bits_worst"] for f in front)


def test_pareto_front_small_cases():
    recs = [{"cost": c, "correct_bits_worst": b} for c, b in [(1, 5), (2, 4), (2, 8), (3, 8), (4, 9)]]
    assert sw.pareto_front(recs) == [0, 2, 4]


def test_outputs(result, tmp_path):
    paths = sw.write_outputs(result, tmp_path)
    data = json.loads((tmp_path / "speed_vs_error.json").read_text())
    assert data["pareto"] == result["pareto"] and len(data["points"]) == 3
    md = (tmp_path / "speed_vs_error.md").read_text()
    assert all(g[0] in md for g in GRID)
    assert (tmp_path / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and len(paths) == 3


def test_faithful_p_is_widest():
    P = GRID[0][2]
    assert P.p == 7 and P.error_bound_ulp < 1
    assert P.replace(p=8, b=11).error_bound_ulp >= 1


def test_dsp_estimate_and_grid():
    from fxmodel.core.unit import preset

    rec = sw.measure_point("rcp24", "preset", preset("recip", "rcp24"), exhaustive_limit=1, samples=100)
    assert rec["dsp_blocks_est"] == preset("recip", "rcp24").cost()["dsp"] == 13     # the one cost model
    assert rec["cost"] == rec["table_bits"] + 1024 * rec["dsp_blocks_est"]
    assert sw.PAPER.entries == 128 and sw.PAPER.t == 3 and not sw.PAPER.center and sw.PAPER.table == "round"


def test_bad_arguments():
    with pytest.raises(ValueError):
        sw.sweep([], progress=False)
    assert bumpmap(["sweep", "--fpga-points", "7"]) == 2


def test_overlapping_labels_are_moved_apart():
    """``_declutter``: three labels written on one point end with disjoint boxes, spread around it."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tools.sweep import _declutter

    fig, ax = plt.subplots()
    texts = [ax.annotate(f"label {k}", (1, 1), xytext=(4, 0), textcoords="offset points") for k in range(3)]
    renderer = fig.canvas.get_renderer()
    assert texts[0].get_window_extent(renderer).overlaps(texts[1].get_window_extent(renderer))
    _declutter(fig, texts)
    boxes = [t.get_window_extent(renderer) for t in texts]
    assert not any(boxes[i].overlaps(boxes[j]) for i in range(3) for j in range(i + 1, 3))
    assert {round(t.xyann[0]) for t in texts} == {4}         # moved vertically only
    plt.close(fig)
