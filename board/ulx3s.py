"""The ULX3S-85F through ``amaranth-boards`` (``amaranth_boards.ulx3s.ULX3S_85F_Platform``): the UART command link on
the FTDI's pins and its error flag on a LED, a first design the board build elaborates (the board top with the PLL,
display and memory controller comes next: ``docs/board.md``)."""

from __future__ import annotations

from amaranth import Elaboratable, Module
from amaranth.lib import io

from .command import CommandLink

__all__ = ["platform", "LinkProbe", "wire_link", "CLOCK_HZ", "BAUD"]

#: The design's clock (the 25 MHz oscillator; the pixel clock in the board top) and the UART's rate: 1 MBd divides
#: both 25 MHz (25 clocks a bit) and the FTDI chip's 3 MHz baud base exactly.
CLOCK_HZ, BAUD = 25_000_000, 1_000_000


def platform():
    """The ULX3S-85F platform (raises ``ModuleNotFoundError`` naming ``amaranth_boards`` when not installed)."""
    from amaranth_boards.ulx3s import ULX3S_85F_Platform
    return ULX3S_85F_Platform()


class LinkProbe(Elaboratable):
    """The command link on the UART pins (``uart_tx_enable`` high), LED 0 on while in the error state, LED 1 flashing
    with each good frame."""

    def __init__(self, record_len: int):
        self.record_len = record_len

    def elaborate(self, platform):
        m = Module()
        m.submodules.link = link = CommandLink(CLOCK_HZ // BAUD, self.record_len)
        wire_link(m, platform, link)
        return m


def wire_link(m: Module, platform, link: CommandLink) -> None:
    """Put ``link`` on the FTDI UART's pins (``uart_tx_enable`` high), its error flag on LED 0 and a toggle per good
    frame on LED 1, in the ``sync`` domain of ``m``."""
    uart = platform.request("uart", 0, dir="-")
    bufs = {"rx": io.Buffer("i", uart.rx), "tx": io.Buffer("o", uart.tx),
            "tx_en": io.Buffer("o", platform.request("uart_tx_enable", 0, dir="-")),
            "led0": io.Buffer("o", platform.request("led", 0, dir="-")),
            "led1": io.Buffer("o", platform.request("led", 1, dir="-"))}
    for name, buf in bufs.items():
        m.submodules[name] = buf
    m.d.comb += [link.rx.eq(bufs["rx"].i), bufs["tx"].o.eq(link.tx), bufs["tx_en"].o.eq(1),
                 bufs["led0"].o.eq(link.error)]
    with m.If(link.done):
        m.d.sync += bufs["led1"].o.eq(~bufs["led1"].o)
