"""``bumpmap``'s one error path: scene and preset files are untrusted input.

One regression test per defect found by trying bad and extreme inputs as a new user would: paths made from a
scene's free-text name, outputs checked only after the work, arguments without a range, empty frames reported as
success, JSON with ``Infinity``, extreme values accepted by the schema that failed later, preset errors blaming
the wrong key. Each runs the command line (``tools.main.main``) in a sandbox (``tmp_path`` with the build folder
inside it) and checks the exit code, that the error is one line naming what was wrong, and what was written.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from fxmodel.core.paths import ROOT
from tools.main import main as bumpmap

TIN = ROOT / "scenes" / "tin-plane.toml"
GRAZING = ROOT / "tests" / "scenes" / "grazing-floor.toml"

#: A small scene whose fields the tests replace (a quad under a camera looking down at it).
SCENE = """\
name = "{name}"
[image]
width = 16
height = 12
[camera]
position = [0.0, {camera_y}, 2.0]
target = [0.0, 0.0, 0.0]
fov = 45.0
[[lights]]
direction = [0.0, 1.0, 1.0]
color = [{light}, 0.5, 0.5]
[[materials]]
name = "m"
color = {color}
{bump}
[[meshes]]
kind = "quad"
material = "m"
origin = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, {edge_v}]
"""
DEFAULTS = {"name": "small", "camera_y": "1.0", "light": "0.5", "color": "[0.5, 0.5, 0.5]", "bump": "",
            "edge_v": "2.0"}


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """cwd inside ``tmp_path``, the build folder and the presets folder inside it."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("BUMPMAP_BUILD", str(work / "build"))
    monkeypatch.setenv("FXMODEL_PRESETS", str(work / "presets"))
    return work


def scene(folder: Path, stem: str = "small", **fields) -> Path:
    path = folder / f"{stem}.toml"
    path.write_text(SCENE.format(**{**DEFAULTS, **fields}))
    return path


def listing(root: Path) -> dict:
    """Every file below ``root``: relative path -> (size, modification time)."""
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*")
            if p.is_file()}


def one_error(capsys, *words) -> str:
    """The stderr of the last command: exactly one line, no traceback, containing ``words``."""
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    for w in words:
        assert w in err, (w, err)
    return err


# -- 1. paths from the command line, never from file contents -------------------------------------------------
@pytest.mark.parametrize("name", ["../../escape", "/abs/olute", "Fig 9/a", "..", "a\\b"])
def test_sim_folder_comes_from_the_file_not_the_name(sandbox, tmp_path, name, capsys):
    """A scene named ``../../escape`` made ``make sim`` write and delete files outside ``build/``; the folder is
    now the file's stem and a digest, under ``build/sim``, and nothing outside it changes."""
    victim = tmp_path / "escape" / "report.json"
    victim.parent.mkdir()
    victim.write_text("keep me")
    path = scene(sandbox, name=name.replace("\\", "\\\\"))
    before = listing(tmp_path)
    argv = ["--scene", str(path), "--size", "16", "--model-only"]
    assert bumpmap(["sim", *argv]) == 0
    from cosim.sim import output_folder
    out = output_folder(argv)
    assert out.parent == sandbox / "build" / "sim" and out.name.startswith("small-")
    assert json.loads((out / "report.json").read_text())["rtl"] is None
    after = listing(tmp_path)
    changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
    assert changed and all(k.startswith("work/build/sim") for k in changed), changed
    assert victim.read_text() == "keep me"


def test_sim_runs_that_differ_never_share_a_folder(sandbox):
    from cosim.sim import output_folder
    path = scene(sandbox)
    base = ["--scene", str(path), "--model-only"]
    folders = {output_folder(base + extra) for extra in
               ([], ["--size", "8"], ["--preset", "p"], ["--sim", "verilator"], ["--input", "fragments"],
                ["--cube-size", "8"])}
    assert len(folders) == 6


