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
