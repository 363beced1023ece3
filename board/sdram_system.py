"""The engine system with its frame in SDRAM (``EngineSystem(..., frame="sdram")``, ``board/frame.py``;
``docs/board.md``): SWAP copies the engine's finished tile through :class:`~board.sdram_frame.SdramFrame` into the
back buffer in SDRAM (LiteDRAM's AXI4 port, in the SDRAM's own clock domain ``dram``: the core runs on it, and
the tile's words cross to it through an asynchronous FIFO), and the display scans the
front buffer out of SDRAM (paper, section 4 and Fig. 5: the engine's colors go to a frame buffer, which the display
reads).

SWAP and FRAME_START as with the frame on chip, by the same :class:`~board.frame.TileCopy`: once the engine has
been quiet for :data:`~board.cdc.QUIET` clocks and the frame has no copy waiting to be shown, the tile is read out
through the depth test's read port (held for the whole copy, so no fragment is drawn into the tile meanwhile), each
pixel narrowed to RGB565 and registered into a small FIFO feeding the copy's write bursts (the walk steps while the
FIFO has room); the next copy waits for this one's last write response; FRAME_START clears the tile. The buffer
shown changes between display frames (:class:`~board.sdram_frame.SdramFrame`).
``board/sdram_sim.py`` (:class:`~board.sdram_sim.SdramBoardSim`) is ``BoardSim`` with LiteDRAM's simulation core on
the port.
"""

from __future__ import annotations

from amaranth import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import Out

from rtl.rop import axi_signature

from .cdc import toggle_sync
from .litedram import ADDR_BITS, DATA_BITS, ID_BITS, TEXTURE_DATA_BITS
from .sdram_frame import LATENCY, FrameLayout, SdramFrame
from .texture_port import TEXTURE_BASE

__all__ = ["members", "elaborate_frame", "elaborate_textures", "texture_spans", "burst", "BURST", "COPY_FIFO",
           "UNSEEN_WRITES"]

#: Beats of the frame's bursts (128 bytes: a 128-pixel line is two).
BURST = 64
#: Words between the tile's read port and the copy's write bursts (an ``AsyncFIFO``, from the engine's clock to the
#: SDRAM's).
COPY_FIFO = 16
#: Clocks by which the ``AsyncFIFO``'s ``w_level`` lags a write: its write pointer and the level are registers, so
#: the words written in the last two clocks are not in it yet (a read shows later still, which only overstates).
UNSEEN_WRITES = 2


def burst(tile_width: int, cols: int) -> int:
    """Beats of the frame's bursts: :data:`BURST`, or less for a narrow tile (the power of two at least its width)
    or one whose width it does not divide when the picture has several columns of tiles (the largest power of two
    dividing the width: no burst crosses a tile's edge)."""
    return min(BURST, 1 << (tile_width - 1).bit_length() if cols == 1 else tile_width & -tile_width)


