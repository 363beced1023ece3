"""No silent degradation (issue 12, item 2): one code path (``fxmodel.render.prepare`` and ``judge``) makes
``render``, ``make sim`` and ``fit`` refuse a scene whose fragment inputs the preset would clamp, and fail a frame
farther from reference (a) than the documented bound."""

import json
from pathlib import Path

import pytest

from fxmodel.cli import main
from fxmodel.render import SCENE_BOUND_LSB, ClampError, judge, prepare, render

ROOT = Path(__file__).resolve().parents[1]
STEEP = ROOT / "tests" / "scenes" / "steep-bumps.toml"          # A about 5.3: beyond s2.14
TIN = ROOT / "scenes" / "tin-plane.toml"


def test_clamped_input_is_one_clear_error_naming_input_count_ranges_and_remedy():
    with pytest.raises(ClampError) as info:
        prepare(STEEP, size=24)
    msg = str(info.value)
    assert "steep-bumps.toml" in msg and "A00" in msg and "A21" in msg and "s2.14" in msg and "bump.a_fmt" in msg
    assert "fit" in msg and "--allow-clamp" in msg
    c = info.value.clamped["A00"]
    assert c["count"] > 0 and c["needs"][1] > c["holds"][1] == 2 - 2 ** -14


def test_allow_clamp_proceeds_and_counts():
    frame = prepare(STEEP, size=24, allow_clamp=True)
    assert frame.stats["clamped_fragment_inputs"]["A00"] == len(frame.codes) > 0


def test_judge_fails_a_frame_over_the_bound_and_records_the_verdict():
    frame = prepare(STEEP, size=24, allow_clamp=True)
    rep = render(frame)
    assert rep["max_lsb_vs_float"] > SCENE_BOUND_LSB                        # clamping A ruins the frame
    problems = judge(rep)
    assert problems and "over the bound" in problems[0] and not rep["verdict"]["pass"]
    assert rep["verdict"]["bound_lsb"] == SCENE_BOUND_LSB and rep["verdict"]["clamped_fragment_inputs"]["A00"] > 0
    assert judge(rep, max_lsb=rep["max_lsb_vs_float"]) == [] and rep["verdict"]["pass"]
    assert sum(rep["pixels_by_lsb_vs_float"]) == rep["pixels"]


def test_render_command_exit_codes(tmp_path, capsys):
    out = str(tmp_path / "x.png")
    assert main(["render", str(STEEP), out, "--size", "24"]) == 2                 # refused: would clamp
    assert "A00" in capsys.readouterr().err and not Path(out).exists()
    assert main(["render", str(STEEP), out, "--size", "24", "--allow-clamp"]) == 1    # drawn, but over the bound
    err = capsys.readouterr().err
    assert "clamped fragment inputs" in err and "over the bound" in err
    assert main(["render", str(TIN), out, "--size", "24"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["verdict"]["pass"] and rep["verdict"]["bound_lsb"] == SCENE_BOUND_LSB


def test_fit_refuses_a_clamped_scene(tmp_path):
    from fxmodel.fit import fit
    with pytest.raises(ClampError, match="A00"):
        fit(STEEP, size=None, scene_size=16, directory=tmp_path, progress=False)


def test_make_sim_refuses_clamped_inputs_and_fails_a_frame_over_the_bound(monkeypatch, tmp_path, capsys):
    """``make sim`` (cosim.sim) goes through the same prepare/judge path; the RTL run itself is replaced by the
    model's output here (the co-simulation tests run the RTL)."""
    import cosim.sim as sim
    from cosim.harness import CosimResult

    def fake_run(params, codes, **kw):
        res = CosimResult(vectors=len(codes), mismatches=0, first=[], seconds=1.0, build_seconds=0.0)
        res.rtl = params.compute(codes)
        return res

    monkeypatch.setattr(sim, "run", fake_run)
    monkeypatch.setattr(sim, "ROOT", tmp_path)
    args = ["--scene", str(STEEP), "--size", "16", "--cube-size", "4", "--sim", "icarus"]
    assert sim.main(args) == 2 and "A00" in capsys.readouterr().err
    assert sim.main(args + ["--allow-clamp", "--max-lsb", "0"]) == 1
    assert "over the bound of 0 LSB" in capsys.readouterr().err
    rep = json.loads((tmp_path / "build" / "sim" / "steep-bumps" / "report.json").read_text())
    assert rep["verdict"]["bound_lsb"] == 0 and not rep["verdict"]["pass"]
    assert rep["verdict"]["clamped_fragment_inputs"]["A00"] > 0
