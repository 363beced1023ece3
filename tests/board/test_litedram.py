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


def test_the_texture_port_is_the_caches_bus_beside_the_frames_port():
    """The core with the texture port keeps the first port as it was and adds a second of the texel caches' bus
    (32-bit words, the caches' ``bus_bytes``), the same address and ID bits."""
    from board.litedram import TEXTURE_DATA_BITS
    from fxmodel.units.texcache import TexCacheParams
    rec = json.loads((ROOT / "docs" / "board" / "litedram.json").read_text())
    assert TEXTURE_DATA_BITS == 8 * TexCacheParams().bus_bytes
    for variant in ("board", "sim"):
        both = rec[f"{variant}_textures"]
        assert both["axi_port"] == rec[variant]["axi_port"] and both["other_ports"] == rec[variant]["other_ports"]
        tex = both["texture_port"]
        assert tex["araddr"] == ["input", ADDR_BITS] and tex["arid"] == ["input", ID_BITS]
        assert tex["rdata"] == ["output", TEXTURE_DATA_BITS] and tex["wstrb"] == ["input", TEXTURE_DATA_BITS // 8]


def test_the_texture_config_adds_only_the_port():
    from board.litedram import PORTS_LINE, SDRAM_HZ, TEXTURE_PORT, config
    plain, tex = config(SDRAM_HZ), config(SDRAM_HZ, textures=True)
    added = tex.replace(plain.split(PORTS_LINE)[0], "", 1).replace(plain.split(PORTS_LINE)[1], "", 1)
    assert added.startswith(PORTS_LINE) and f'"{TEXTURE_PORT}"' in added and added.count("\n") == 1


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
