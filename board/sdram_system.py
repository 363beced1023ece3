"""The engine system with its frame in SDRAM (``EngineSystem(..., frame="sdram")``, ``board/frame.py``;
``docs/board.md``): SWAP copies the engine's finished tile through :class:`~board.sdram_frame.SdramFrame` into the
back buffer in SDRAM (LiteDRAM's AXI4 port, in the engine's clock: the core runs on it), and the display scans the
front buffer out of SDRAM (paper, section 4 and Fig. 5: the engine's colors go to a frame buffer, which the display
reads).

SWAP as with the frame on chip: a toggle to the engine's clock; once the engine has been quiet for
:data:`~board.cdc.QUIET` clocks and the frame has no copy waiting to be shown, the tile is read out through the
depth test's read port (held for the whole copy, so no fragment is drawn into the tile meanwhile), each pixel
narrowed to RGB565 and registered into a small FIFO feeding the copy's write bursts; the next copy waits for this
one's last write response. The buffer shown changes between display frames (:class:`~board.sdram_frame.SdramFrame`).
``board/sdram_sim.py`` (:class:`~board.sdram_sim.SdramBoardSim`) is ``BoardSim`` with LiteDRAM's simulation core on
the port.
"""

from __future__ import annotations

from amaranth import Cat, DomainRenamer, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import Out

from host.protocol import Cmd
from rtl.rop import axi_signature

from .cdc import QUIET, toggle_sync
from .litedram import ADDR_BITS, DATA_BITS, ID_BITS
from .sdram_frame import LATENCY, FrameLayout, SdramFrame

__all__ = ["members", "elaborate_swap", "BURST", "COPY_FIFO"]

#: Beats of the frame's bursts (128 bytes: a 128-pixel line is two).
BURST = 64
#: Words between the tile's read port and the copy's write bursts.
COPY_FIFO = 8


def members() -> dict:
    """The engine system's ports added for the frame in SDRAM: ``mem`` (the AXI4 manager, ``engine``),
    ``mem_error`` (an error response, sticky), ``underrun`` (the scan-out missed a word, sticky)."""
    return {"mem": Out(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "mem_error": Out(1), "underrun": Out(1)}


def elaborate_swap(system, m: Module, link, eng, disp) -> None:
    """SWAP, the copy into SDRAM and the display's pixels (module docstring), into ``system``'s module ``m``."""
    P = system.params.rop
    pixels = P.width * P.height
    if disp.latency != LATENCY + 1:
        raise AssertionError(f"the display's pixel latency must be {LATENCY + 1} (the frame's and a register)")
    frame = SdramFrame(FrameLayout(P.width, P.height, burst=min(BURST, 1 << (P.width - 1).bit_length())),
                       system.timing)
    m.submodules.sdram_frame = DomainRenamer({"dram": "engine"})(frame)
    f = frame
    q = SyncFIFO(width=DATA_BITS, depth=COPY_FIFO)
    m.submodules.copy_fifo = DomainRenamer("engine")(q)
    wiring.connect(m, f.mem, wiring.flipped(system.mem))
    m.d.comb += [f.i.valid.eq(q.r_rdy), f.i.payload.eq(q.r_data), q.r_en.eq(f.i.ready),
                 system.mem_error.eq(f.error), system.underrun.eq(f.underrun), system.front.eq(f.front)]
    swap_req = Signal()
    with m.If(link.done & (link.cmd == Cmd.SWAP)):
        m.d.sync += swap_req.eq(~swap_req)
    swap_seen = toggle_sync(m, "swap", swap_req, "engine")
    quiet = Signal(range(QUIET + 1))
    with m.If(eng.i.valid | eng.busy | eng.rop_busy):
        m.d.engine += quiet.eq(0)
    with m.Elif(quiet != QUIET):
        m.d.engine += quiet.eq(quiet + 1)
    want, free = Signal(), Signal(init=1)               # a SWAP to serve; no copy in progress
    with m.If(swap_seen):
        m.d.engine += want.eq(1)
    # the tile's read-out: the read port held for the whole copy, the address stepping while the FIFO has room
    # for the words in flight (the read-out's ``readout_latency`` and the registered word's); ``d[k]``: a word
    # stepped ``k + 1`` clocks ago
    addr = Signal(range(pixels + 1))
    reading = Signal()
    d = [Signal(name=f"d{k + 1}") for k in range(P.readout_latency + 1)]
    step = reading & (addr != pixels) & (q.level + sum(d) < COPY_FIFO)
    zb = P.z_fmt.width
    data = eng.fb.data
    word565 = Cat(data[zb + 19:zb + 24], data[zb + 10:zb + 16], data[zb + 3:zb + 8])
    m.d.comb += [eng.fb.read.eq(reading), eng.fb.addr.eq(addr[:len(eng.fb.addr)]), q.w_en.eq(d[-1])]
    m.d.engine += [d[0].eq(step), *(b.eq(a) for a, b in zip(d, d[1:])), q.w_data.eq(word565)]
    with m.If(step):
        m.d.engine += addr.eq(addr + 1)
    with m.If(f.copied):
        m.d.engine += free.eq(1)
    with m.If(want & free & ~reading & ~swap_seen & (quiet == QUIET)):
        m.d.engine += [want.eq(0), free.eq(0), addr.eq(0), reading.eq(1)]
    with m.If(reading & (addr == pixels) & ~Cat(*d[:-1]).any()):
        m.d.engine += reading.eq(0)
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


def wire_sdram(m: Module, platform, system) -> None:
    """The board's SDRAM: LiteDRAM's board core (GENSDRPHY on the chip's pins, in the engine's clock) on the
    system's AXI port, the chip's clock from a double-data-rate output at 180 degrees (its rising edge in the
    middle of the engine clock's period, as LiteX's ULX3S target does), the core's Verilog added to the build
    (generated into ``build/litedram`` when missing: :func:`board.litedram.generate`), LEDs 4 (underrun), 5 (an
    AXI error response) and 6 (the SDRAM ready)."""
    from amaranth.lib import io

    from fxmodel.core.paths import build_dir

    from .litedram import generate
    from .sdram_core import LiteDram
    pins = platform.request("sdram", 0, dir="-")
    d = LiteDram(pins)
    m.submodules.dram = DomainRenamer({"dram": "engine"})(d)
    wiring.connect(m, system.mem, d.axi)
    m.submodules.sdram_clk = clk = io.DDRBuffer("o", pins.clk, o_domain="engine")
    m.d.comb += [clk.o[0].eq(0), clk.o[1].eq(1)]
    leds = {k: io.Buffer("o", platform.request("led", k, dir="-")) for k in (4, 5, 6)}
    for k, buf in leds.items():
        m.submodules[f"led{k}"] = buf
    m.d.comb += [leds[4].o.eq(system.underrun), leds[5].o.eq(system.mem_error), leds[6].o.eq(d.ready)]
    path = build_dir("litedram") / "gateware" / "litedram_core.v"
    if not path.exists():
        path = generate(False)
    platform.add_file("litedram_core.v", core_verilog(path.read_text()))
