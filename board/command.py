"""The board's command parser: UART bytes -> commands of the protocol in ``host/protocol.py`` (``docs/protocol.md``),
with a sticky error state. The Python reference is :func:`host.protocol.parse`; ``cosim/test_board_uart.py`` checks
this RTL against it byte for byte.

Payload bytes are passed on as they arrive (``data``, ``index``, with ``data_valid``; one per UART byte, so a
consumer never has to stall the line) and a frame takes effect at ``done``, which pulses once its CRC matched: a
triangle's consumer keeps the record until then; an upload's words are written as they arrive (a bad CRC leaves
the words it carried undefined and the error state set, and the host sends the upload again after CLEAR).

Two checks beyond the frame's form: a FRAME_START whose width and height are not the board's tile, or whose column
and row lie outside the board's grid of tiles, enters the error state with ``Err.SIZE`` (after its CRC matched, so
``done`` does not pulse); an upload's command byte while a frame is drawn (after FRAME_START until SWAP, COPY or
CLEAR, or while the board's ``state`` says ``busy``: a SWAP's picture not shown yet) enters it with ``Err.BUSY``,
before any of its words is passed on; a TEXTURE frame whose memory byte names the other form of words than the
board's maps (``host.protocol.SDRAM_FORM``: the maps in SDRAM or on chip) enters it with ``Err.MAPS`` after its CRC
matched (the upload writer writes none of its words: ``board/upload.py``). STATUS is answered with the board's
``state`` (``host.protocol.STATE_BITS``) instead of ``ACK``. A FRAME_START's column and row (0, 0 in its 4-byte
form) are on ``col``, ``row`` when its ``done`` pulses.
"""

from __future__ import annotations

from amaranth import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from host.protocol import (
    ACK,
    CLEAR_FRAME,
    ENDS_TILE,
    ERROR_BITS,
    LENGTHS,
    MAPS_FORMS,
    MEMORIES,
    SDRAM_FORM,
    STATE_ANSWER,
    STATE_BITS,
    SYNC,
    Cmd,
    Err,
    check_maps,
    crc16,
)

__all__ = ["CommandParser", "CommandLink", "check_tile", "check_grid", "crc16_byte"]


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


def check_grid(grid):
    """``grid`` if it is the ``(columns, rows)`` of tiles a FRAME_START can name (ints in 1..65535); else
    ``ValueError`` naming it."""
    if not (isinstance(grid, tuple) and len(grid) == 2 and all(isinstance(v, int) and 1 <= v <= 0xFFFF
                                                                for v in grid)):
        raise ValueError(f"grid={grid!r}: (columns, rows) of tiles, ints in 1..65535 (FRAME_START's place)")
    return grid


