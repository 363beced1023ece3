"""The texel caches' misses into the SDRAM (``docs/board.md``, "Textures in SDRAM"): the engine's texture fetch
(``rtl/texfetch.py``, its ``tex`` port: the bump map's and the color texture's lookups of paper, sections 3.2 and 4,
through one decoupled texel cache each) reads its maps from LiteDRAM's second AXI4 user port
(:data:`board.litedram.TEXTURE_PORT`), and that port runs in the SDRAM's clock (domain ``dram``), the caches in the
engine's.

:class:`TextureReadCrossing` carries the two read channels across: each ``AR`` transfer through an
``amaranth.lib.fifo.AsyncFIFO`` from the engine's clock to the SDRAM's, each ``R`` beat through another back. Both
sides keep AXI's rules by construction: a FIFO's ``w_rdy`` is the ``ready`` of the side that writes it, its ``r_rdy``
the ``valid`` of the side that reads it, and a word read leaves only with its handshake. The caches hold ``rready``
high (each line's space is reserved when its miss is queued), so the ``R`` FIFO drains as fast as it fills; the
core sees ``rready`` fall only while the FIFO is full.

The maps live in the upper half of the SDRAM (:data:`TEXTURE_BASE`; the frame's buffers in the lower,
``board/sdram_frame.py``): the caches' ports are built with :data:`TEXTURE_ADDR_BITS` address bits, so every
address they make is below :data:`TEXTURE_BASE`, a power of two, and the crossing sets that one bit above them:
the SDRAM address is ``TEXTURE_BASE + address`` with no carry and nothing cut. Their one-bit ID is widened with
zeros on ``AR``; the core returns the ID it was given, so on ``R`` the ID's upper bits are zero and only its low
bits go on: a beat whose upper bits are not zero, or whose response is an error (``SLVERR``, ``DECERR``), sets
``error`` (sticky, in the engine's clock) instead of passing unseen. The caches never write: ``AW`` and ``W`` stay
idle in the crossing; the board's TEXTURE uploads write the maps through them (:class:`TextureWrites`; both on the one
port: :class:`TexturePort`).
"""

from __future__ import annotations

from amaranth import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import In, Out

from fxmodel.core.unit import require
from rtl.rop import axi_signature

from .cdc import toggle_sync
from .litedram import ADDR_BITS, ID_BITS, SDRAM_BYTES, TEXTURE_DATA_BITS

__all__ = ["TextureReadCrossing", "TextureWrites", "TexturePort", "AR_DEPTH", "R_DEPTH", "TEXTURE_BASE",
           "TEXTURE_ADDR_BITS"]

#: Byte address of the maps in the SDRAM (the texture layout's address 0): the chip's upper half.
TEXTURE_BASE = SDRAM_BYTES // 2
#: Address bits of the caches' ports: their addresses lie below :data:`TEXTURE_BASE`.
TEXTURE_ADDR_BITS = (TEXTURE_BASE - 1).bit_length()

#: ``AR`` transfers the crossing holds (the caches' bursts outstanding are counted by their miss registers).
AR_DEPTH = 4
#: ``R`` beats the crossing holds: a power of two, so that the beats of a line stream through while the pointers
#: cross (an ``AsyncFIFO``'s ``w_rdy`` sees a read some clocks late).
R_DEPTH = 16

_AR = ("araddr", "arlen", "arsize", "arburst")
_R = ("rdata", "rresp", "rlast")


