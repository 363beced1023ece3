"""``bumpmap animate`` (``tools/animate.py``): the frames-per-second row of a scene from its parts (the link's bytes
a frame from the protocol's frame sizes, the display's rate from the board's pixel clock, the SDRAM figure from
the frame's bytes), and the animated picture of the model's frames."""

from __future__ import annotations

import argparse

import pytest

from board.top import PIXEL_HZ
from board.video import VGA_640x480
from host.protocol import record_bytes
from tools import animate


def test_a_still_scene_row_adds_up():
    row = animate.scene_rates("berlin-wall", "default", 50e6, 1_000_000)
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tf = from_triangles(prepare(scene_path("berlin-wall"), size=(640, 480)))
    clocks = int(tf.scan.clocks.sum())
    n = len(tf.records)
    assert row["frames"] == 1 and row["triangles"] == n and row["engine_clocks_per_frame_max"] == clocks
    # SYNC, CMD, LEN (2), CRC (2) around each payload: FRAME_START's width and height, SWAP empty, a record per
    # triangle
    assert row["link_bytes_per_frame_max"] == 6 + 4 + 6 + n * (6 + record_bytes(tf.params.raster.record))
    display = PIXEL_HZ / VGA_640x480.frame_clocks
    shown = min(50e6 / clocks, 1_000_000 / 10 / row["link_bytes_per_frame_max"], display)
    assert row["shown_fps"] == round(shown, 1) and row["engine_fps"] == round(50e6 / clocks, 1)
    frame_mb = 640 * 480 * 2 / 1e6
    assert row["sdram_MBps_total"] == round(frame_mb * display + frame_mb * shown, 1)


def test_the_animation_is_written_frame_by_frame(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    ap = argparse.ArgumentParser()
    animate.add_arguments(ap)
    gif = tmp_path / "a.gif"
    args = ap.parse_args(["--size", "16", "--gif", str(gif), "--rates"])
    assert animate.run(args) == 0
    from host.scene import load_scene, scene_path
    assert iio.imread(gif).shape[:3] == (load_scene(scene_path("tin-plane")).animation.frames, 16, 16)
