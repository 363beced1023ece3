"""The board's frame in SDRAM (``docs/board.md``): two buffers of RGB565 words behind LiteDRAM's AXI4 user port,
the finished tile copied into the back one with AXI write bursts, the front one read line by line with AXI read
bursts into a line FIFO ahead of the display's scan-out (paper, section 4 and Fig. 5: the engine's colors go to a
frame buffer, which the display reads).

Clock domains: ``dram`` is LiteDRAM's user clock (the AXI port, the copy, the scan-out's fetch; on the board the
engine's clock, which LiteDRAM's core takes as its own), ``sync`` the pixel clock (the display). The line FIFO is an
:class:`amaranth.lib.fifo.AsyncFIFO` from ``dram`` to ``sync``.

Layout (:class:`FrameLayout`): pixel ``(x, y)`` of buffer ``b`` at byte ``base + b buffer_bytes + y pitch + 2 x``,
``pitch`` and ``buffer_bytes`` powers of two (no multiplier). A line is moved in bursts of up to ``burst`` beats
(one 16-bit pixel a beat, ``INCR``, ``AxSIZE = 1``) starting at multiples of ``burst`` pixels: no burst crosses a
4 KB page.

- **Copy** (:class:`SdramFrame` ``i``: a tile's ``tile_width tile_height`` words in raster order, by default the
  whole frame's): the tile's place in the frame's grid of tiles (``col``, ``row``) and whether the copy shows the
  buffer (``show``) are taken when its first word is offered (the writer holds them from before that word until
  the copy's end); ``AW`` for each burst of the tile's place in the back buffer (at most :data:`AW_AHEAD` ahead of
  the data), ``W`` beats straight from ``i`` (only for bursts whose ``AW`` was taken), ``B`` always taken; when
  every burst's ``B`` is in, the copy is done (``copied``); a copy with ``show`` then waits (``i`` not ready) until
  the buffer has been shown, one without it leaves the buffer to the picture's next tile.
- **Scan-out**: at the start of each vertical blanking the pixel clock's side toggles ``frame``; the fetch, once its
  previous frame's reads are all in, makes the finished copy (if any) the front buffer there (no tearing: the
  buffer shown changes only between frames, and the copy never writes the buffer being read), then reads the front
  buffer's ``width height`` words in bursts, each ``AR`` only while the FIFO has room for every beat owed. Before
  the first copy the fetch writes black words without reading. The display takes one word a pixel inside the frame
  (black outside); a word not there in time (``underrun``, sticky) is owed and dropped when it comes, so every
  frame takes exactly its ``width height`` words and the next starts aligned.
- ``error`` (sticky, ``dram``): an ``SLVERR``/``DECERR`` response on ``B`` or ``R``.
"""

from __future__ import annotations

import dataclasses

from amaranth import Module, Mux, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import In, Out

from rtl.fixed import const_mul
from rtl.rop import axi_signature

from .litedram import ADDR_BITS, DATA_BITS, ID_BITS

__all__ = ["FrameLayout", "SdramFrame", "tile_grid", "AW_AHEAD", "LATENCY", "FIFO_DEPTH", "bandwidth"]

#: Write bursts whose ``AW`` may be taken before their data (LiteDRAM's AXI port queues addresses).
AW_AHEAD = 2
#: Words of the line FIFO (a DP16KD's 1 024 x 18: more than a line of 640 ahead of the scan-out).
FIFO_DEPTH = 1024
#: Pixel clocks from the display's ``x``, ``y`` to :attr:`SdramFrame.color` (the pop, the registered word).
LATENCY = 2


