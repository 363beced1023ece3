"""The SDRAM bandwidth record (``board/sdram_bandwidth.py``, ``docs/board/sdram-bandwidth.json``) is what the code
computes now, and its figures are the frame's bytes at the display's rate against the board's peak."""

from __future__ import annotations

import json
from fractions import Fraction

from board.litedram import DATA_BITS, SDRAM_HZ
from board.sdram_bandwidth import record
from board.video import VGA_640x480
from fxmodel.core.paths import ROOT


def test_the_committed_record_is_current():
    rec = json.loads((ROOT / "docs" / "board" / "sdram-bandwidth.json").read_text())
    assert {k: v for k, v in rec.items() if k != "command"} == json.loads(json.dumps(record()))


def test_the_figures_are_bytes_at_the_display_rate_against_the_peak():
    rec = record()
    from board.top import DRAM_HZ
    assert DRAM_HZ <= SDRAM_HZ and rec["sdram_clock_MHz"] == DRAM_HZ / 1e6   # the board's core, not the chip's rating
    peak = Fraction(DRAM_HZ * DATA_BITS // 8)
    hz = Fraction(VGA_640x480.pixel_hz, VGA_640x480.frame_clocks)
    assert rec["sdram_peak_MBps"] == peak / 10 ** 6
    for f in rec["frames"]:
        total = 2 * f["width"] * f["height"] * 2 * hz                    # read once and written once a frame
        assert f["total_MBps"] == round(float(total / 10 ** 6), 2)
        assert f["share_of_peak"] == round(float(Fraction(str(f["total_MBps"])) * 10 ** 6 / peak), 3)
        assert f["share_of_peak"] < 1
