"""No silent degradation: one code path (``host.render.prepare`` and ``judge``) makes
``render``, ``make sim`` and ``fit`` refuse a scene whose fragment inputs the preset would clamp, and fail a frame
farther from reference (a) than the documented bound."""

import json
from pathlib import Path

import pytest

from fxmodel.core.paths import ROOT
from host.render import SCENE_BOUND_LSB, ClampError, from_triangles, judge, prepare, render
from tools.main import main

STEEP = ROOT / "tests" / "scenes" / "steep-bumps.toml"          # A about 5.3: beyond bump.a_fmt without the exponent
WIDE = ROOT / "tests" / "scenes" / "wide-span.toml"             # U / W about 60: beyond persp.uv_fmt
TIN = ROOT / "scenes" / "tin-plane.toml"


def test_clamped_input_is_one_clear_error_naming_input_count_ranges_and_remedy():
    with pytest.raises(ClampError) as info:
        prepare(WIDE, size=32)
    msg = str(info.value)
    assert "wide-span.toml" in msg and "U:" in msg and "V:" in msg and "s6.20" in msg and "persp.uv_fmt" in msg
    assert "fit" in msg and "--allow-clamp" in msg
    c = info.value.clamped["U"]
    assert c["count"] > 0 and c["needs"][1] > c["holds"][1] == 32 - 2 ** -20


def test_allow_clamp_proceeds_and_counts():
    frame = prepare(WIDE, size=32, allow_clamp=True)
    assert 0 < frame.stats["clamped_fragment_inputs"]["U"] < len(frame.codes)


def test_judge_fails_a_frame_over_the_bound_and_records_the_verdict():
    frame = prepare(WIDE, size=32, allow_clamp=True)
    rep = render(frame)
    assert rep["max_lsb_vs_float"] > SCENE_BOUND_LSB                        # clamping U ruins the frame
    problems = judge(rep)
    assert problems and "over the bound" in problems[0] and not rep["verdict"]["pass"]
    assert rep["verdict"]["bound_lsb"] == SCENE_BOUND_LSB and rep["verdict"]["clamped_fragment_inputs"]["U"] > 0
    assert judge(rep, max_lsb=rep["max_lsb_vs_float"]) == [] and rep["verdict"]["pass"]
    assert sum(rep["pixels_by_lsb_vs_float"]) == rep["pixels"]


