"""Co-simulation of the DVI output (``board/dvi.py``): the lanes decoded back to pixels (DVI 1.0 section 3.2) equal
the golden model's symbols and the test picture bit for bit, and the video timing read from the decoded syncs is
the mode's exactly. The serial lanes of a small mode, clock by clock; the encoders' words of a whole 640 x 480
frame at 60 Hz (slow) and of a few of its lines."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from board.video import SMALL, VGA_640x480
from cosim.board_dvi import expected_picture, measure, run


def _check(res, t, frames):
    start, want, pix = res["start"], res["want"], res["pix"]
    n = t.frame_clocks
    for k in range(frames):
        got = res["symbols"][start + k * n:start + (k + 1) * n]
        assert len(got) == n, f"frame {k}: only {len(got)} of {n} clocks recorded"
        bad = np.flatnonzero(np.any(got != want, axis=1))
        assert not len(bad), f"frame {k}: {len(bad)} symbols differ, first at clock {bad[0]}"
        frame = pix[start + k * n:start + (k + 1) * n]
        active = frame[frame[:, 0] == 1][:, 3:6].reshape(t.v_active, t.h_active, 3)
        assert np.array_equal(active, expected_picture(t))
    m = measure(pix, t)
    assert m["line_periods"] == [t.h_total] and m["hsync_widths"] == [t.h_sync]
    assert m["active_widths"] == [t.h_active] and m["vsync_widths"] == [t.v_sync * t.h_total]
    return m


def test_serial_lanes_of_a_small_mode_decode_to_the_picture(sim):
    t = SMALL
    res = run(t, serial=True, clocks=5 * t.frame_clocks, sim=sim)
    m = _check(res, t, 3)
    assert m["frame_periods"] == [t.frame_clocks] and m["lines_per_frame"] == [t.v_active]


def test_640_wide_lines_decode_to_the_picture(sim):
    """The 640 x 480 mode's line (800 clocks, 96 of negative hsync) over a few lines: every counter bit of ``x``."""
    t = dataclasses.replace(VGA_640x480, v_active=4, v_front=1, v_sync=2, v_back=1)
    res = run(t, serial=False, clocks=3 * t.frame_clocks, sim=sim)
    m = _check(res, t, 2)
    assert m["frame_periods"] == [t.frame_clocks] and m["lines_per_frame"] == [4]


@pytest.mark.slow
def test_a_whole_640x480_frame_decodes_to_the_picture(sim):
    """420 000 pixel clocks: about two minutes on Icarus (``make exhaustive`` runs it)."""
    t = VGA_640x480
    res = run(t, serial=False, clocks=t.frame_clocks + (t.v_total - t.v_active + 1) * t.h_total, sim=sim)
    m = _check(res, t, 1)
    assert m["frame_periods"] == [t.frame_clocks]
