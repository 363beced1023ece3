"""The texture fetch of the pixel pipeline with its maps in external memory: the bump map's and the color
texture's lookups of each fragment (paper, sections 3.2 and 4) through one decoupled texel cache each
(``rtl/texcache_decoupled.py``), both caches reading one AXI4 memory through one read port.

- **Fork and join.** A fragment's request holds both maps' footprints (each a footprint on a surface of the one
  :class:`~fxmodel.units.texcache.Layout`: :meth:`fxmodel.pipeline.engine.EngineParams.texture_layout`) and a
  sideband; it enters both caches in the same clock (each cache's ``i.valid`` waits for the other's ``ready``),
  and its texels leave when both caches have them (each cache's ``o.ready`` waits for the other's ``valid``).
  The sideband rides the bump map's cache, so the texels of both maps and the fragment leave together, in order.
- **One read port, in order.** The caches' ``AR`` requests are granted alternately when both wait (a grant holds
  until its handshake, as AXI4 requires); the owner of each granted burst enters a FIFO, and the ``R`` beats,
  which the memory returns in order on the one ID, go to the owner at its head until ``RLAST``. Each cache's
  bursts keep their order, so each map's traffic is its cache's model (``EngineParams.texture_traffic``) burst
  for burst; only their interleaving depends on timing.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In, Out

from fxmodel.core.unit import require
from fxmodel.units.texcache import Layout
from rtl.rop import axi_signature

from .texcache_decoupled import DecoupledTexCache, request_layout

__all__ = ["TexFetch", "MAPS"]

#: The maps a fragment looks up, in request order (``fxmodel.pipeline.engine.TEXTURE_MAPS``).
MAPS = ("bump_map", "texture")

_AR = ("arid", "araddr", "arlen", "arsize", "arburst")


class TexFetch(wiring.Component):
    """Both maps' caches (``caches``: per map its :class:`~fxmodel.units.texcache.TexCacheParams`) over ``layout``.

    Ports: ``i`` (stream of ``bump_map`` and ``texture``, each a :func:`~rtl.texcache_decoupled.request_layout`,
    and ``side``), ``o`` (stream of ``bump_map`` and ``texture``, four texels each, corner 0 low, and ``side``),
    ``mem`` (AXI4 manager, read channels), ``busy``.
    """

    def __init__(self, caches: dict, layout: Layout, side_bits: int = 1, addr_bits: int = 32):
        require(set(caches) == set(MAPS), "caches", sorted(caches), f"must name the maps {MAPS}")
        require(side_bits >= 1, "side_bits", side_bits, "must be at least 1")
        self.caches = {k: DecoupledTexCache(caches[k], layout, side_bits if k == MAPS[0] else 0, addr_bits)
                       for k in MAPS}
        self.layout, self.side_bits = layout, side_bits
        req, out = self.payloads(caches, layout, side_bits)
        super().__init__({"i": In(stream.Signature(req)), "o": Out(stream.Signature(out)),
                          "mem": Out(axi_signature(addr_bits, 32)), "busy": Out(1)})

    @staticmethod
    def payloads(caches: dict, layout: Layout, side_bits: int) -> tuple:
        """``(request, output)`` payload layouts of the ports ``i`` and ``o``."""
        req = data.StructLayout({**{k: request_layout(layout) for k in MAPS}, "side": side_bits})
        out = data.StructLayout({**{k: 4 * caches[k].texel_bits for k in MAPS}, "side": side_bits})
        return req, out

    def elaborate(self, platform):
        m = Module()
        c0, c1 = (self.caches[k] for k in MAPS)
        m.submodules.bump_map, m.submodules.texture = c0, c1
        # fork
        m.d.comb += [self.i.ready.eq(c0.i.ready & c1.i.ready), c0.i.valid.eq(self.i.valid & c1.i.ready),
                     c1.i.valid.eq(self.i.valid & c0.i.ready), c1.i.payload.eq(self.i.payload.texture)]
        for f in ("surface", "x0", "x1", "y0", "y1"):
            m.d.comb += getattr(c0.i.payload, f).eq(getattr(self.i.payload.bump_map, f))
        m.d.comb += c0.i.payload.side.eq(self.i.payload.side)
        # join
        m.d.comb += [self.o.valid.eq(c0.o.valid & c1.o.valid), c0.o.ready.eq(self.o.ready & c1.o.valid),
                     c1.o.ready.eq(self.o.ready & c0.o.valid), self.o.payload.bump_map.eq(c0.o.payload.texels),
                     self.o.payload.texture.eq(c1.o.payload.texels), self.o.payload.side.eq(c0.o.payload.side),
                     self.busy.eq(c0.busy | c1.busy)]
        self._read_port(m, (c0, c1))
        return m

    def _read_port(self, m, caches):
        """``AR`` granted alternately (held until its handshake), owners in order, ``R`` beats to the owner."""
        axi = self.mem
        depth = sum(c.params.misses for c in caches)
        m.submodules.owners = owners = SyncFIFO(width=1, depth=depth)
        last, locked, held = Signal(), Signal(), Signal()
        want = [c.mem.arvalid for c in caches]
        pick = Signal()
        m.d.comb += pick.eq(Mux(want[0] & want[1], ~last, want[1]))
        grant = Signal()
        m.d.comb += grant.eq(Mux(locked, held, pick))
        src = [c.mem for c in caches]
        m.d.comb += [axi.arvalid.eq(Mux(grant, want[1], want[0]) & owners.w_rdy),
                     src[0].arready.eq(axi.arready & owners.w_rdy & ~grant),
                     src[1].arready.eq(axi.arready & owners.w_rdy & grant)]
        for f in _AR:
            m.d.comb += getattr(axi, f).eq(Mux(grant, getattr(src[1], f), getattr(src[0], f)))
        fire = axi.arvalid & axi.arready
        m.d.comb += [owners.w_en.eq(fire), owners.w_data.eq(grant)]
        with m.If(fire):
            m.d.sync += [last.eq(grant), locked.eq(0)]
        with m.Elif(axi.arvalid):
            m.d.sync += [locked.eq(1), held.eq(grant)]
        owner = owners.r_data[0]
        for k, s in enumerate(src):
            m.d.comb += [s.rvalid.eq(axi.rvalid & owners.r_rdy & (owner == k)), s.rdata.eq(axi.rdata),
                         s.rresp.eq(axi.rresp), s.rlast.eq(axi.rlast), s.rid.eq(axi.rid),
                         s.awready.eq(0), s.wready.eq(0), s.bvalid.eq(0)]
        m.d.comb += [axi.rready.eq(owners.r_rdy & Mux(owner, src[1].rready, src[0].rready)),
                     owners.r_en.eq(axi.rvalid & axi.rready & axi.rlast),
                     axi.awvalid.eq(0), axi.wvalid.eq(0), axi.bready.eq(1)]