class TextureReadCrossing(wiring.Component):
    """AXI4 read channels from domain ``i_domain`` (port ``up``: the texture fetch's manager connects to it; ``ID``
    of ``up_id_bits``, ``up_addr_bits`` address bits, each address put at ``base + address``) to domain
    ``o_domain`` (port ``down``: connect it to the core's texture port), ``ar_depth`` and ``r_depth`` words of
    ``AsyncFIFO`` (module docstring); ``error`` (domain ``i_domain``, sticky): an ``R`` beat with an error
    response or an ID the manager did not send."""

    def __init__(self, up_id_bits: int = 1, *, up_addr_bits: int = TEXTURE_ADDR_BITS, base: int = TEXTURE_BASE,
                 i_domain: str = "sync", o_domain: str = "dram", ar_depth: int = AR_DEPTH, r_depth: int = R_DEPTH):
        require(1 <= up_id_bits <= ID_BITS, "up_id_bits", up_id_bits, f"must be in 1..{ID_BITS} (the core's ID)")
        require(1 <= up_addr_bits <= ADDR_BITS, "up_addr_bits", up_addr_bits, f"must be in 1..{ADDR_BITS}")
        require(base % (1 << up_addr_bits) == 0 and 0 <= base <= SDRAM_BYTES - (1 << up_addr_bits), "base", base,
                f"must be a multiple of 2**{up_addr_bits} with 2**{up_addr_bits} bytes after it in the SDRAM")
        self.base = base
        for name, depth in (("ar_depth", ar_depth), ("r_depth", r_depth)):
            require(depth >= 2 and depth & (depth - 1) == 0, name, depth, "must be a power of two, at least 2")
        self.i_domain, self.o_domain, self.ar_depth, self.r_depth = i_domain, o_domain, ar_depth, r_depth
        super().__init__({"up": In(axi_signature(up_addr_bits, TEXTURE_DATA_BITS, up_id_bits)),
                          "down": Out(axi_signature(ADDR_BITS, TEXTURE_DATA_BITS, ID_BITS)), "error": Out(1)})
        #: the two FIFOs: an ``AR`` transfer as the caches make it, an ``R`` beat as the core returns it
        self.ar_fifo = AsyncFIFO(width=len(self._ar_word(self.up)), depth=ar_depth, w_domain=i_domain,
                                 r_domain=o_domain)
        self.r_fifo = AsyncFIFO(width=len(self._r_word(self.down)), depth=r_depth, w_domain=o_domain,
                                r_domain=i_domain)

    @staticmethod
    def _ar_word(port):
        """An ``AR`` transfer's fields of ``port`` as one word (the ``AR`` FIFO's)."""
        return Cat(*(getattr(port, f) for f in ("arid",) + _AR))

    @staticmethod
    def _r_word(port):
        """An ``R`` beat's fields of ``port`` as one word (the ``R`` FIFO's)."""
        return Cat(*(getattr(port, f) for f in ("rid",) + _R))

    def elaborate(self, platform):
        m = Module()
        up, down = self.up, self.down
        taken = wiring.Signature(up.signature.members).create()       # the AR transfer as it leaves the FIFO
        m.d.comb += [down.arid.eq(taken.arid), down.araddr.eq(taken.araddr | self.base)]  # ``base``: above every
        m.d.comb += [getattr(down, f).eq(getattr(taken, f)) for f in _AR[1:]]             # ``up`` address
        m.submodules.ar = ar = self.ar_fifo
        m.d.comb += [ar.w_data.eq(self._ar_word(up)), ar.w_en.eq(up.arvalid), up.arready.eq(ar.w_rdy),
                     self._ar_word(taken).eq(ar.r_data), down.arvalid.eq(ar.r_rdy), ar.r_en.eq(down.arready)]
        beat = wiring.Signature(down.signature.members).create()      # the R beat as it leaves the FIFO
        rid = beat.rid
        m.submodules.r = r = self.r_fifo
        m.d.comb += [r.w_data.eq(self._r_word(down)), r.w_en.eq(down.rvalid), down.rready.eq(r.w_rdy),
                     self._r_word(beat).eq(r.r_data), up.rid.eq(rid[:len(up.rid)]), up.rvalid.eq(r.r_rdy),
                     r.r_en.eq(up.rready)]
        m.d.comb += [getattr(up, f).eq(getattr(beat, f)) for f in _R]
        with m.If(r.r_rdy & up.rready & (up.rresp[1] | rid[len(up.rid):].any())):
            m.d[self.i_domain] += self.error.eq(1)
        m.d.comb += [down.awvalid.eq(0), down.wvalid.eq(0), down.bready.eq(1)]
        return m