def test_fit_refuses_a_bad_name_before_writing_anything(sandbox, tmp_path, capsys):
    path = scene(sandbox)
    before = listing(tmp_path)
    for name in ("../../x", "/abs", "a/b", ".hidden", ""):
        assert bumpmap(["fit", str(path), "--name", name, "--out", str(sandbox / "p"), "--quiet"]) == 2
        one_error(capsys, "bad pipeline preset name")
    assert listing(tmp_path) == before


def test_fit_default_name_is_the_file_stem_not_the_scene_name(sandbox, capsys):
    """A scene named ``a/../../b`` wrote its preset outside ``--out``; the default name is the file's stem."""
    path = scene(sandbox, name="a/../../b")
    out = sandbox / "p"
    assert bumpmap(["fit", str(path), "--size", "8", "--passes", "1", "--out", str(out), "--quiet"]) == 0
    assert [p.name for p in out.iterdir()] == ["small-fit.toml"]
    assert json.loads(capsys.readouterr().out)["path"] == str(out / "small-fit.toml")


def test_maps_file_names_are_labels_not_paths(sandbox, tmp_path):
    """``bumpmap maps`` named its PNGs by the material's free-text name: ``../../x`` wrote outside the folder."""
    text = SCENE.format(**DEFAULTS).replace('name = "m"', 'name = "../../x"').replace('material = "m"',
                                                                                    "material = 0")
    path = sandbox / "maps.toml"
    path.write_text(text)
    before = listing(tmp_path)
    assert bumpmap(["maps", str(path), str(sandbox / "maps")]) == 0
    after = listing(tmp_path)
    new = sorted(k for k in after if before.get(k) != after[k])
    assert new == ["work/maps/0-______x_color.png"], new


@pytest.mark.parametrize("stem, name", [("ü-x", "x-fit"), ("-x", "x-fit"), ("..x", "x-fit"), ("a b", "a_b-fit"),
                                        ("ü", "scene-fit")])
def test_fit_default_name_of_any_file_stem_is_a_preset_name(sandbox, stem, name):
    """Found by the fuzzer: a scene file ``ü-x.toml`` gave the default name ``_-x-fit``, which fit then refused."""
    from fxmodel.pipeline.presets import check_preset_name
    from tools.fit import _setup
    path = scene(sandbox, stem=stem)
    assert check_preset_name(_setup(path, 8, None, None).default_name) == name


# -- 3. one error path: outputs checked before the work -------------------------------------------------------
def test_output_problems_are_one_line_before_the_work(sandbox, capsys):
    path = scene(sandbox)
    (sandbox / "dir.png").mkdir()
    assert bumpmap(["render", str(path), str(sandbox / "dir.png")]) == 2
    one_error(capsys, "dir.png", "is a directory")
    (sandbox / "refs").write_text("a file")
    assert bumpmap(["render", str(path), str(sandbox / "x.png"), "--refs", str(sandbox / "refs")]) == 2
    one_error(capsys, "refs", "is a file")
    assert not (sandbox / "x.png").exists()
    (sandbox / "preset-file").write_text("a file")
    assert bumpmap(["fit", str(path), "--out", str(sandbox / "preset-file"), "--quiet"]) == 2
    one_error(capsys, "preset-file")


def test_an_output_that_is_an_input_is_refused_and_the_input_kept(sandbox, capsys):
    """``render scene.toml scene.toml`` replaced the scene file with the PNG, and an output naming the scene's PNG
    map, the preset file or (another spelling, a hard link of) the input did the same; ``eval`` and ``send
    --dry-run`` too. Each is refused (exit 2, one line) before the work, and the input is unchanged."""
    import numpy as np
    from PIL import Image
    path = scene(sandbox, color='{ file = "paint.png" }')
    Image.new("RGB", (4, 4), (200, 100, 50)).save(sandbox / "paint.png")
    (sandbox / "presets").mkdir()
    (sandbox / "presets" / "p.toml").write_text("weight_bits = 12\n")
    os.link(path, sandbox / "link.toml")
    before = listing(sandbox)
    for out, preset in ((path, "default"), ("./small.toml", "default"), ("link.toml", "default"),
                        ("paint.png", "default"), ("presets/p.toml", "p")):
        assert bumpmap(["render", str(path), str(out), "--size", "8", "--cube-size", "8", "--preset", preset]) == 2
        one_error(capsys, f"output PNG {Path(out)}: is the input")
    np.save(sandbox / "in.npy", np.array([1.0, 1.5]))
    before = listing(sandbox)
    assert bumpmap(["eval", "recip", "in.npy", "in.npy"]) == 2
    one_error(capsys, "output in.npy: is the input in.npy")
    assert bumpmap(["send", "--scene", str(path), "--dry-run", str(path)]) == 2
    one_error(capsys, "--dry-run file", "is the input")
    assert bumpmap(["fit", str(path), "--out", str(sandbox), "--name", "small", "--quiet"]) == 2
    one_error(capsys, "preset file", "small.toml: is the input")
    assert listing(sandbox) == before


