"""The board's bandwidth record (``docs/board/budget.json``) is what ``bumpmap board-budget`` computes now, and its
figures are the arithmetic they claim."""

from __future__ import annotations

import json

from board.budget import budget
from fxmodel.core.paths import ROOT


def test_committed_record_is_current():
    record = json.loads((ROOT / "docs" / "board" / "budget.json").read_text())
    record.pop("command")
    assert record == budget(engine_mhz=110.0, tile=32)


def test_figures():
    b = budget()
    assert b["sdram_peak_MBps"] == 200.0
    assert abs(b["scanout_MBps"] - 640 * 480 * 2 * 25.175e6 / (800 * 525) / 1e6) < 0.05
    assert b["drawing_MBps_compact"] == 110 * 6
    assert abs(b["direct_fb_Mpx_per_s_compact_at_peak"] - (200 - b["scanout_MBps"]) / 6) < 0.1
