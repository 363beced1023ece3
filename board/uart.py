"""UART receiver and transmitter (8 data bits, no parity, one stop bit), ``divisor`` clocks a bit: the board's link to
the host (``docs/protocol.md``)."""

from __future__ import annotations

from amaranth import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = ["UartRx", "UartTx"]


class UartRx(wiring.Component):
    """``rx`` (idle high) -> ``data`` with a one-clock ``valid``; ``framing`` pulses instead when the stop bit is
    low. The line is taken through two registers (it comes from another clock); bits are sampled mid-bit, timed
    from the start bit's falling edge."""

    def __init__(self, divisor: int):
        if divisor < 4:
            raise ValueError(f"UART divisor {divisor}: at least 4 clocks a bit")
        self.divisor = divisor
        super().__init__({"rx": In(1, init=1), "data": Out(8), "valid": Out(1), "framing": Out(1)})

    def elaborate(self, platform):
        m = Module()
        d = self.divisor
        s1, line = Signal(init=1), Signal(init=1)
        m.d.sync += [s1.eq(self.rx), line.eq(s1), self.valid.eq(0), self.framing.eq(0)]
        timer = Signal(range(d + d // 2 + 1))
        bit = Signal(range(10))
        shift = Signal(8)
        with m.FSM():
            with m.State("idle"):
                with m.If(~line):
                    m.d.sync += [timer.eq(d + d // 2 - 1), bit.eq(0)]   # to the middle of data bit 0
                    m.next = "bits"
            with m.State("bits"):
                with m.If(timer != 0):
                    m.d.sync += timer.eq(timer - 1)
                with m.Elif(bit == 8):                                      # the stop bit
                    m.d.sync += [self.data.eq(shift), self.valid.eq(line), self.framing.eq(~line)]
                    m.next = "idle"
                with m.Else():
                    m.d.sync += [shift.eq((line << 7) | (shift >> 1)),
                                 bit.eq(bit + 1), timer.eq(d - 1)]
        return m


class UartTx(wiring.Component):
    """``data`` with ``valid`` (held until ``ready``) -> ``tx``, idle high."""

    def __init__(self, divisor: int):
        self.divisor = divisor
        super().__init__({"tx": Out(1, init=1), "data": In(8), "valid": In(1), "ready": Out(1)})

    def elaborate(self, platform):
        m = Module()
        d = self.divisor
        timer = Signal(range(d))
        frame = Signal(10, init=0x3FF)
        left = Signal(range(11))
        m.d.comb += [self.ready.eq(left == 0), self.tx.eq(frame[0])]
        with m.If(left == 0):
            with m.If(self.valid):
                m.d.sync += [frame.eq((self.data << 1) | (1 << 9)), left.eq(10), timer.eq(d - 1)]
        with m.Elif(timer == 0):
            m.d.sync += [frame.eq((frame >> 1) | (1 << 9)), left.eq(left - 1), timer.eq(d - 1)]
        with m.Else():
            m.d.sync += timer.eq(timer - 1)
        return m