def test_render_command_exit_codes(tmp_path, capsys):
    out = str(tmp_path / "x.png")
    assert main(["render", str(WIDE), out, "--size", "32"]) == 2                  # refused: would clamp
    assert "persp.uv_fmt" in capsys.readouterr().err and not Path(out).exists()
    assert main(["render", str(WIDE), out, "--size", "32", "--allow-clamp"]) == 1     # drawn, but over the bound
    err = capsys.readouterr().err
    assert "clamped fragment inputs" in err and "over the bound" in err
    assert main(["render", str(TIN), out, "--size", "24", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["verdict"]["pass"] and rep["verdict"]["bound_lsb"] == SCENE_BOUND_LSB


def test_fit_widens_a_preset_for_a_scene_the_default_refuses(tmp_path, monkeypatch):
    """fit widens as well as narrows: U / W about 60 needs another integer bit (and the addresses then more
    fraction bits); the written preset draws the scene within the bound, with no clamped input."""
    from tools.fit import fit
    rep = fit(WIDE, size=None, scene_size=24, directory=tmp_path, progress=False, passes=1, name="wide")
    assert [s[0] for s in rep["widened"]][0] == "uv_int" and rep["final"]["max_lsb_vs_float"] <= 1
    monkeypatch.setenv("FXMODEL_PRESETS", str(tmp_path))
    frame = prepare(WIDE, size=24, preset="wide")                       # no ClampError
    assert judge(render(frame), 1) == []


def test_make_sim_refuses_clamped_inputs_and_fails_a_frame_over_the_bound(monkeypatch, tmp_path, capsys):
    """``make sim`` (cosim.sim) goes through the same prepare/judge path; the RTL run itself is replaced by the
    model's output here (the co-simulation tests run the RTL)."""
    import cosim.sim as sim

    class FakeResult(dict):
        ok = True

        def describe(self):
            return ""

    def fake_stream(params, codes, *args):
        res = FakeResult(mismatches=0, first=[], seconds=1.0, sim_cpu_seconds=1.0, cycles=len(codes),
                         build_seconds=0.0)
        res.rtl = params.compute(codes)
        return res

    monkeypatch.setattr(sim, "_stream", fake_stream)
    monkeypatch.setenv("BUMPMAP_BUILD", str(tmp_path / "build"))
    args = ["--scene", str(WIDE), "--size", "32", "--cube-size", "4", "--sim", "icarus"]
    assert sim.main(args) == 2 and "persp.uv_fmt" in capsys.readouterr().err      # from triangles (the default)
    assert sim.main(args + ["--allow-clamp"]) == 2                                 # the set-up refuses by name
    assert "attribute U" in capsys.readouterr().err
    args += ["--input", "fragments"]
    assert sim.main(args) == 2 and "persp.uv_fmt" in capsys.readouterr().err
    assert sim.main(args + ["--allow-clamp", "--max-lsb", "0"]) == 1
    assert "over the bound of 0 LSB" in capsys.readouterr().err
    out = sim.output_folder(args + ["--allow-clamp", "--max-lsb", "0"])
    assert out.parent == tmp_path / "build" / "sim" and out.name.startswith("wide-span-")
    rep = json.loads((out / "report.json").read_text())
    assert rep["verdict"]["bound_lsb"] == 0 and not rep["verdict"]["pass"]
    assert rep["verdict"]["clamped_fragment_inputs"]["U"] > 0


def test_block_exponent_draws_a_steep_bump_map_within_the_bound():
    """Regression: A about 5.3 (beyond bump.a_fmt) was clamped on every fragment; the per-triangle exponent holds it."""
    frame = prepare(STEEP, size=48)
    rep = render(frame)
    assert frame.stats["block_exponents"][0] == 0 and sum(frame.stats["block_exponents"]) == len(frame.codes)
    assert judge(rep) == [] and rep["flags"]["bump_saturated"] == 0


def test_grazing_floor_is_refused_for_its_texture_addresses():
    """Regression: a floor running to W = 0.0013 was drawn 8-13 LSB from (a); its addresses are not resolved."""
    with pytest.raises(ClampError) as info:
        prepare(ROOT / "tests" / "scenes" / "grazing-floor.toml", size=48)
    assert not info.value.clamped and "U, V (bump-map address)" in info.value.imprecise
    assert "more fraction bits" in str(info.value)


def test_reference_c_is_reported_only_when_asked(tmp_path, capsys):
    """``render --truth K`` (and ``render(truth_samples=K)``): the model, (a) and (b) judged against the true image
    on the covered pixels, ``truth.png`` written; without it, no ``vs_truth`` and no picture."""
    frame = prepare(TIN, size=24)
    plain = render(frame, tmp_path / "plain")
    assert "vs_truth" not in plain and not (tmp_path / "plain" / "truth.png").exists()
    rep = render(frame, tmp_path / "c", truth_samples=4)
    vt = rep["vs_truth"]
    assert vt["samples"] == 4 and 0 < vt["full_pixels"] <= rep["pixels"] and vt["edge_pixels"] > 0
    assert {"model", "float", "ideal"} <= set(vt) and (tmp_path / "c" / "truth.png").stat().st_size > 0
    assert main(["render", str(TIN), str(tmp_path / "x.png"), "--size", "24", "--truth", "4"]) == 0
    assert "model vs truth (c)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:                                            # ranged: 0..32
        main(["render", str(TIN), str(tmp_path / "x.png"), "--truth", "99"])
    assert exc.value.code == 2 and "--truth: 99 is out of range" in capsys.readouterr().err


def test_sim_folder_names_reference_c_only_when_asked():
    """``sim --truth``: a run judged against (c) has a folder of its own; the default run's name is unchanged."""
    import argparse

    from cosim.sim import run_key
    base = dict(size=None, preset="default", cube_size=None, sim="icarus", input="triangles", depth=False,
                allow_clamp=False)
    plain = run_key(argparse.Namespace(**base, truth=0), TIN)
    assert run_key(argparse.Namespace(**base), TIN) == plain
    assert run_key(argparse.Namespace(**base, truth=8), TIN) != plain


def test_a_triangle_the_records_cannot_hold_is_refused_naming_the_scene_and_the_remedy(tmp_path):
    # A triangle whose U spans exactly two tiles (vertex values -1 .. 1) fits the fragments of a preset fitted
    # to another scene (sphere-fit: its vertex format holds [-1, 1)) but not its triangle record: `render` drew
    # it, `render --triangles` and `sim` refused it with the set-up's bare "triangle 0: attribute U ..." (no
    # scene, no remedy).
    path = tmp_path / "two-tiles.toml"
    path.write_text("""
[image]
width = 32
height = 32
[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 45.0
[[lights]]
direction = [0.0, 0.0, 1.0]
color = [0.9, 0.9, 0.9]
[[materials]]
name = "m"
[materials.bump]
procedural = "mexican-hat"
size = [16, 16]
repeat = [2, 2]
[[meshes]]
kind = "triangles"
material = "m"
positions = [[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]]
uvs = [[0.0, 1.0], [1.0, 1.0], [0.5, 0.0]]
""")
    frame = prepare(path, preset="sphere-fit")                             # the fragments fit
    with pytest.raises(ValueError) as info:
        from_triangles(frame)
    msg = str(info.value)
    assert str(path) in msg and "attribute U" in msg and f"bumpmap fit {path}" in msg