def members(textures: bool = False) -> dict:
    """The engine system's ports added for the frame in SDRAM: ``mem`` (the AXI4 manager, ``dram``),
    ``mem_error`` (an error response, or a copied word the copy's FIFO could not take, or an error of the texture
    port; sticky), ``underrun`` (the scan-out missed a word, sticky); with ``textures`` (the maps in SDRAM) also
    ``tex``, the manager of the core's texture port (``dram``, :func:`elaborate_textures`)."""
    out = {"mem": Out(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "mem_error": Out(1), "underrun": Out(1)}
    if textures:
        out["tex"] = Out(axi_signature(ADDR_BITS, TEXTURE_DATA_BITS, ID_BITS))
    return out


def texture_spans(params) -> dict:
    """Per map in SDRAM (``params``: an :class:`~fxmodel.pipeline.engine.EngineParams` with ``textures``) its
    span in the SDRAM ``(byte address, bytes)``: its span of the texture layout
    (:meth:`~fxmodel.units.texcache.Layout.span`) at :data:`~board.texture_port.TEXTURE_BASE`."""
    from fxmodel.pipeline.engine import TEXTURE_MAPS
    layout = params.texture_layout()
    spans = {name: layout.span(name) for name in TEXTURE_MAPS}
    return {name: (TEXTURE_BASE + start, size) for name, (start, size) in spans.items()}


def elaborate_textures(system, m: Module, eng, up):
    """The maps in SDRAM (``docs/board.md``, "Textures in SDRAM") into ``system``'s module ``m``: the engine
    ``eng``'s texture fetch reads through :class:`~board.texture_port.TexturePort` (from the engine's clock to the
    SDRAM's) on the system's ``tex`` port, whose write channels take the uploads' words of the maps in SDRAM
    (``up``: the :class:`~board.upload.UploadWriter`'s ``sd_*``); each such word also empties the texel caches
    (``eng.tex_flush``, a pulse of the engine's clock from the word's toggle: uploads come while the engine is
    idle). Returns the port's errors (sticky, of both clocks) for ``mem_error``."""
    from .texture_port import TexturePort
    m.submodules.texture_port = tp = TexturePort(i_domain="engine", o_domain="dram")
    wiring.connect(m, eng.tex, tp.up)
    wiring.connect(m, tp.down, wiring.flipped(system.tex))
    m.d.comb += [tp.req.eq(up.sd_req), tp.addr.eq(up.sd_addr), tp.data.eq(up.sd_data),
                 eng.tex_flush.eq(toggle_sync(m, "tex_flush", up.sd_req, "engine"))]
    return tp.error | tp.read_error


def elaborate_frame(system, m: Module, tc, disp) -> None:
    """The frame in SDRAM (module docstring) into ``system``'s module ``m``: the tile copy ``tc``'s words into the
    copy's FIFO and write bursts, the display's pixels from the front buffer."""
    P = system.params.rop
    if disp.latency != LATENCY + 1:
        raise AssertionError(f"the display's pixel latency must be {LATENCY + 1} (the frame's and a register)")
    t, cols = system.timing, system.grid[0]
    layout = FrameLayout(t.h_active, t.v_active, burst=burst(P.width, cols))
    if layout.base + 2 * layout.buffer_bytes > TEXTURE_BASE:
        raise AssertionError("the frame's buffers reach the maps' half of the SDRAM (board/texture_port.py)")
    m.submodules.sdram_frame = f = SdramFrame(layout, t, tile=(P.width, P.height))
    q = AsyncFIFO(width=DATA_BITS, depth=COPY_FIFO, w_domain="engine", r_domain="dram")
    m.submodules.copy_fifo = q
    wiring.connect(m, f.mem, wiring.flipped(system.mem))
    # the copy steps while the FIFO has room for its word, those in flight (the read-out's ``readout_latency`` and
    # the registered word's: TileCopy writes ``readout_latency + 1`` clocks after a step) and those its level does
    # not show yet (UNSEEN_WRITES), so a write never finds the FIFO full (a word lost there would leave the copy's
    # last burst short, and the copy would never end); the next copy waits for this one's last write response, a
    # pulse of the SDRAM's clock handed to the engine's as a toggle
    flight = P.readout_latency + 1 + UNSEEN_WRITES
    copied, lost = Signal(), Signal()
    with m.If(q.w_en & ~q.w_rdy):                      # cannot happen (the room above); sticky if it does
        m.d.engine += lost.eq(1)
    with m.If(f.copied):
        m.d.dram += copied.eq(~copied)
    # the copy's place and show: TileCopy's registers, held from before the copy's first word until the next
    # copy begins, which waits for this one's last write; SdramFrame takes them with the first word, which reached
    # it through the FIFO's synchronised pointers, so they have settled in the SDRAM's clock
    cb = system.place_bits[0]
    m.d.comb += [f.col.eq(tc.copy_place[:cb]), f.row.eq(tc.copy_place[cb:]), f.show.eq(tc.copy_show)]
    m.d.comb += [f.i.valid.eq(q.r_rdy), f.i.payload.eq(q.r_data), q.r_en.eq(f.i.ready),
                 q.w_en.eq(tc.w_en), q.w_data.eq(tc.w_data), tc.room.eq(q.w_level < COPY_FIFO - flight),
                 tc.shown.eq(toggle_sync(m, "copied", copied, "engine")),
                 system.mem_error.eq(f.error | lost | system.tex_error), system.underrun.eq(f.underrun),
                 system.front.eq(f.front)]
    # the display: the frame's word (LATENCY clocks) expanded to bytes and registered
    m.d.comb += [f.x.eq(disp.x), f.y.eq(disp.y)]
    px = f.color
    r, g, b = px[11:16], px[5:11], px[0:5]
    m.d.sync += [disp.r.eq(Cat(r[2:], r)), disp.g.eq(Cat(g[4:], g)), disp.b.eq(Cat(b[2:], b))]
    m.d.comb += system.words.eq(disp.words)


#: The generated core's declaration of the data pins: ``input`` although they are its ``TRELLIS_IO`` tristate
#: buffers' pads; the design is given the core with them as ``inout`` (``docs/board.md``).
DQ_INPUT = "input  wire   [15:0] sdram_dq,"
DQ_INOUT = "inout  wire   [15:0] sdram_dq,"


def core_verilog(text: str) -> str:
    """The generated board core's Verilog with its data pins an ``inout`` (``ValueError`` if the declaration is
    not the one this was written for)."""
    if text.count(DQ_INPUT) != 1:
        raise ValueError(f"the generated litedram_core.v does not declare '{DQ_INPUT}' once: regenerate it "
                         "(bumpmap litedram) or update board/sdram_system.py")
    return text.replace(DQ_INPUT, DQ_INOUT)


def wire_sdram(m: Module, platform, system, clk_hz: int) -> None:
    """The board's SDRAM: LiteDRAM's board core (GENSDRPHY on the chip's pins) on the system's AXI port, in domain
    ``dram`` (the caller's: its own clock, ``clk_hz``, with a reset held until the PLL locks, which the core and
    its init sequence need, unlike the engine's registers), the chip's clock from a double-data-rate output at 180
    degrees (its rising edge in the middle of the core's clock period, as LiteX's ULX3S target does), the core's
    Verilog for ``clk_hz`` added to the build (generated into the build folder when missing:
    :func:`board.litedram.core`; with the texture port when the system has its maps in SDRAM), LEDs 4
    (underrun), 5 (an AXI error response) and 6 (the SDRAM ready)."""
    from amaranth.lib import io

    from .litedram import core
    from .sdram_core import LiteDram
    pins = platform.request("sdram", 0, dir="-")
    d = LiteDram(pins, textures=system.textures)
    m.submodules.dram = d
    wiring.connect(m, system.mem, d.axi)
    if system.textures:                                 # the maps on the core's texture port
        wiring.connect(m, system.tex, d.tex)
    m.submodules.sdram_clk = clk = io.DDRBuffer("o", pins.clk, o_domain="dram")
    m.d.comb += [clk.o[0].eq(0), clk.o[1].eq(1)]
    leds = {k: io.Buffer("o", platform.request("led", k, dir="-")) for k in (4, 5, 6)}
    for k, buf in leds.items():
        m.submodules[f"led{k}"] = buf
    m.d.comb += [leds[4].o.eq(system.underrun), leds[5].o.eq(system.mem_error), leds[6].o.eq(d.ready)]
    platform.add_file("litedram_core.v", core_verilog(core(False, clk_hz, system.textures).read_text()))
