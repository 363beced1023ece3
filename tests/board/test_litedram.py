"""The SDRAM's widths the design is built with (``board/litedram.py``) are the generated core's AXI port's
(``docs/board/litedram.json``, the record of ``bumpmap litedram``)."""

from __future__ import annotations

import json

from board.litedram import ADDR_BITS, DATA_BITS, ID_BITS, SDRAM_BYTES
from fxmodel.core.paths import ROOT


def test_the_widths_are_the_generated_ports():
    rec = json.loads((ROOT / "docs" / "board" / "litedram.json").read_text())
    for variant in ("board", "sim"):
        axi = rec[variant]["axi_port"]
        assert axi["awaddr"] == ["input", ADDR_BITS] and axi["araddr"] == ["input", ADDR_BITS]
        assert axi["wdata"] == ["input", DATA_BITS] and axi["rdata"] == ["output", DATA_BITS]
        assert axi["awid"] == ["input", ID_BITS] and axi["wstrb"] == ["input", DATA_BITS // 8]
    assert SDRAM_BYTES == 32 << 20 == 1 << ADDR_BITS


def test_the_config_for_another_clock_changes_only_the_clock():
    from board.litedram import CLOCK_LINE, CONFIG, SDRAM_HZ, config
    base = CONFIG.read_text()
    assert config(SDRAM_HZ).replace(f'"sys_clk_freq":  {SDRAM_HZ},', CLOCK_LINE) == base
    slow = config(71_428_571)
    assert slow.replace('"sys_clk_freq":  71428571,', CLOCK_LINE) == base and CLOCK_LINE not in slow


def test_a_clock_above_the_chips_or_not_an_int_is_refused():
    import pytest

    from board.litedram import SDRAM_HZ, config
    for bad in (SDRAM_HZ + 1, 0, -5, 1e8):
        with pytest.raises(ValueError, match="clk_hz"):
            config(bad)
