"""The board's command parser: UART bytes -> commands of the protocol in ``host/protocol.py`` (``docs/protocol.md``),
with a sticky error state. The Python reference is :func:`host.protocol.parse`; ``cosim/test_board_uart.py`` checks
this RTL against it byte for byte.

Payload bytes are passed on as they arrive (``data``, ``index``, with ``data_valid``; one per UART byte, so a
consumer never has to stall the line) and a frame takes effect at ``done``, which pulses once its CRC matched: a
triangle's consumer keeps the record until then; an upload's words are written as they arrive (a bad CRC leaves
the words it carried undefined and the error state set, and the host sends the upload again after CLEAR).

Two checks beyond the frame's form: a FRAME_START whose width and height are not the board's tile enters the error
state with ``Err.SIZE`` (after its CRC matched, so ``done`` does not pulse); an upload's command byte while a frame
is drawn (after FRAME_START until SWAP or CLEAR, or while the board's ``state`` says ``busy``: a SWAP's picture not
shown yet) enters it with ``Err.BUSY``, before any of its words is passed on. STATUS is answered with the board's
``state`` (``host.protocol.STATE_BITS``) instead of ``ACK``.
"""

from __future__ import annotations

from amaranth import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from host.protocol import ACK, CLEAR_FRAME, LENGTHS, MEMORIES, STATE_ANSWER, STATE_BITS, SYNC, Cmd, Err, crc16

__all__ = ["CommandParser", "CommandLink", "check_tile", "crc16_byte"]


def _crc_step(crc: int, byte: int) -> int:
    """One byte of :func:`host.protocol.crc16` on an arbitrary register value."""
    return crc16(bytes([byte]), crc)


def crc16_byte(crc, byte):
    """CRC-16/CCITT-FALSE after one more ``byte`` (Amaranth values of 16 and 8 bits). The byte step is linear over
    GF(2) in the 24 bits of register and byte, so each output bit is the XOR of the input bits whose unit vector
    sets it: the taps are read off :func:`host.protocol.crc16` itself, one call per input bit."""
    bits = Cat(crc, byte)
    cols = [_crc_step(1 << i, 0) for i in range(16)] + [_crc_step(0, 1 << i) for i in range(8)]
    out = []
    for j in range(16):
        taps = [bits[i] for i, col in enumerate(cols) if col >> j & 1]
        x = taps[0]
        for t in taps[1:]:
            x = x ^ t
        out.append(x)
    return Cat(*out)


def check_tile(tile):
    """``tile`` if it is ``None`` or a ``(width, height)`` FRAME_START can name (ints in 1..65535); else
    ``ValueError`` naming it."""
    if tile is not None and not (isinstance(tile, tuple) and len(tile) == 2
                                 and all(isinstance(v, int) and 1 <= v <= 0xFFFF for v in tile)):
        raise ValueError(f"tile={tile!r}: (width, height), ints in 1..65535 (FRAME_START's fields), or None")
    return tile


