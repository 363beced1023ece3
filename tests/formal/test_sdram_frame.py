"""The frame in SDRAM's AXI4 port (``formal/sdram_frame.py``): the bounded check passes and its covers are reached
(a copy finished, a read burst finished), and the frame without the last write in its read room (the bug the
check found: ``ARVALID`` falling before ``ARREADY``) fails it on ``ar_hold`` with a waveform."""

from __future__ import annotations

import pytest

from formal.runner import Job, run_job, tools_missing
from formal.sdram_frame import DEPTH, TILE, sdram_frame_set
from fxmodel.core.paths import build_dir

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(tools_missing() is not None, reason=str(tools_missing()))]
OUT = build_dir("formal", "test")


def test_the_port_keeps_the_axi4_rules_and_reaches_its_covers():
    h = sdram_frame_set("proof")
    res = run_job(Job("sdram_frame_bmc", h.m, h.ports, "bmc", DEPTH), OUT)
    assert res.status == "PASS", res
    h = sdram_frame_set("cover")
    res = run_job(Job("sdram_frame_cover", h.m, h.ports, "cover", 40), OUT)
    assert res.status == "PASS" and set(h.covered) == {"copy_reach", "read_burst_reach"}, res


def test_the_read_room_without_the_last_write_is_caught():
    h = sdram_frame_set("proof", broken=True)
    res = run_job(Job("sdram_frame_broken", h.m, h.ports, "bmc", DEPTH), OUT)
    assert res.status == "FAIL" and "ar_hold" in res.failed and res.traces, res


def test_a_tile_at_a_time_keeps_the_rules_and_its_bursts_at_their_places():
    """The frame copied a tile at a time (the place and ``show`` free every clock): the same checks, each ``AW``
    inside the grid of tiles, a tile's words all written before ``copied``."""
    h = sdram_frame_set("proof", tile=TILE)
    res = run_job(Job("sdram_frame_tiled_bmc", h.m, h.ports, "bmc", DEPTH), OUT)
    assert res.status == "PASS", res
    h = sdram_frame_set("cover", tile=TILE)
    res = run_job(Job("sdram_frame_tiled_cover", h.m, h.ports, "cover", 40), OUT)
    assert res.status == "PASS" and set(h.covered) == {"copy_reach", "read_burst_reach"}, res