class TextureWrites(wiring.Component):
    """The TEXTURE uploads' words into the SDRAM, one single-beat AXI4 write each, in domain ``domain`` (the
    SDRAM's). A word comes from another clock as the board's other uploads do (``board/upload.py``): ``addr`` (an
    SDRAM byte address) and ``data`` are holding registers of that clock, and ``req`` toggles when they hold a new
    word; two registers later the word is taken into registers of this clock, and ``AW`` (``INCR``, one beat of
    four bytes) and ``W`` (every byte, ``WLAST``) are offered, each held until taken, then the response awaited.
    Words come at most once a UART byte, far slower than a write; a word seen while the last is still being written
    is not written and sets ``error``, as does an error response (sticky, this clock). ``busy``: a write offered or
    its response awaited. Port ``down``: the write channels of an AXI4 manager (the read channels stay idle)."""

    def __init__(self, domain: str = "dram"):
        self.domain = domain
        super().__init__({"req": In(1), "addr": In(ADDR_BITS), "data": In(TEXTURE_DATA_BITS),
                          "down": Out(axi_signature(ADDR_BITS, TEXTURE_DATA_BITS, ID_BITS)), "busy": Out(1),
                          "error": Out(1)})

    def elaborate(self, platform):
        m = Module()
        d, sync = self.down, m.d[self.domain]
        seen = toggle_sync(m, "texture_word", self.req, self.domain)
        aw, w, b = Signal(), Signal(), Signal()              # offered on AW, on W; the response awaited
        m.d.comb += [d.awvalid.eq(aw), d.awlen.eq(0), d.awsize.eq(2), d.awburst.eq(1), d.wvalid.eq(w),
                     d.wstrb.eq((1 << (TEXTURE_DATA_BITS // 8)) - 1), d.wlast.eq(1), d.bready.eq(1),
                     d.arvalid.eq(0), d.rready.eq(1), self.busy.eq(aw | w | b)]
        with m.If(aw & d.awready):
            sync += aw.eq(0)
        with m.If(w & d.wready):
            sync += w.eq(0)
        with m.If(b & d.bvalid):
            sync += b.eq(0)
            with m.If(d.bresp[1]):
                sync += self.error.eq(1)
        with m.If(seen):
            with m.If(self.busy):                            # the last word still in flight: this one is lost
                sync += self.error.eq(1)
            with m.Else():
                sync += [d.awaddr.eq(self.addr), d.wdata.eq(self.data), aw.eq(1), w.eq(1), b.eq(1)]
        return m


class TexturePort(wiring.Component):
    """The engine's side of the SDRAM's texture port: :class:`TextureReadCrossing` (the texture fetch's reads,
    port ``up`` in domain ``i_domain``) and :class:`TextureWrites` (the uploads' words: ``req``, ``addr``,
    ``data``) on the one port ``down`` (domain ``o_domain``), the reads on its read channels and the writes on its
    write channels. ``error`` (sticky, domain ``o_domain``): a write's error (:class:`TextureWrites`), or an ``AR``
    while an upload's word is being written, which the board never does (uploads are refused while a frame is
    drawn, and a write ends long before the next frame's first lookup), since LiteDRAM would not order them; the
    read crossing's ``error`` (domain ``i_domain``) is ``read_error``; ``write_busy``: an upload's write in
    flight."""

    def __init__(self, up_id_bits: int = 1, *, i_domain: str = "sync", o_domain: str = "dram"):
        self.crossing = TextureReadCrossing(up_id_bits, i_domain=i_domain, o_domain=o_domain)
        self.writes = TextureWrites(o_domain)
        self.o_domain = o_domain
        sig = self.crossing.signature.members
        super().__init__({"up": sig["up"], "down": sig["down"], "req": In(1), "addr": In(ADDR_BITS),
                          "data": In(TEXTURE_DATA_BITS), "error": Out(1), "read_error": Out(1),
                          "write_busy": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.read = r = self.crossing
        m.submodules.write = w = self.writes
        wiring.connect(m, wiring.flipped(self.up), r.up)
        m.d.comb += [w.req.eq(self.req), w.addr.eq(self.addr), w.data.eq(self.data), self.read_error.eq(r.error),
                     self.write_busy.eq(w.busy)]
        # every member of the port from its signature: the read channels' (``AR``, ``R``) to the crossing, the
        # write channels' to the writes, each in its direction
        down = self.down
        for name, member in down.signature.members.items():
            side = r.down if name.startswith(("ar", "r")) else w.down
            src, dst = (side, down) if member.flow == Out else (down, side)
            m.d.comb += getattr(dst, name).eq(getattr(src, name))
        with m.If(w.error | (down.arvalid & w.busy)):
            m.d[self.o_domain] += self.error.eq(1)
        return m