class CommandParser(wiring.Component):
    """Parser of the byte stream (``byte`` with ``valid``; ``framing`` from the UART). Out: ``cmd``, ``length``;
    ``data``/``index``/``data_valid`` per payload byte; ``done`` for a good frame; ``error`` (sticky) with ``code``
    (:class:`host.protocol.Err`); ``reply``/``reply_valid``: the byte the board answers (``ACK`` per good frame,
    STATUS's ``STATE_ANSWER | state``, ``0x80 | code`` on entering the error state, ``ACK`` on leaving it). In:
    ``state``, the board's :data:`host.protocol.STATE_BITS` (``sync``). ``tile``: the ``(width, height)`` a
    FRAME_START must name (:func:`host.protocol.parse`'s), or ``None`` (a board without a frame) to accept any."""

    def __init__(self, record_len: int, tile: tuple[int, int] | None = None):
        self.record_len, self.tile = record_len, check_tile(tile)
        self.lengths = LENGTHS(record_len)
        super().__init__({"byte": In(8), "valid": In(1), "framing": In(1), "state": In(len(STATE_BITS)),
                          "cmd": Out(8), "length": Out(16), "data": Out(8), "index": Out(16), "data_valid": Out(1),
                          "done": Out(1), "error": Out(1), "code": Out(3), "reply": Out(8), "reply_valid": Out(1)})

    def elaborate(self, platform):
        m = Module()
        b = self.byte
        crc, got, count = Signal(16), Signal(8), Signal(16)
        last4 = Signal(32)                              # the payload's last four bytes (FRAME_START's size), LE
        drawing = Signal()                              # after FRAME_START, until SWAP or CLEAR: no uploads
        window = Signal(8 * len(CLEAR_FRAME))
        clear = int.from_bytes(CLEAR_FRAME, "little")          # the newest byte in the high bits
        m.d.sync += [self.data_valid.eq(0), self.done.eq(0), self.reply_valid.eq(0)]
        known, upload = Signal(), Signal()
        m.d.comb += [known.eq(sum((b == c) for c in self.lengths) != 0),
                     upload.eq(sum((b == c) for c in MEMORIES) != 0)]          # TEXTURE, CUBE
        length = Cat(self.length[:8], b)                          # the length once its high byte arrives
        in_range = Signal()
        m.d.comb += in_range.eq(sum((self.cmd == c) & (length >= lo) & (length <= hi)
                                    for c, (lo, hi) in self.lengths.items()) != 0)

        def fail(code):
            m.d.sync += [self.error.eq(1), self.code.eq(code), self.reply.eq(0x80 | code), self.reply_valid.eq(1),
                         window.eq(0)]
            m.next = "error"

        with m.FSM():
            with m.State("sync"):
                with m.If(self.framing):
                    fail(Err.FRAMING)
                with m.Elif(self.valid):
                    with m.If(b == SYNC):
                        m.d.sync += crc.eq(0xFFFF)
                        m.next = "cmd"
                    with m.Else():
                        fail(Err.SYNC)
            for state, nxt in (("cmd", "len0"), ("len0", "len1"), ("len1", None), ("body", None),
                               ("crc0", "crc1"), ("crc1", None)):
                with m.State(state):
                    with m.If(self.framing):
                        fail(Err.FRAMING)
                    with m.Elif(self.valid):
                        if state in ("cmd", "len0", "len1", "body"):
                            m.d.sync += crc.eq(crc16_byte(crc, b))
                        if state == "cmd":
                            m.d.sync += self.cmd.eq(b)
                            with m.If(~known):
                                fail(Err.COMMAND)
                            with m.Elif(upload & (drawing | self.state[STATE_BITS["busy"]])):
                                fail(Err.BUSY)
                            with m.Else():
                                m.next = nxt
                        elif state == "len0":
                            m.d.sync += self.length[:8].eq(b)
                            m.next = nxt
                        elif state == "len1":
                            m.d.sync += [self.length[8:].eq(b), count.eq(0)]
                            with m.If(~in_range):
                                fail(Err.LENGTH)
                            with m.Else():
                                m.next = "body"
                                with m.If(length == 0):
                                    m.next = "crc0"
                        elif state == "body":
                            m.d.sync += [self.data.eq(b), self.index.eq(count), self.data_valid.eq(1),
                                         count.eq(count + 1), last4.eq(Cat(last4[8:], b))]
                            with m.If(count == self.length - 1):
                                m.next = "crc0"
                        elif state == "crc0":
                            m.d.sync += got.eq(b)
                            m.next = nxt
                        else:
                            with m.If(Cat(got, b) != crc):
                                fail(Err.CRC)
                            if self.tile is not None:
                                w, h = self.tile
                                with m.Elif((self.cmd == Cmd.FRAME_START) & (last4 != (w | h << 16))):
                                    fail(Err.SIZE)
                            with m.Else():
                                answer = Mux(self.cmd == Cmd.STATUS, STATE_ANSWER | self.state, ACK)
                                m.d.sync += [self.done.eq(1), self.reply.eq(answer), self.reply_valid.eq(1)]
                                with m.If(self.cmd == Cmd.FRAME_START):
                                    m.d.sync += drawing.eq(1)
                                with m.If((self.cmd == Cmd.SWAP) | (self.cmd == Cmd.CLEAR)):
                                    m.d.sync += drawing.eq(0)
                                m.next = "sync"
            with m.State("error"):
                with m.If(self.valid):
                    nwin = Cat(window[8:], b)
                    m.d.sync += window.eq(nwin)
                    with m.If(nwin == clear):
                        m.d.sync += [self.error.eq(0), self.code.eq(0), self.reply.eq(ACK), self.reply_valid.eq(1),
                                     drawing.eq(0)]
                        m.next = "sync"
        return m


class CommandLink(wiring.Component):
    """The UART link of the board: :class:`~board.uart.UartRx` -> :class:`CommandParser` -> replies through
    :class:`~board.uart.UartTx`. Ports: ``rx``, ``tx``, the parser's outputs and its ``state`` input; ``tile`` the
    parser's."""

    def __init__(self, divisor: int, record_len: int, tile: tuple[int, int] | None = None):
        self.divisor, self.record_len, self.tile = divisor, record_len, tile
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "state": In(len(STATE_BITS)),
                          "cmd": Out(8), "length": Out(16),
                          "data": Out(8), "index": Out(16), "data_valid": Out(1), "done": Out(1), "error": Out(1),
                          "code": Out(3)})

    def elaborate(self, platform):
        from amaranth.lib.fifo import SyncFIFOBuffered

        from .uart import UartRx, UartTx
        m = Module()
        m.submodules.rx = rx = UartRx(self.divisor)
        m.submodules.parser = p = CommandParser(self.record_len, self.tile)
        m.submodules.tx = tx = UartTx(self.divisor)
        # a reply is due at the stop bit of a received byte, at most one per byte, and takes as long to send as a
        # byte to receive; a small queue absorbs the one-clock slips between the two
        m.submodules.replies = q = SyncFIFOBuffered(width=8, depth=4)
        m.d.comb += [rx.rx.eq(self.rx), p.byte.eq(rx.data), p.valid.eq(rx.valid), p.framing.eq(rx.framing),
                     p.state.eq(self.state), q.w_data.eq(p.reply), q.w_en.eq(p.reply_valid),
                     self.tx.eq(tx.tx), tx.data.eq(q.r_data), tx.valid.eq(q.r_rdy), q.r_en.eq(tx.ready)]
        for name in ("cmd", "length", "data", "index", "data_valid", "done", "error", "code"):
            m.d.comb += getattr(self, name).eq(getattr(p, name))
        return m