def tile_grid(width: int, height: int, tile_width: int, tile_height: int) -> tuple[int, int]:
    """The ``(columns, rows)`` of ``tile_width x tile_height`` tiles that cover a ``width x height`` picture (the
    last column and row cut by its edge)."""
    return -(-width // tile_width), -(-height // tile_height)


def _pow2(n: int) -> int:
    return 1 << max(0, (n - 1).bit_length())


@dataclasses.dataclass(frozen=True)
class FrameLayout:
    """Two ``width x height`` buffers of 16-bit words in SDRAM from byte ``base``; bursts of up to ``burst`` beats.

    Derived: ``pitch`` (bytes a line: the power of two at least ``2 width``), ``buffer_bytes`` (``pitch`` times the
    power of two at least ``height``), ``bursts_per_line``, ``bursts`` (a frame's), ``pixels``."""

    width: int
    height: int
    base: int = 0
    burst: int = 64

    def __post_init__(self):
        for name in ("width", "height", "burst"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise ValueError(f"FrameLayout.{name}={v!r}: must be a positive integer")
        if self.burst > 256 or self.burst & (self.burst - 1):
            raise ValueError(f"FrameLayout.burst={self.burst}: must be a power of two of at most 256 (AXI4 INCR)")
        if self.base < 0 or self.base % self.pitch:
            raise ValueError(f"FrameLayout.base={self.base}: must be a non-negative multiple of the pitch "
                             f"({self.pitch} bytes)")
        if self.base + 2 * self.buffer_bytes > 1 << ADDR_BITS:
            raise ValueError(f"two {self.width}x{self.height} buffers from byte {self.base} exceed the SDRAM's "
                             f"{1 << ADDR_BITS} bytes")

    @property
    def beat_bytes(self) -> int:
        return DATA_BITS // 8

    @property
    def pitch(self) -> int:
        return _pow2(self.beat_bytes * self.width)

    @property
    def buffer_bytes(self) -> int:
        return self.pitch * _pow2(self.height)

    @property
    def bursts_per_line(self) -> int:
        return -(-self.width // self.burst)

    @property
    def bursts(self) -> int:
        return self.bursts_per_line * self.height

    @property
    def pixels(self) -> int:
        return self.width * self.height

    def address(self, buffer: int, y: int, x: int) -> int:
        """Byte address of pixel ``(x, y)`` of ``buffer``."""
        return self.base + buffer * self.buffer_bytes + y * self.pitch + self.beat_bytes * x

    def burst_list(self, buffer: int) -> list[tuple[int, int]]:
        """``(address, beats)`` of a frame's bursts in order."""
        return [(self.address(buffer, y, x), min(self.burst, self.width - x))
                for y in range(self.height) for x in range(0, self.width, self.burst)]


def bandwidth(layout: FrameLayout, timing, frames_copied_per_s: float) -> dict:
    """The SDRAM traffic of the frame in bytes a second: the scan-out reads the front buffer every display frame,
    each copy writes one buffer."""
    frame_bytes = layout.pixels * layout.beat_bytes
    scan = frame_bytes * timing.frame_hz
    copy = frame_bytes * frames_copied_per_s
    return {"frame_bytes": frame_bytes, "scanout_MBps": round(scan / 1e6, 2), "copy_MBps": round(copy / 1e6, 2),
            "total_MBps": round((scan + copy) / 1e6, 2)}


class _Bursts:
    """A walk over a frame's bursts: ``y`` and the burst's first pixel ``x`` (a multiple of ``burst``); ``beats``
    the current burst's; ``step()`` the statements to the next one; ``last`` at the frame's last burst."""

    def __init__(self, layout: FrameLayout, name: str):
        self.L = layout
        self.x = Signal(range(max(2, layout.width + layout.burst)), name=f"{name}_x")
        self.y = Signal(range(max(2, layout.height)), name=f"{name}_y")
        rest = layout.width - self.x
        self.beats = Mux(rest < layout.burst, rest, layout.burst)
        self.line_end = self.x + layout.burst >= layout.width
        self.last = self.line_end & (self.y == layout.height - 1)

    def step(self):
        return [self.x.eq(Mux(self.line_end, 0, self.x + self.L.burst)),
                self.y.eq(Mux(self.line_end, Mux(self.last, 0, self.y + 1), self.y))]

    def reset(self):
        return [self.x.eq(0), self.y.eq(0)]

    def address(self, buffer, frame: FrameLayout | None = None, x0=0, y0=0):
        """The burst's byte address in ``buffer`` of ``frame`` (default the walk's own layout), the walk's pixel
        ``(x, y)`` at ``(x0 + x, y0 + y)`` of the frame (shifts by the powers of two, no multiplier)."""
        L = self.L if frame is None else frame
        shift = (L.beat_bytes - 1).bit_length()
        return (L.base + ((x0 + self.x) << shift) + ((y0 + self.y) << (L.pitch - 1).bit_length())
                + (buffer << (L.buffer_bytes - 1).bit_length()))[:ADDR_BITS]


class SdramFrame(wiring.Component):
    """The double-buffered frame behind an AXI4 port (module docstring).

    Ports: ``i`` (``dram``; the copy's words, RGB565), ``col``, ``row``, ``show`` (the copy's place and whether it
    shows the buffer: held by the writer from before the copy's first word until its end, taken with that word),
    ``copied`` (``dram``: a pulse when a copy's last ``B`` is in), ``mem`` (the AXI4 manager, ``dram``), ``error``
    (``dram``, sticky), ``x``, ``y`` (``sync``: the display's position; ``color``, the word there, :data:`LATENCY`
    clocks later, 0 outside the frame), ``front`` (``sync``: the buffer shown, through a synchroniser),
    ``underrun`` (``sync``, sticky). ``tile``: the copy's ``(width, height)``, default the frame's; the frame's
    grid of tiles (``grid``: columns and rows, the last ones cut by the frame's edge) must fit its buffer's pitch
    and lines, and a tile's width must be a multiple of the burst unless the grid has one column (so that no burst
    crosses a line). ``count_last_write=False`` leaves the last clock's FIFO write out of the read's room
    (``ARVALID`` may then fall before ``ARREADY``): only for the test that shows the formal check catches it.
    """

    def __init__(self, layout: FrameLayout, timing, fifo_depth: int = FIFO_DEPTH, count_last_write: bool = True,
                 tile: tuple[int, int] | None = None):
        if layout.width > timing.h_active or layout.height > timing.v_active:
            raise ValueError(f"the {layout.width}x{layout.height} frame exceeds the display's "
                             f"{timing.h_active}x{timing.v_active}")
        if fifo_depth < 2 * layout.burst:
            raise ValueError(f"fifo_depth={fifo_depth}: must hold two bursts ({2 * layout.burst} words)")
        tw, th = (layout.width, layout.height) if tile is None else tile
        self.tile = FrameLayout(tw, th, burst=layout.burst)
        self.grid = tile_grid(layout.width, layout.height, tw, th)
        cols, rows = self.grid
        if cols * tw * layout.beat_bytes > layout.pitch or rows * th * layout.pitch > layout.buffer_bytes:
            raise ValueError(f"the {cols}x{rows} tiles of {tw}x{th} exceed the {layout.width}x{layout.height} "
                             f"frame's buffer ({layout.pitch} bytes a line, {layout.buffer_bytes // layout.pitch} "
                             "lines)")
        if cols > 1 and tw % layout.burst:
            raise ValueError(f"tile width {tw}: a multiple of the burst ({layout.burst} beats) when the frame has "
                             f"{cols} columns of tiles")
        self.layout, self.timing, self.fifo_depth = layout, timing, fifo_depth
        self.count_last_write = count_last_write        # False: the bug formal/sdram_frame.py must catch
        super().__init__({"i": In(stream.Signature(DATA_BITS)), "col": In(range(cols)), "row": In(range(rows)),
                          "show": In(1, init=1), "copied": Out(1),
                          "mem": Out(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "error": Out(1),
                          "x": In(range(timing.h_total)), "y": In(range(timing.v_total)),
                          "color": Out(DATA_BITS), "front": Out(1), "underrun": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.fifo = fifo = AsyncFIFO(width=DATA_BITS, depth=self.fifo_depth, w_domain="dram",
                                             r_domain="sync")
        front, done = Signal(), Signal()         # dram: the buffer scanned out; a copy waits to be shown
        self._copy(m, front, done)
        self._fetch(m, fifo, front, done)
        self._scan(m, fifo)
        m.submodules.front_ff = FFSynchronizer(front, self.front, o_domain="sync")
        axi = self.mem
        with m.If((axi.bvalid & axi.bresp.any()) | (axi.rvalid & axi.rready & axi.rresp.any())):
            m.d.dram += self.error.eq(1)
        return m

    def _copy(self, m, front, done):
        """The write side: the copy's place and ``show`` taken with its first word, then ``AW`` per burst of the
        tile's place in the back buffer, ``W`` from ``i``, ``B`` counted."""
        L, T, axi = self.layout, self.tile, self.mem
        aw, w = _Bursts(T, "aw"), _Bursts(T, "w")
        ahead = Signal(range(AW_AHEAD + 1))               # bursts whose AW is taken and whose data is not all sent
        aw_left = Signal(range(T.bursts + 1), init=T.bursts)   # bursts of this copy still to address
        b_left = Signal(range(T.bursts + 1), init=T.bursts)
        beat = Signal(range(L.burst + 1))
        started, show = Signal(), Signal()                # the copy's place and show taken
        x0 = Signal(range(max(2, self.grid[0] * T.width)), name="copy_x0")
        y0 = Signal(range(max(2, self.grid[1] * T.height)), name="copy_y0")
        active = ~done & started
        with m.If(~done & ~started & self.i.valid):
            m.d.dram += [started.eq(1), show.eq(self.show), x0.eq(const_mul(self.col, T.width)),
                         y0.eq(const_mul(self.row, T.height))]
        m.d.comb += [axi.awid.eq(0), axi.awaddr.eq(aw.address(~front, L, x0, y0)), axi.awlen.eq(aw.beats - 1),
                     axi.awsize.eq((L.beat_bytes - 1).bit_length()), axi.awburst.eq(1),
                     axi.awvalid.eq(active & (aw_left != 0) & (ahead < AW_AHEAD)), axi.bready.eq(1)]
        aw_go = axi.awvalid & axi.awready
        wlast = beat + 1 == w.beats
        m.d.comb += [axi.wdata.eq(self.i.payload), axi.wstrb.eq((1 << L.beat_bytes) - 1), axi.wlast.eq(wlast),
                     axi.wvalid.eq(active & (ahead != 0) & self.i.valid), self.i.ready.eq(axi.wvalid & axi.wready)]
        w_go = axi.wvalid & axi.wready
        burst_sent = w_go & wlast
        m.d.dram += ahead.eq(ahead + aw_go - burst_sent)
        with m.If(aw_go):
            m.d.dram += [aw_left.eq(aw_left - 1), *aw.step()]
        with m.If(w_go):
            m.d.dram += beat.eq(Mux(wlast, 0, beat + 1))
        with m.If(burst_sent):
            m.d.dram += w.step()
        b_go = axi.bvalid & axi.bready
        with m.If(b_go):
            m.d.dram += b_left.eq(b_left - 1)
            with m.If(b_left == 1):                       # the copy's last response: its tile is in the buffer
                m.d.dram += [done.eq(show), started.eq(0), aw_left.eq(T.bursts), b_left.eq(T.bursts)]
        m.d.comb += self.copied.eq(b_go & (b_left == 1))

    def _fetch(self, m, fifo, front, done):
        """The read side: at each frame toggle (once the last frame's reads are in) swap in a finished copy, then
        ``AR`` per burst of the front buffer while the FIFO has room for every beat owed; black before the first
        copy."""
        L, axi = self.layout, self.mem
        frame_req = Signal()                              # sync: a toggle at each vertical blanking's start
        with m.If((self.x == 0) & (self.y == self.timing.v_active)):
            m.d.sync += frame_req.eq(~frame_req)
        req_s, req_last = Signal(), Signal()
        m.submodules.frame_ff = FFSynchronizer(frame_req, req_s, o_domain="dram")
        m.d.dram += req_last.eq(req_s)
        pending, fetching, blank, shown_any = Signal(), Signal(), Signal(), Signal()
        with m.If(req_s ^ req_last):
            m.d.dram += pending.eq(1)
        ar = _Bursts(L, "ar")
        owed = Signal(range(self.fifo_depth + 1))         # beats of taken ARs not yet in the FIFO
        ar_open = Signal(range(self.fifo_depth + 1))      # bursts taken and not finished
        blank_left = Signal(range(L.pixels + 1))
        # the FIFO's words: its ``w_level`` counts a write two clocks later (its write pointer and the level are
        # registers), so the word written in the last clock is counted here; then the sum only falls (reads)
        # until the next AR, and ARVALID, once up, stays up until taken (formal/sdram_frame.py)
        room, wrote = Signal(), Signal()
        m.d.comb += room.eq(fifo.w_level + wrote + owed + L.burst <= self.fifo_depth)
        m.d.comb += [axi.arid.eq(0), axi.araddr.eq(ar.address(front)), axi.arlen.eq(ar.beats - 1),
                     axi.arsize.eq((L.beat_bytes - 1).bit_length()), axi.arburst.eq(1),
                     axi.arvalid.eq(fetching & ~blank & room), axi.rready.eq(fifo.w_rdy)]
        ar_go = axi.arvalid & axi.arready
        r_go = axi.rvalid & axi.rready
        blank_go = blank & (blank_left != 0) & fifo.w_rdy
        m.d.comb += [fifo.w_en.eq(r_go | blank_go), fifo.w_data.eq(Mux(blank, 0, axi.rdata))]
        if self.count_last_write:
            m.d.dram += wrote.eq(fifo.w_en & fifo.w_rdy)
        m.d.dram += [owed.eq(owed + Mux(ar_go, ar.beats, 0) - r_go),
                     ar_open.eq(ar_open + ar_go - (r_go & axi.rlast))]
        with m.If(ar_go):
            m.d.dram += ar.step()
            with m.If(ar.last):
                m.d.dram += fetching.eq(0)
        with m.If(blank_go):
            m.d.dram += blank_left.eq(blank_left - 1)
        idle = ~fetching & (ar_open == 0) & (blank_left == 0)
        with m.If(pending & idle):
            # between frames: no read of either buffer outstanding, so the finished copy can become the front
            m.d.dram += [pending.eq(0), fetching.eq(shown_any | done), blank.eq(~(shown_any | done)),
                         *ar.reset()]
            with m.If(~(shown_any | done)):
                m.d.dram += blank_left.eq(L.pixels)
            with m.If(done):
                m.d.dram += [front.eq(~front), done.eq(0), shown_any.eq(1)]

    def _scan(self, m, fifo):
        """The display's side: one word a pixel inside the frame; a word missing is owed (``underrun``)."""
        L = self.layout
        inside = Signal()
        m.d.sync += inside.eq((self.x < L.width) & (self.y < L.height))
        debt = Signal(range(L.pixels + 1))
        take = inside | (debt != 0)
        m.d.comb += fifo.r_en.eq(take)
        m.d.sync += self.color.eq(Mux(inside & fifo.r_rdy & (debt == 0), fifo.r_data, 0))
        with m.If(inside & ~fifo.r_rdy):
            m.d.sync += [self.underrun.eq(1), debt.eq(debt + 1)]
        with m.Elif(inside & (debt != 0)):
            pass                                          # pops an owed word; this pixel's is owed instead
        with m.Elif(~inside & (debt != 0) & fifo.r_rdy):
            m.d.sync += debt.eq(debt - 1)