def test_refs_images_that_are_inputs_or_the_output_are_refused(sandbox, capsys):
    """``render --refs DIR`` writes fixed names (``host.render.REFERENCE_IMAGES``) into DIR: a scene's PNG map
    named ``diff.png`` there was overwritten by the difference image, and an output PNG named ``DIR/diff.png`` by
    the model's image over the difference image. Each is refused (exit 2, one line) before the work, and nothing
    is written. ``DIR/model.png`` as the output is the same picture as the references' own, and is drawn."""
    from PIL import Image
    path = scene(sandbox, color='{ file = "diff.png" }')
    Image.new("RGB", (4, 4), (200, 100, 50)).save(sandbox / "diff.png")
    before = listing(sandbox)
    size = ["--size", "8", "--cube-size", "8"]
    assert bumpmap(["render", str(path), "out.png", "--refs", ".", *size]) == 2
    one_error(capsys, "--refs image diff.png", "is the input")
    assert bumpmap(["render", str(path), "refs/diff.png", "--refs", "refs", *size]) == 2
    one_error(capsys, "output PNG refs/diff.png", "diff.png")
    assert {k: v for k, v in listing(sandbox).items() if k != "refs"} == before
    assert bumpmap(["render", str(path), "refs/model.png", "--refs", "refs", *size]) in (0, 1)   # drawn
    assert (sandbox / "refs" / "diff.png").exists() and listing(sandbox)["diff.png"] == before["diff.png"]


def test_an_output_that_is_not_a_regular_file_is_refused(sandbox, capsys):
    """An output path naming a FIFO or a device (``render scene.toml /dev/null``) was renamed over: run as root,
    that replaced ``/dev/null`` with a regular file. It is refused before the work (exit 2, one line); here a
    FIFO stands for the device."""
    path = scene(sandbox)
    os.mkfifo(sandbox / "fifo")
    for argv in (["render", str(path), "fifo", "--size", "8", "--cube-size", "8"],
                 ["send", "--scene", str(path), "--dry-run", "fifo"]):
        assert bumpmap(argv) == 2
        one_error(capsys, "fifo: not a regular file")
        assert stat.S_ISFIFO(os.lstat(sandbox / "fifo").st_mode)


