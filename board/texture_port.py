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
the SDRAM address is ``TEXTURE_BASE + address`` with no carry and nothing cut. Their one-bit ID is widened with zeros on ``AR``;
the core returns the ID it was given, so on ``R`` the ID's upper bits are zero and only its low bits go on: a
beat whose upper bits are not zero, or whose response is an error (``SLVERR``, ``DECERR``), sets ``error``
(sticky, in the engine's clock) instead of passing unseen. The caches never write: ``AW`` and ``W`` stay idle.
"""

from __future__ import annotations

from amaranth import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.fifo import AsyncFIFO
from amaranth.lib.wiring import In, Out

from fxmodel.core.unit import require
from rtl.rop import axi_signature

from .litedram import ADDR_BITS, ID_BITS, SDRAM_BYTES, TEXTURE_DATA_BITS

__all__ = ["TextureReadCrossing", "AR_DEPTH", "R_DEPTH", "TEXTURE_BASE", "TEXTURE_ADDR_BITS"]

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
    of ``up_id_bits``, ``up_addr_bits`` address bits, each address put at ``base + address``) to domain ``o_domain`` (port ``down``: connect it to the core's texture port), ``ar_depth``
    and ``r_depth`` words of ``AsyncFIFO`` (module docstring); ``error`` (domain ``i_domain``, sticky): an ``R``
    beat with an error response or an ID the manager did not send."""

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

    def elaborate(self, platform):
        m = Module()
        up, down = self.up, self.down
        addr = Signal.like(down.araddr)
        m.d.comb += down.araddr.eq(addr | self.base)        # the bits of ``base`` lie above every ``up`` address
        ar_up = Cat(up.arid, up.araddr, *(getattr(up, f) for f in _AR[1:]))
        ar_down = Cat(addr[:len(up.araddr)], *(getattr(down, f) for f in _AR[1:]))
        m.submodules.ar = ar = AsyncFIFO(width=len(ar_up), depth=self.ar_depth, w_domain=self.i_domain,
                                         r_domain=self.o_domain)
        m.d.comb += [ar.w_data.eq(ar_up), ar.w_en.eq(up.arvalid), up.arready.eq(ar.w_rdy),
                     Cat(down.arid[:len(up.arid)], ar_down).eq(ar.r_data), down.arvalid.eq(ar.r_rdy),
                     ar.r_en.eq(down.arready)]
        rid = Signal.like(down.rid)
        r_down, r_up = Cat(*(getattr(down, f) for f in ("rid",) + _R)), Cat(rid, *(getattr(up, f) for f in _R))
        m.submodules.r = r = AsyncFIFO(width=len(r_down), depth=self.r_depth, w_domain=self.o_domain,
                                       r_domain=self.i_domain)
        m.d.comb += [r.w_data.eq(r_down), r.w_en.eq(down.rvalid), down.rready.eq(r.w_rdy),
                     r_up.eq(r.r_data), up.rid.eq(rid[:len(up.rid)]), up.rvalid.eq(r.r_rdy), r.r_en.eq(up.rready)]
        with m.If(r.r_rdy & up.rready & (up.rresp[1] | rid[len(up.rid):].any())):
            m.d[self.i_domain] += self.error.eq(1)
        m.d.comb += [down.awvalid.eq(0), down.wvalid.eq(0), down.bready.eq(1)]
        return m
