"""amaranth-boards' ULX3S-85F platform with the project's Amaranth: the device, the resources the board needs, and a
design on its pins prepared for the open flow (RTLIL, LPF constraints, the build script; nothing is placed)."""

from __future__ import annotations

import pytest

pytest.importorskip("amaranth_boards")

from board.ulx3s import BAUD, CLOCK_HZ, LinkProbe, platform  # noqa: E402


def plan_text(plan, name: str) -> str:
    """The file ``name`` of a prepared build plan as text (Amaranth keeps some files as bytes)."""
    text = plan.files[name]
    return text.decode() if isinstance(text, bytes) else text


def test_platform_is_the_85f_with_the_board_resources():
    p = platform()
    assert (p.device, p.package, p.default_clk) == ("LFE5U-85F", "BG381", "clk25")
    names = {name for name, _ in p.resources}
    assert {"clk25", "uart", "uart_tx_enable", "sdram", "hdmi", "led"} <= names
    assert CLOCK_HZ % BAUD == 0


def test_the_link_probe_prepares_for_the_open_flow():
    plan = platform().prepare(LinkProbe(record_len=290), name="probe")
    files = set(plan.files)
    assert {"probe.il", "probe.lpf", "build_probe.sh"} <= files
    lpf = plan_text(plan, "probe.lpf")
    assert "M1" in lpf and "L4" in lpf                     # the FTDI's rx and tx pins