class CommandParser(wiring.Component):
    """Parser of the byte stream (``byte`` with ``valid``; ``framing`` from the UART). Out: ``cmd``, ``length``;
    ``data``/``index``/``data_valid`` per payload byte; ``done`` for a good frame; ``error`` (sticky) with ``code``
    (:class:`host.protocol.Err`); ``reply``/``reply_valid``: the byte the board answers (``ACK`` per good frame,
    STATUS's ``STATE_ANSWER | state``, ``0x80 | code`` on entering the error state, ``ACK`` on leaving it). In:
    ``state``, the board's :data:`host.protocol.STATE_BITS` (``sync``). ``tile``: the ``(width, height)`` a
    FRAME_START must name (:func:`host.protocol.parse`'s), or ``None`` (a board without a frame) to accept any;
    ``grid``: the ``(columns, rows)`` of tiles its place must lie in; ``maps``: where the board's maps are
    (``chip``, ``sdram``: the form a TEXTURE frame must name), or ``None`` to accept either. ``col``, ``row``: a
    FRAME_START's place, valid at its ``done``."""

    def __init__(self, record_len: int, tile: tuple[int, int] | None = None, grid: tuple[int, int] = (1, 1),
                 maps: str | None = None):
        self.record_len, self.tile, self.grid = record_len, check_tile(tile), check_grid(grid)
        self.maps = check_maps(maps)
        self.lengths = LENGTHS(record_len)
        super().__init__({"byte": In(8), "valid": In(1), "framing": In(1), "state": In(len(STATE_BITS)),
                          "cmd": Out(8), "length": Out(16), "data": Out(8), "index": Out(16), "data_valid": Out(1),
                          "done": Out(1), "error": Out(1), "code": Out(ERROR_BITS), "reply": Out(8),
                          "reply_valid": Out(1),
                          "col": Out(16), "row": Out(16)})

    def elaborate(self, platform):
        m = Module()
        b = self.byte
        crc, got, count = Signal(16), Signal(8), Signal(16)
        last8 = Signal(64)                              # the payload's last eight bytes (FRAME_START's), LE
        drawing = Signal()                              # after FRAME_START, until SWAP, COPY or CLEAR: no uploads
        other_form = Signal()                           # a TEXTURE frame's memory byte names the other form
        # FRAME_START's size and place: its 4-byte form in last8's high half, its 8-byte form whole
        short = self.length == 4
        size = Mux(short, last8[32:], last8[:32])
        m.d.comb += [self.col.eq(Mux(short, 0, last8[32:48])), self.row.eq(Mux(short, 0, last8[48:]))]
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
                            m.d.sync += [self.length[8:].eq(b), count.eq(0), other_form.eq(0)]
                            with m.If(~in_range):
                                fail(Err.LENGTH)
                            with m.Else():
                                m.next = "body"
                                with m.If(length == 0):
                                    m.next = "crc0"
                        elif state == "body":
                            m.d.sync += [self.data.eq(b), self.index.eq(count), self.data_valid.eq(1),
                                         count.eq(count + 1), last8.eq(Cat(last8[8:], b))]
                            if self.maps is not None:
                                with m.If((count == 0) & (self.cmd == Cmd.TEXTURE)):
                                    m.d.sync += other_form.eq((b & SDRAM_FORM) != MAPS_FORMS[self.maps])
                            with m.If(count == self.length - 1):
                                m.next = "crc0"
                        elif state == "crc0":
                            m.d.sync += got.eq(b)
                            m.next = nxt
                        else:
                            with m.If(Cat(got, b) != crc):
                                fail(Err.CRC)
                            for refused, code in self._refusals(size, other_form):
                                with m.Elif(refused):
                                    fail(code)
                            with m.Else():
                                answer = Mux(self.cmd == Cmd.STATUS, STATE_ANSWER | self.state, ACK)
                                m.d.sync += [self.done.eq(1), self.reply.eq(answer), self.reply_valid.eq(1)]
                                with m.If(self.cmd == Cmd.FRAME_START):
                                    m.d.sync += drawing.eq(1)
                                with m.If(sum(self.cmd == c for c in ENDS_TILE) != 0):
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

    def _refusals(self, size, other_form):
        """The checks of a frame whose CRC matched, ``(condition, code)`` in turn: a FRAME_START not naming the
        board's tile at a place in its grid (``size``: its width and height), a TEXTURE frame of the other form
        than the board's maps (``other_form``, registered from its memory byte); none without a tile or maps."""
        out = []
        if self.tile is not None:
            w, h = self.tile
            placed = (size == (w | h << 16)) & (self.col < self.grid[0]) & (self.row < self.grid[1])
            out.append(((self.cmd == Cmd.FRAME_START) & ~placed, Err.SIZE))
        if self.maps is not None:
            out.append((other_form, Err.MAPS))
        return out


class CommandLink(wiring.Component):
    """The UART link of the board: :class:`~board.uart.UartRx` -> :class:`CommandParser` -> replies through
    :class:`~board.uart.UartTx`. Ports: ``rx``, ``tx``, the parser's outputs and its ``state`` input; ``tile``,
    ``grid`` and ``maps`` the parser's."""

    def __init__(self, divisor: int, record_len: int, tile: tuple[int, int] | None = None,
                 grid: tuple[int, int] = (1, 1), maps: str | None = None):
        self.divisor, self.record_len, self.tile, self.grid, self.maps = divisor, record_len, tile, grid, maps
        super().__init__({"rx": In(1, init=1), "tx": Out(1, init=1), "state": In(len(STATE_BITS)),
                          "cmd": Out(8), "length": Out(16),
                          "data": Out(8), "index": Out(16), "data_valid": Out(1), "done": Out(1), "error": Out(1),
                          "code": Out(ERROR_BITS), "col": Out(16), "row": Out(16)})

    def elaborate(self, platform):
        from amaranth.lib.fifo import SyncFIFOBuffered

        from .uart import UartRx, UartTx
        m = Module()
        m.submodules.rx = rx = UartRx(self.divisor)
        m.submodules.parser = p = CommandParser(self.record_len, self.tile, self.grid, self.maps)
        m.submodules.tx = tx = UartTx(self.divisor)
        # a reply is due at the stop bit of a received byte, at most one per byte, and takes as long to send as a
        # byte to receive; a small queue absorbs the one-clock slips between the two
        m.submodules.replies = q = SyncFIFOBuffered(width=8, depth=4)
        m.d.comb += [rx.rx.eq(self.rx), p.byte.eq(rx.data), p.valid.eq(rx.valid), p.framing.eq(rx.framing),
                     p.state.eq(self.state), q.w_data.eq(p.reply), q.w_en.eq(p.reply_valid),
                     self.tx.eq(tx.tx), tx.data.eq(q.r_data), tx.valid.eq(q.r_rdy), q.r_en.eq(tx.ready)]
        for name in ("cmd", "length", "data", "index", "data_valid", "done", "error", "code", "col", "row"):
            m.d.comb += getattr(self, name).eq(getattr(p, name))
        return m
