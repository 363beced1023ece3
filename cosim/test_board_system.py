"""The board end to end (``cosim/board_system.py``, slow: about five minutes on Verilator): the tin plane's bytes
as ``bumpmap send`` writes them into the UART, every frame answered with ACK, the decoded DVI frame equal to the
model's on every pixel and the video timing the mode's exactly."""

from __future__ import annotations

import pytest

from board.frame import BOARD_PRESET, board_engine
from cosim.board_system import simulate
from host.protocol import scene_frames


@pytest.mark.slow
def test_the_tin_plane_from_host_bytes_to_the_decoded_dvi_frame():
    params, frame, tframe = board_engine("tin-plane", BOARD_PRESET, 128)
    mat = tframe.records.matrix()
    data = b"".join(scene_frames(frame.params, params.raster.record, mat, (params.rop.width, params.rop.height)))
    rep = simulate(params, mat, data, sim="verilator")
    assert rep["shown"] and rep["acks_ok"] and not rep["error"] and not rep["overrun"]
    assert rep["mismatches"] == 0, rep["first_mismatches"]
    assert rep["timing_ok"], rep["timing"]


@pytest.mark.slow
def test_the_tin_plane_with_its_maps_in_sdram():
    """``--textures``: the maps loaded into the SDRAM by the host's TEXTURE frames and read through the texel
    caches; the whole 640 x 480 picture a tile at a time, decoded and equal to the model's on every pixel, no
    upload's word refused, no memory error."""
    import numpy as np

    from board.frame import board_picture, board_textures, tiled_color
    from host.protocol import picture_frames, upload_frames_of
    params, frame, tiles = board_picture("tin-plane", BOARD_PRESET, 128)
    params = board_textures(params, True, "sdram")
    per_tile = [(place, recs.matrix()) for place, recs in tiles]
    data = b"".join(upload_frames_of(frame.params, params) + picture_frames(params.raster.record, per_tile,
                                                                            (128, 128)))
    picture = tiled_color(params, tiles, (frame.scene.width, frame.scene.height))
    rep = simulate(params, np.concatenate([m for _, m in per_tile]), data, sim="verilator", frame="sdram",
                   picture=picture)
    assert rep["shown"] and rep["acks_ok"] and rep["state_ok"] and rep["textures"]
    assert not any(rep[k] for k in ("error", "overrun", "underrun", "mem_error", "upload_bad"))
    assert rep["mismatches"] == 0, rep["first_mismatches"]
