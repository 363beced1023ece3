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
    """The berlin wall's row: its 640 x 480 picture in 20 tiles of 128 (five by four), each tile's records set up
    here from the picture's triangles, the clocks each tile's scan plus its clear and copy walks, the link's bytes
    each tile's FRAME_START (its place: 4 bytes more but for the first tile), records and COPY or SWAP."""
    import math

    from board.cdc import QUIET
    from board.top import DRAM_HZ
    from fxmodel.units.raster import scan
    from host.engine_setup import frame_raster, frame_records
    from host.render import prepare
    from host.scene import scene_path
    row = animate.scene_rates("berlin-wall", "default", 50e6, 1_000_000, 128)
    frame = prepare(scene_path("berlin-wall"), size=(640, 480))
    raster = frame_raster(frame)
    tiles = [frame_records(frame, raster, (x, y, 128, 128))[0] for y in range(0, 480, 128) for x in range(0, 640, 128)]
    assert len(tiles) == 20 == row["tiles"] and row["tile_records_max"] == sum(map(len, tiles))
    pixels = 128 * 128
    from board.frame import picture_tiles
    latency = picture_tiles(frame, 128)[0].rop.readout_latency
    walk = QUIET + pixels + latency + 1
    copy = max(walk, QUIET + math.ceil(pixels * 50e6 / DRAM_HZ))
    clocks = sum(int(scan(raster, t).clocks.sum()) for t in tiles) + 20 * (walk + copy)
    assert row["frames"] == 1 and row["engine_clocks_per_frame_max"] == clocks
    assert row["triangles"] == len(frame_records(frame, raster)[0])
    # SYNC, CMD, LEN (2), CRC (2) around each payload: FRAME_START's size (and place), COPY and SWAP empty, a
    # record per triangle in each tile it touches
    n = sum(map(len, tiles))
    assert row["link_bytes_per_frame_max"] == 10 + 19 * 14 + 20 * 6 + n * (6 + record_bytes(raster.record))
    display = PIXEL_HZ / VGA_640x480.frame_clocks
    shown = min(50e6 / clocks, 1_000_000 / 10 / row["link_bytes_per_frame_max"], display)
    assert row["shown_fps"] == round(shown, 1) and row["engine_fps"] == round(50e6 / clocks, 1)
    assert row["sdram_MBps_total"] == round(640 * 480 * 2 / 1e6 * display + 20 * pixels * 2 / 1e6 * shown, 1)


def test_the_animation_is_written_frame_by_frame(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    ap = argparse.ArgumentParser()
    animate.add_arguments(ap)
    gif = tmp_path / "a.gif"
    args = ap.parse_args(["--size", "16", "--gif", str(gif), "--rates"])
    assert animate.run(args) == 0
    from host.scene import load_scene, scene_path
    assert iio.imread(gif).shape[:3] == (load_scene(scene_path("tin-plane")).animation.frames, 16, 16)
