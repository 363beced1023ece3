"""Overlapping geometry drawn from triangles (host/visibility.py): the fixed-point depth test (the raster-operations
unit's model) against the float z-buffer of reference (a) on the overlapping shipped scene: depth disagreements only
within the documented depth precision, counted, left out of the LSB comparison, marked in a picture; the report's
depth and memory figures consistent with each other and with the frame."""

import numpy as np
import pytest

from fxmodel.units.raster import RasterParams
from host.render import from_triangles, judge, prepare, render_triangles
from host.visibility import first_max, resolve
from tools.main import main as bumpmap

SCENE = "scenes/tin-sphere.toml"


@pytest.fixture(scope="module")
def tframe():
    return from_triangles(prepare(SCENE, size=160, cube_size=16))


def test_first_max_is_the_z_buffer_rule():
    pixel = np.array([3, 1, 3, 1, 3, 2])
    value = np.array([5, 2, 7, 2, 7, 0])
    # pixel 1: a tie, the first drawn (index 1) keeps it; pixel 3: 7 beats 5, the first 7 (index 2) keeps it
    assert first_max(pixel, value).tolist() == [1, 5, 2]


def test_overlapping_scene_from_triangles(tframe, tmp_path):
    frame, vis = tframe.frame, tframe.vis
    report = render_triangles(tframe, tmp_path)
    report.pop("_triangle_bytes")
    depth, memory = report["depth"], report["memory"]
    # real overdraw, counted consistently
    assert depth["passed"] + depth["failed"] == depth["fragments"] == len(tframe.scan)
    assert depth["covered_pixels"] == len(frame.frags) == len(vis.pixel)
    assert depth["overdraw"] == pytest.approx(depth["fragments"] / depth["covered_pixels"], abs=1e-4)
    assert depth["overdraw"] > 1.2 and depth["failed"] > 0.1 * depth["fragments"]
    assert depth["passed"] >= depth["covered_pixels"]                   # each covered pixel passes at least once
    assert depth["early_depth"]["shaded_early"] == depth["passed"]
    assert memory["bytes_read_per_pixel"] == pytest.approx(memory["bytes_read"] / depth["covered_pixels"], 1e-3)
    assert memory["bytes_written_per_pixel"] == pytest.approx(memory["bytes_written"] / depth["covered_pixels"],
                                                             1e-3)
    assert memory["bytes_written"] > 0 and memory["bytes_read"] > 0
    # depth disagreements: present (the tile crossing the floor), all within the documented precision
    precision = float(RasterParams.PRESETS["default"].depth_precision())
    assert depth["precision"] == precision
    assert depth["disagreements"] == int(vis.disagree.sum()) > 0
    assert 0 < depth["max_depth_gap_of_disagreements"] <= precision
    assert depth["problems"] == []
    # left out of the comparison with (a), and counted in the verdict
    assert report["max_lsb_vs_float_well_conditioned"] <= 1
    assert judge(report) == [] and report["verdict"]["depth_disagreements"] == depth["disagreements"]
    # the frame shows the fragment each pixel keeps; the picture marks every disagreement in red
    from PIL import Image
    pic = np.asarray(Image.open(tmp_path / "depth_disagreements.png").convert("RGB")).astype(int)
    red = (pic[..., 0] == 255) & (pic[..., 1] == 0) & (pic[..., 2] == 0)
    assert red.sum() == 4 * depth["disagreements"]                      # each pixel 2 x 2 at the picture's scale


def test_a_disagreement_beyond_the_precision_fails_the_verdict(tframe, monkeypatch):
    """With a precision claimed a hundred times finer than the proof's, the same disagreements are beyond it: the
    verdict must fail and say so (it must never pass a frame it knows is wrong)."""
    true = RasterParams.depth_precision
    monkeypatch.setattr(RasterParams, "depth_precision", lambda self, name="Z": true(self, name) / 100)
    vis = resolve(tframe)
    assert vis.problems and "fixed-point depth is wrong" in vis.problems[0]
    monkeypatch.setattr(tframe, "vis", vis)
    report = render_triangles(tframe)
    assert judge(report) and not report["verdict"]["pass"]