def test_animate_names_its_picture_by_the_file_not_the_scene_name(sandbox, tmp_path):
    """``bumpmap animate`` named its GIF by the scene's ``name``: ``name = "../../x"`` wrote ``../../x.gif``
    outside ``--out``. The default is the scene file's stem."""
    pytest.importorskip("imageio.v3")
    path = scene(sandbox, name="../../escaped")
    path.write_text(path.read_text() + "[animation]\nframes = 2\n")
    before = listing(tmp_path)
    assert bumpmap(["animate", "--scene", str(path), "--size", "16", "--out", "out", "--rates"]) == 0
    after = listing(tmp_path)
    assert sorted(k for k in after if before.get(k) != after[k]) == ["work/out/small.gif"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_output_folder_is_refused_before_the_work(sandbox, capsys):
    path = scene(sandbox)
    ro = sandbox / "ro"
    ro.mkdir()
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        assert bumpmap(["render", str(path), str(ro / "x.png")]) == 2
        one_error(capsys, "not writable")
    finally:
        ro.chmod(0o755)


def test_eval_checks_both_outputs_before_writing_either(sandbox, capsys):
    import numpy as np
    np.save(sandbox / "in.npy", np.array([1.0, 1.5]))
    assert bumpmap(["eval", "recip", str(sandbox / "in.npy"), str(sandbox / "missing" / "deep" / "out.npy"),
                    "--hex", str(sandbox)]) == 2
    one_error(capsys, "--hex file", "is a directory")
    assert not (sandbox / "missing" / "deep" / "out.npy").exists()
    assert bumpmap(["eval", "recip", str(sandbox / "in.npy"), str(sandbox / "new" / "out.npy")]) == 0
    assert np.load(sandbox / "new" / "out.npy").shape[0] == 2


def test_eval_checks_a_npy_header_against_the_file_before_loading(sandbox, capsys):
    """A 144-byte ``.npy`` whose header declares ``shape (10**12,)`` made ``np.load`` ask for 7 TiB: a
    ``MemoryError`` traceback. The header is checked against the file's size first; pickles are never loaded."""
    import numpy as np
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000,), }".ljust(117) + "\n"
    (sandbox / "huge.npy").write_bytes(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
                                       + bytes(16))
    assert bumpmap(["eval", "recip", "huge.npy", "out.npy"]) == 2
    one_error(capsys, "huge.npy", "shape (1000000000000,)", "holds 16 bytes")
    np.save(sandbox / "obj.npy", np.array([1.0, None], dtype=object), allow_pickle=True)
    assert bumpmap(["eval", "recip", "obj.npy", "out.npy"]) == 2
    one_error(capsys, "obj.npy", "never loaded")
    assert not (sandbox / "out.npy").exists()


@pytest.mark.parametrize("argv, words", [
    (["render", "S", "x.png", "--cube-size", "100000"], "--cube-size: 100000 is out of range"),
    (["render", "S", "x.png", "--cube-size", "0"], "--cube-size: 0 is out of range"),
    (["render", "S", "x.png", "--size", "0"], "--size: 0 is out of range"),
    (["render", "S", "x.png", "--max-lsb", "-1"], "--max-lsb: -1 is out of range"),
    (["fit", "S", "--passes", "-1"], "--passes: -1 is out of range"),
    (["fit", "S", "--jobs", "0"], "--jobs: 0 is out of range"),
    (["fit", "S", "--max-lsb", "-1"], "--max-lsb: -1 is out of range"),
    (["errors", "recip", "--random", "-5"], "--random: -5 is out of range"),
    (["sim", "--shards", "0"], "--shards: 0 is out of range"),
    (["sim", "--latency", "99"], "--latency: 99 is out of range"),
    (["sim", "--wait-states", "1"], "--wait-states: 1 is out of range"),
    (["scenes-stress", "--count", "-5"], "--count: -5 is out of range"),        # was an empty success, exit 0
    (["scenes-stress", "--size", "0"], "--size: 0 is out of range"),
])
def test_every_numeric_argument_is_ranged(sandbox, capsys, argv, words):
    with pytest.raises(SystemExit) as exc:
        bumpmap([str(scene(sandbox)) if a == "S" else a for a in argv])
    assert exc.value.code == 2
    one_error(capsys, words)


def test_sim_unit_typo_is_one_line(sandbox, capsys):
    assert bumpmap(["sim", "--unit", "recipx"]) == 2
    one_error(capsys, "unknown unit 'recipx'")


def test_the_same_malformed_scene_exits_2_everywhere(sandbox, capsys):
    bad = sandbox / "bad.toml"
    bad.write_text("[image]\nwidth = 'wide'\n")
    for argv in (["render", str(bad), "x.png"], ["fit", str(bad), "--quiet"],
                 ["sim", "--scene", str(bad), "--model-only"], ["info", "pipeline", "--scene", str(bad)]):
        assert bumpmap(argv) == 2, argv
        one_error(capsys, "bad.toml")


