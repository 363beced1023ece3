"""AXI4 manager properties of the frame in SDRAM (``board/sdram_frame.py``): the port's write and read channels checked
with :class:`formal.axi.AxiManagerCheck` (``AW``/``W``/``AR`` held until ready, legal bursts inside 4 KB, ``WLAST``
on each burst's last beat, one ID, outstanding bounds; the memory's responses assumed well-formed with bounded
stalls), rule 2 assumed on the copy's words, and the frame's own bursts: every ``AW``/``AR`` of the layout's length
at a burst boundary (a copy's inside the grid of tiles, :data:`TILE` in the tiled set), a copy's words all written
before ``copied`` (no ``W`` beat without its ``AW`` burst). A bounded check (both clock domains one clock: the line
FIFO's crossing is Amaranth's ``AsyncFIFO``, its logic the same for any two clocks); covers: a copy finished, a read
burst finished.
"""

from __future__ import annotations

from amaranth.hdl import DomainRenamer, Signal
from amaranth.lib import wiring

from board.sdram_frame import FrameLayout, SdramFrame
from board.video import SMALL

from .axi import AxiManagerCheck
from .props import Harness, bits_for

__all__ = ["sdram_frame_set", "LAYOUT", "FIFO", "TILE", "STALL", "DEPTH"]

#: A frame of two lines of six pixels in bursts of four (a short last burst), a line FIFO of eight words.
LAYOUT, FIFO = FrameLayout(6, 2, burst=4), 8
#: Its tiles for the tiled set: four by one, a grid of two by two (the last column cut by the frame's edge).
TILE = (4, 1)
#: The memory's bounded stalls (assumed) and the bounded check's depth: a whole copy and the first reads fit.
STALL, DEPTH = 3, 28


def sdram_frame_set(kind: str = "proof", layout: FrameLayout = LAYOUT, fifo_depth: int = FIFO,
                    broken: bool = False, tile: tuple[int, int] | None = None) -> Harness:
    """The harness (module docstring); ``broken``: the frame without the last write in its read room
    (``SdramFrame(count_last_write=False)``), which must fail ``ar_hold``. ``tile``: the copies a tile of the frame
    at a time (:data:`TILE`), their place and ``show`` free (any, changing any clock: the frame takes them with a
    copy's first word)."""
    h = Harness(kind)
    m = h.m
    dut = SdramFrame(layout, SMALL, fifo_depth, count_last_write=not broken, tile=tile)
    m.submodules.dut = DomainRenamer({"dram": "sync"})(dut)
    m.d.comb += [dut.i.valid.eq(h.free(1, "i_valid")), dut.i.payload.eq(h.free(16, "i_payload")),
                 dut.x.eq(h.free(len(dut.x), "x")), dut.y.eq(h.free(len(dut.y), "y")),
                 dut.show.eq(h.free(1, "show"))]
    for name in ("col", "row"):
        port = getattr(dut, name)
        if len(port):
            m.d.comb += port.eq(h.free(len(port), name))
            h.check(port < dut.grid[name == "row"], f"{name}_in_grid", assume=True)
    for name, member in dut.mem.signature.members.items():
        if member.flow == wiring.In:
            m.d.comb += getattr(dut.mem, name).eq(h.free(member.shape, f"axi_{name}"))
    h.stream_hold(dut.i.valid, dut.i.ready, dut.i.payload, "i", assume=True)
    a = dut.mem
    AxiManagerCheck(h, a, max_out=max(fifo_depth, layout.bursts + 2), stall=STALL)
    T = dut.tile
    for ch, width in (("aw", dut.grid[0] * T.width), ("ar", layout.width)):    # a copy's tiles; the frame read
        valid, addr, ln = (getattr(a, f"{ch}{f}") for f in ("valid", "addr", "len"))
        last = (T.width if ch == "aw" else layout.width) % layout.burst or layout.burst
        h.check(~valid | (ln == layout.burst - 1) | (ln == last - 1), f"{ch}_layout_len")
        h.check(~valid | (getattr(a, f"{ch}size") == 1), f"{ch}_layout_size")
        line_offset = addr[:(layout.pitch - 1).bit_length()]          # the byte in the line (pitch: a power of 2)
        h.check(~valid | ((line_offset[:(2 * layout.burst - 1).bit_length()] == 0)
                          & (line_offset < 2 * width)), f"{ch}_layout_addr")
    words = Signal(bits_for(T.pixels + 1), name="f_copy_words")
    w_x = a.wvalid & a.wready
    with m.If(dut.copied):
        m.d.sync += words.eq(0)
    with m.Elif(w_x):
        m.d.sync += words.eq(words + 1)
    h.check(~dut.copied | (words + w_x == T.pixels), "copied_after_every_word")
    h.check(~w_x | (dut.i.valid & dut.i.ready & (a.wdata == dut.i.payload)), "w_from_i")
    h.cover(dut.copied, "copy_reach")
    h.cover(a.rvalid & a.rready & a.rlast, "read_burst_reach")
    return h
