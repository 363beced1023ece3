"""The golden model's command line (bumpmap) and the $readmemh vector files."""

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset
from fxmodel.core.vectors import read_readmemh, write_readmemh
from tools.main import main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "tools", *args], capture_output=True, text=True)


def test_info_recip_reports_formats_and_bound():
    res = run_cli("info", "recip")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    P = preset("recip")
    assert info["inputs"] == [{"name": "w", "signed": True, "int_bits": 8, "frac_bits": 16}]
    assert [o["name"] for o in info["outputs"]] == ["mant", "exp", "dbz"]
    assert info["outputs"][0] == {"name": "mant", "signed": True, "int_bits": 2, "frac_bits": P.p - 1}
    assert info["precision_bits"] == P.p and info["table_entries"] == 2 ** (P.m - 1) and info["terms"] == P.t
    assert info["max_error_ulp"] == pytest.approx(float(P.error_bound_ulp)) and info["max_error_ulp"] < 1


def test_info_shows_the_cost_estimate_also_with_a_scene(capsys):
    assert main(["info", "pipeline"]) == 0
    demo = json.loads(capsys.readouterr().out)["cost"]
    assert demo == preset("pipeline").cost() and demo["dsp"] > 0
    assert main(["info", "pipeline", "--scene", "tin-plane", "--preset", "tin-plane-fit"]) == 0
    fitted = json.loads(capsys.readouterr().out)
    assert fitted["scene"] == "tin-plane" and fitted["cost"]["memory_bits"] != demo["memory_bits"]
    assert main(["info", "recip", "--scene", "tin-plane"]) == 2
    assert "pipeline only" in capsys.readouterr().err


def test_info_small_preset_has_16_bit_input(capsys):
    assert main(["info", "recip", "--preset", "small"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["inputs"][0]["int_bits"] + info["inputs"][0]["frac_bits"] == 16


def test_unknown_preset_and_unit_are_one_line_errors():
    res = run_cli("info", "recip", "--preset", "nope")
    assert res.returncode == 2 and "no preset 'nope'" in res.stderr and "Traceback" not in res.stderr
    res = run_cli("info", "nounit")
    assert res.returncode == 2 and "unknown unit 'nounit'" in res.stderr


def test_eval_writes_real_outputs_and_hex(tmp_path):
    P = preset("recip")
    w = np.array([0.5, -0.5, 1.0, 3.25, -100.0, 0.0, 2 ** -16])
    np.save(tmp_path / "in.npy", w)
    assert main(["eval", "recip", str(tmp_path / "in.npy"), str(tmp_path / "out.npy"),
                 "--hex", str(tmp_path / "v.hex")]) == 0
    out = np.load(tmp_path / "out.npy")
    assert out.shape == (7, 3) and out.dtype == np.float64
    recip = out[:, 0] * 2.0 ** out[:, 1]
    assert recip[:3].tolist() == [2.0, -2.0, 1.0] and recip[6] == 2.0 ** 16
    assert abs(recip[3] - 1 / 3.25) < 2 ** -(P.p - 1) / 3.25 * 2 and out[5, 2] == 1
    fields = [(p.name, p.fmt) for p in P.inputs + P.outputs]
    vec = read_readmemh(tmp_path / "v.hex", fields)
    codes = P.in_fmt.from_real(w)
    assert np.array_equal(vec[:, 0], codes) and np.array_equal(vec[:, 1:], P.compute(codes))


def test_eval_rejects_unrepresentable_value_naming_the_row(tmp_path):
    np.save(tmp_path / "in.npy", np.array([0.5, 0.25, 1e-9, 3.0]))
    res = run_cli("eval", "recip", str(tmp_path / "in.npy"), str(tmp_path / "out.npy"))
    assert res.returncode != 0 and "row 2" in res.stderr and "(w)" in res.stderr
    assert not (tmp_path / "out.npy").exists()


def test_eval_rejects_wrong_shape(tmp_path):
    np.save(tmp_path / "in.npy", np.zeros((3, 2)))
    res = run_cli("eval", "recip", str(tmp_path / "in.npy"), str(tmp_path / "out.npy"))
    assert res.returncode != 0 and "expected shape (K, 1)" in res.stderr


def test_eval_divide_two_columns(tmp_path):
    np.save(tmp_path / "in.npy", np.array([[0.75, 1.5], [-0.5, 1.0], [0.25, 0.0]]))
    assert main(["eval", "divide", str(tmp_path / "in.npy"), str(tmp_path / "out.npy")]) == 0
    out = np.load(tmp_path / "out.npy")
    D = preset("divide")
    assert abs(out[0, 0] - 0.5) <= float(D.max_error) and abs(out[1, 0] + 0.5) <= float(D.max_error)
    assert out[2, 1] == 1 and out[2, 0] == float(D.out_fmt.max_value)


def test_errors_command_on_small_is_exhaustive(capsys):
    assert main(["errors", "recip", "--preset", "small"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["coverage"] == "exhaustive" and rep["vectors"] == 1 << 16
    assert rep["within_bound"] and rep["faithful"] and rep["max_error_ulp"] <= rep["bound_ulp"]
    assert isinstance(rep["monotone"]["monotone"], bool)


@pytest.mark.parametrize("unit", ["persp", "bump"])
def test_errors_command_measures_persp_and_bump(capsys, unit):
    assert main(["errors", unit, "--preset", "small", "--random", "3000"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["within_bound"] and 0 < rep["vectors"] <= 3000 + len(preset(unit, "small").hard_cases())
    assert 0 < rep["mean_error"] <= rep["max_error"] <= rep["bound"]


@given(st.lists(st.tuples(st.integers(-(1 << 23), (1 << 23) - 1), st.integers(0, 7), st.integers(-(1 << 40), 1 << 40)),
                min_size=1, max_size=40))
def test_readmemh_round_trip(tmp_path_factory, rows):
    fields = [("a", Fmt(True, 8, 16)), ("b", Fmt(False, 3, 0)), ("c", Fmt(True, 42, 0))]
    path = tmp_path_factory.mktemp("hex") / "v.hex"
    codes = np.array(rows, dtype=np.int64)
    write_readmemh(path, fields, codes, chunk=7)
    lines = [s for s in path.read_text().splitlines() if not s.startswith("//")]
    assert len(lines) == len(rows) and all(len(s) == (24 + 3 + 42 + 3) // 4 for s in lines)
    assert np.array_equal(read_readmemh(path, fields), codes)


def test_render_from_triangles(tmp_path, capsys):
    """``bumpmap render --triangles``: the frame the engine draws, judged, with the fragments' beside it."""
    from tools.main import main
    assert main(["render", "tests/scenes/steep-sphere.toml", str(tmp_path / "t.png"), "--triangles",
                 "--cube-size", "8", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["input"] == "triangles" and rep["verdict"]["pass"] and rep["from_fragments"]["max_lsb_vs_float"] <= 1
    assert (tmp_path / "t.png").stat().st_size > 0