def test_render_size_help_says_the_aspect_is_kept(capsys):
    with pytest.raises(SystemExit):
        bumpmap(["render", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(square)" not in text and "keeps the scene's aspect ratio" in text


# -- 4. limits stated once, extreme values refused by key ------------------------------------------------------
@pytest.mark.parametrize("fields, key", [
    ({"bump": '[materials.bump]\nprocedural = "mexican-hat"\nsigma = 1e308'}, "materials[0].bump.sigma"),
    ({"light": "1e308"}, "lights[0].color"),
    ({"edge_v": "1e160"}, "meshes[0].edge_v"),
    ({"camera_y": "1e308"}, "camera.position"),
    ({"color": '{ procedural = "graffiti", size = [8, 2] }'}, "materials[0].color.size"),
    ({"color": '{ procedural = "graffiti", size = [8, 1] }'}, "materials[0].color.size"),
])
def test_extreme_values_are_refused_by_key(sandbox, capsys, fields, key):
    """Each of these failed later with a traceback or blamed another key (sigma 1e308: OverflowError; a light
    of 1e308: 'diffuse cube: row 0: inf'; 1e160 positions: NaN normals and exit 0; camera y 1e308: 'camera.up
    parallel'; graffiti 1 or 2 texels high: Pillow's 'font size must be greater than 0')."""
    path = scene(sandbox, **fields)
    assert bumpmap(["render", str(path), str(sandbox / "x.png")]) == 2
    one_error(capsys, key)
    assert not (sandbox / "x.png").exists()


def test_byte_order_mark_is_accepted(sandbox, capsys):
    path = scene(sandbox)
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert bumpmap(["render", str(path), str(sandbox / "x.png")]) == 0


@pytest.mark.parametrize("text, words", [
    ('[persp]\nuv_fmt = "s6.200"\n', "key persp.uv_fmt"),
    ("[bump]\nd_fmt = 13\n", "key bump.d_fmt: must be a format string"),
    ("[persp]\ncoord_bits = 100000000000\n", "key persp.coord_bits"),
])
def test_preset_errors_blame_the_right_key(sandbox, capsys, text, words):
    (sandbox / "presets").mkdir()
    (sandbox / "presets" / "bad.toml").write_text(text)
    assert bumpmap(["render", str(scene(sandbox)), str(sandbox / "x.png"), "--preset", "bad"]) == 2
    one_error(capsys, words)


@pytest.mark.parametrize("depth", [500, 5000])
def test_toml_nested_too_deeply_is_one_line(sandbox, capsys, depth):
    """``a = [[[[...]]]]`` a few hundred levels deep (a 10 kB file) made tomllib raise ``RecursionError``: a
    traceback and exit 1, for a scene file and for a preset file."""
    deep = "[" * depth + "]" * depth
    bad = sandbox / "deep.toml"
    bad.write_text(f"name = {deep}\n")
    assert bumpmap(["render", str(bad), "x.png"]) == 2
    one_error(capsys, "deep.toml: TOML nested too deeply")
    (sandbox / "presets").mkdir()
    (sandbox / "presets" / "deep.toml").write_text(f"weight_bits = {deep}\n")
    assert bumpmap(["render", str(scene(sandbox)), "x.png", "--preset", "deep"]) == 2
    one_error(capsys, "presets/deep.toml: TOML nested too deeply")
    assert not (sandbox / "x.png").exists()


# -- 5. no empty success ----------------------------------------------------------------------------------------
def test_an_empty_frame_is_a_warning_in_render_and_a_refusal_in_fit_and_sim(sandbox, capsys):
    """Camera below the floor (back faces culled): render drew a black PNG with "pass": true and no word, fit
    'succeeded' with 1-bit formats, make sim ended in a traceback ('no inputs: nothing to check')."""
    path = scene(sandbox, camera_y="-1.0")
    assert bumpmap(["render", str(path), str(sandbox / "x.png"), "--json"]) == 0
    captured = capsys.readouterr()
    assert "warning:" in captured.err and "nothing is drawn" in captured.err
    report = json.loads(captured.out)                       # strict JSON: no Infinity for the empty frame
    assert report["pixels"] == 0 and report["psnr_db_vs_float"] is None and report["exact_vs_float"]
    assert bumpmap(["fit", str(path), "--quiet", "--out", str(sandbox / "p")]) == 2
    one_error(capsys, "nothing is drawn")
    assert not (sandbox / "p" / "small-fit.toml").exists()
    assert bumpmap(["sim", "--scene", str(path), "--model-only"]) == 2
    one_error(capsys, "nothing is drawn")


@pytest.mark.parametrize("way", ["--depth", "--textures"])
def test_sim_with_the_frame_buffer_or_external_textures_judges_the_frame(sandbox, capsys, monkeypatch, way):
    """``bumpmap sim --depth`` and ``--textures external`` exited 0 on "RTL == model" without judging the frame
    against reference (a): ``--max-lsb`` was ignored, ``report.json`` had no verdict and a depth disagreement
    beyond the precision could not fail. The simulator is replaced by one that returns the model's frame (RTL ==
    model), so only the judging is tested; ``--max-lsb 0`` on a frame 1 LSB from (a) must fail."""
    import cosim.engine_fetch
    import cosim.rop
    from cosim.sim import output_folder

    def fake_depth(params, records, **kw):
        zbuf, color, stats, out, scan = params.draw(records.matrix())
        return {"color": color, "rtl_bytes_read": stats["bytes_read"], "rtl_bytes_written": stats["bytes_written"],
                "mismatches": 0, "first": [], "status": 0, "cycles": 1, "seconds": 0.0, "build_seconds": 0.0}

    def fake_fetch(params, records, **kw):
        out, _ = params.compute(records)
        return {"mismatches": 0, "first": [], "rtl": out, "bursts_equal": True, "rtl_bytes": 0,
                "model_bytes": 0, "maps": {}, "cycles": 1, "clocks_per_fragment": 1.0, "raster_clocks": 1,
                "seconds": 0.0, "build_seconds": 0.0}

    monkeypatch.setattr(cosim.rop, "run_engine", fake_depth)
    monkeypatch.setattr(cosim.engine_fetch, "run_engine_fetch", fake_fetch)
    path = scene(sandbox, bump='[materials.bump]\nprocedural = "mexican-hat"\nsize = [8, 8]\nstrength = 2.0')
    argv = ["--scene", str(path), "--truth", "0", *(["--depth"] if way == "--depth" else ["--textures", "external"])]
    assert bumpmap(["sim", *argv]) == 0
    report = json.loads((output_folder(argv) / "report.json").read_text())
    assert report["verdict"]["pass"] and report["max_lsb_vs_float_well_conditioned"] == 1
    capsys.readouterr()
    assert bumpmap(["sim", *argv, "--max-lsb", "0"]) == 1
    out, err = capsys.readouterr()
    assert "RTL == model" in out and "verdict" in out and "FAIL" in out
    assert "over the bound of 0 LSB" in err
    assert not json.loads((output_folder([*argv, "--max-lsb", "0"]) / "report.json").read_text())["verdict"]["pass"]


# -- 6. strict JSON -------------------------------------------------------------------------------------------
def test_reports_are_strict_json(sandbox, capsys):
    """``report.json`` held ``Infinity`` when a frame equalled a reference; a strict parser must read it."""
    path = scene(sandbox, light="0.0", color="[0.0, 0.0, 0.0]")        # black everywhere: equals both refs
    assert bumpmap(["sim", "--scene", str(path), "--model-only"]) == 0
    from cosim.sim import output_folder
    text = (output_folder(["--scene", str(path), "--model-only"]) / "report.json").read_text()

    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")
    report = json.loads(text, parse_constant=refuse)
    assert report["exact_vs_float"] and report["psnr_db_vs_float"] is None
    from host.atomic import strict_json
    with pytest.raises(ValueError):
        strict_json({"psnr": float("inf")})


# -- 7. fit keeps its promise or says why ----------------------------------------------------------------------
@pytest.mark.parametrize("size", ["64", "0"])
def test_fit_meets_the_bound_on_the_grazing_floor(sandbox, capsys, size):
    """``fit --max-lsb 1`` on the grazing floor ended in 'RuntimeError: the final preset is 3 LSB from (a)':
    the widening judged the fragments' frame, the final check the triangles'. It widens on, judged as the final
    check judges, and the written preset meets the bound at full size."""
    assert bumpmap(["fit", str(GRAZING), "--max-lsb", "1", "--size", size, "--quiet",
                    "--out", str(sandbox / "p")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["final"]["max_lsb_vs_float_well_conditioned"] <= 1
    from fxmodel.pipeline.presets import load_preset
    from host.render import from_triangles, prepare, render
    units = load_preset("grazing-floor-fit", sandbox / "p")
    frame = prepare(GRAZING, preset=units)
    rep = render(frame, model=from_triangles(frame).in_frame_order())
    assert rep["max_lsb_vs_float_well_conditioned"] <= 1


def test_fit_that_cannot_reach_the_bound_exits_1_with_the_best(sandbox, capsys, monkeypatch):
    """Where no widening helps, one line: the best bound reached and the preset reaching it, exit 1."""
    import tools.fit as fit
    monkeypatch.setattr(fit, "WIDEN_STEPS", {})                # no widening helps a frame over the bound
    assert bumpmap(["fit", str(GRAZING), "--max-lsb", "0", "--size", "32", "--quiet",
                    "--out", str(sandbox / "p")]) == 1
    err = one_error(capsys, "the best reached is", "LSB from reference (a)", "try --max-lsb")
    assert "Traceback" not in err and not (sandbox / "p" / "grazing-floor-fit.toml").exists()


def test_sigterm_ends_in_one_line(sandbox):
    """SIGTERM during a render: exit 143 and the one line 'terminated', no traceback."""
    import signal
    import subprocess
    import sys
    import time
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "tools", "render", str(TIN), str(sandbox / "x.png"), "--size",
                             "1024"], cwd=sandbox, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    time.sleep(2.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:                                # finished first on a fast machine
        pytest.skip("the render finished before the signal")
    assert proc.returncode == 143 and err.strip().splitlines()[-1] == "terminated" and "Traceback" not in err


def test_out_of_memory_is_one_line(sandbox, capsys, monkeypatch):
    """A ``MemoryError`` the limits did not prevent (numpy's allocation of a shape an input declared, before the
    eval's header check) ended in a traceback; it is one line and exit 2 like any bad input."""
    import host.render
    def boom(*args, **kwargs):
        raise MemoryError
    monkeypatch.setattr(host.render, "prepare", boom)
    assert bumpmap(["render", str(scene(sandbox)), "x.png"]) == 2
    one_error(capsys, "error: out of memory")


def test_exit_codes_page_states_the_limits_as_the_code_does():
    """``docs/exit-codes.md``'s limits table: each value is the constant it names (so the page cannot drift)."""
    import importlib
    import re
    text = (ROOT / "docs" / "exit-codes.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| [^|]+ \| ([0-9.]+) \| `([\w.]+)`(?: \(`(\w+)`\))? \|$", text, re.M)
    assert len(rows) == 15
    for value, where, key in rows:
        module, name = where.rsplit(".", 1)
        constant = getattr(importlib.import_module(module), name)
        constant = constant[key][2] if key else constant
        assert value == str(constant), (where, value, constant)
    for code in ("| 0 |", "| 1 |", "| 2 |", "| 130 |", "| 143 |"):
        assert code in text


def test_fit_whose_widening_makes_an_invalid_unit_says_so(sandbox, capsys):
    """Found by the fuzzer: texture coordinates of 1e6 made fit widen ``uv_int`` into an invalid perspective unit,
    and it ended with that unit's message ('coord_bits=22: ...'), exit 2, not saying it was fit giving up."""
    path = scene(sandbox)
    path.write_text(path.read_text() + "uv = [[0.0, 0.0], [1000000.0, 1000000.0]]\n")
    assert bumpmap(["fit", str(path), "--size", "8", "--passes", "1", "--quiet", "--out", str(sandbox / "p")]) == 1
    one_error(capsys, "fit: widened to uv_int=", "the preset is invalid", "no preset within the search's limits")