def test_outputs_not_in_the_scan_order_are_refused(tframe):
    out = tframe.out.copy()
    out[[0, 1]] = out[[1, 0]]
    if np.array_equal(out, tframe.out):
        out[0, 0] += 1
    with pytest.raises(ValueError, match="not the scan's"):
        resolve(tframe, out)


def test_the_rtl_frame_is_resolved_like_the_model(tframe):
    """The RTL's outputs (equal to the model's, in the same order) give the same frame; a changed color of a
    winning fragment shows in the frame, one of a losing fragment does not."""
    vis = resolve(tframe, tframe.out)
    assert np.array_equal(vis.winner, tframe.vis.winner)
    rgb = tframe.out[:, 2:5].astype(np.uint8).copy()
    lost = np.setdiff1d(np.arange(len(rgb)), vis.winner)[0]
    rgb[lost] = 255 - rgb[lost]
    assert np.array_equal(tframe.image(rgb), tframe.image(tframe.out[:, 2:5].astype(np.uint8)))
    rgb[vis.winner[0]] = 255 - rgb[vis.winner[0]]
    assert not np.array_equal(tframe.image(rgb), tframe.image(tframe.out[:, 2:5].astype(np.uint8)))


def test_make_sim_from_triangles_reports_depth_and_memory(monkeypatch, tmp_path, capsys):
    """``make sim INPUT=triangles`` on the overlapping scene: report.json has the depth and memory sections and
    the verdict; the summary table prints them. The RTL run is replaced by the model's outputs here (the
    co-simulation tests run the RTL)."""
    import json

    import cosim.sim as sim

    class FakeResult(dict):
        ok = True

        def describe(self):
            return ""

    def fake_run_records(params, inputs, expected, counts, clocks=None, **kw):
        res = FakeResult(mismatches=0, first=[], seconds=1.0, sim_cpu_seconds=1.0, cycles=int(clocks.sum()),
                         busy_cycles=int(clocks.sum()), build_seconds=0.0, shards=[[0, len(counts)]],
                         shard_busy_cycles=[int(clocks.sum())])
        res.rtl = np.asarray(expected)
        return res

    monkeypatch.setattr(sim, "run_records", fake_run_records)
    monkeypatch.setenv("BUMPMAP_BUILD", str(tmp_path / "build"))
    argv = ["--scene", "tin-sphere", "--size", "96", "--cube-size", "8", "--input", "triangles", "--sim", "icarus"]
    assert bumpmap(["sim", *argv]) == 0
    table = capsys.readouterr().out
    assert "overdraw" in table and "depth disagreements" in table and "memory / pixel" in table
    out = sim.output_folder(argv)
    assert out.parent == tmp_path / "build" / "sim" and out.name.startswith("tin-sphere-")
    report = json.loads((out / "report.json").read_text())
    d, m = report["depth"], report["memory"]
    assert set(d) >= {"fragments", "passed", "failed", "overdraw", "disagreements",
                      "max_depth_gap_of_disagreements", "precision"}
    assert set(m) >= {"bytes_read_per_pixel", "bytes_written_per_pixel"}
    assert d["passed"] + d["failed"] == d["fragments"] == report["fragments"]
    assert d["max_depth_gap_of_disagreements"] <= d["precision"] and report["verdict"]["pass"]
    assert (out / "depth_disagreements.png").exists() and (out / "rtl.png").exists()


def test_depth_tool_table_and_picture(tmp_path, capsys):
    """``bumpmap depth`` (the README's memory-traffic table and picture): its rows agree with the frame's
    own counts, and the drawing order matters (the reversed order fails other fragments)."""
    import json

    pic = tmp_path / "depth.png"
    assert bumpmap(["depth", "--scenes", "tin-sphere", "--size", "128", "--json", "--picture", str(pic)]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["overdraw"] == pytest.approx(row["fragments"] / row["covered_pixels"], abs=1e-4)
    assert row["early_depth_saves"] == pytest.approx(row["failed"] / row["fragments"], abs=1e-4)
    assert 0 < row["failed_reversed_order"] != row["failed"]
    from fxmodel.units.rop import DEPTH_BYTES
    read = row["bytes_read_per_pixel"] * row["covered_pixels"]
    assert read == pytest.approx(DEPTH_BYTES * row["fragments"], rel=1e-3)
    assert pic.exists() and pic.stat().st_size > 1000
    assert bumpmap(["depth", "--scenes", "nope"]) == 2
