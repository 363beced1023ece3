"""The texture fetch of the pixel pipeline with its maps in external memory: the bump map's and the color
texture's lookups of each fragment (paper, sections 3.2 and 4) through one decoupled texel cache each
(``rtl/texcache_decoupled.py``), both caches reading one AXI4 memory through one read port.

- **Fork and join.** A fragment's request holds every cache's footprint, each on a surface of the one
  :class:`~fxmodel.units.texcache.Layout` (:meth:`fxmodel.pipeline.engine.EngineParams.texture_layout`; one
  cache per map, two for a trilinear map, its even and its odd levels, so its two levels are looked up in the
  same clock) and a sideband; it enters every cache in the same clock (each cache's ``i.valid`` waits for the
  others' ``ready``), and its texels leave when every cache has them (each cache's ``o.ready`` waits for the
  others' ``valid``). The sideband rides the first cache (the bump map's), so the texels and the fragment leave
  together, in order. A level a trilinear lookup does not need is a ``skip`` request
  (``rtl/texcache_decoupled.py``): it keeps the order and touches no line.
- **One read port, in order.** The caches' ``AR`` requests are granted round robin (alternately for two; a
  grant holds until its handshake, as AXI4 requires); the owner of each granted burst enters a FIFO, and the
  ``R`` beats, which the memory returns in order on the one ID, go to the owner at its head until ``RLAST``.
  Each cache's bursts keep their order, so each cache's traffic is its model (``EngineParams.texture_traffic``)
  burst for burst; only their interleaving depends on timing.
"""

from __future__ import annotations

from amaranth.hdl import Array, Const, Module, Mux, Signal
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
    """One decoupled cache per port of ``caches`` (port name to its :class:`~fxmodel.units.texcache.TexCacheParams`,
    in request order: :meth:`fxmodel.pipeline.engine.EngineParams.texture_caches`, one port per map, two for a
    trilinear map's even and odd levels) over ``layout``.

    Ports: ``i`` (stream of one :func:`~rtl.texcache_decoupled.request_layout` per cache, with a ``skip`` bit for
    the ports named in ``skips``, and ``side``), ``o`` (stream of four texels per cache, corner 0 low, and
    ``side``), ``mem`` (AXI4 manager, read channels), ``busy``.
    """

    def __init__(self, caches: dict, layout: Layout, side_bits: int = 1, addr_bits: int = 32, skips=()):
        require(len(caches) >= 1 and set(skips) <= set(caches), "caches", sorted(caches),
                f"must name at least one port and every port of skips {sorted(skips)}")
        require(side_bits >= 1, "side_bits", side_bits, "must be at least 1")
        self.ports = tuple(caches)
        first = self.ports[0]
        self.caches = {k: DecoupledTexCache(caches[k], layout, side_bits if k == first else 0, addr_bits,
                                            skip=k in skips) for k in self.ports}
        self.layout, self.side_bits, self.skips = layout, side_bits, tuple(skips)
        req, out = self.payloads(caches, layout, side_bits, skips)
        super().__init__({"i": In(stream.Signature(req)), "o": Out(stream.Signature(out)),
                          "mem": Out(axi_signature(addr_bits, 32)), "busy": Out(1)})

    @staticmethod
    def payloads(caches: dict, layout: Layout, side_bits: int, skips=()) -> tuple:
        """``(request, output)`` payload layouts of the ports ``i`` and ``o``."""
        req = data.StructLayout({**{k: request_layout(layout, skip=k in skips) for k in caches}, "side": side_bits})
        out = data.StructLayout({**{k: 4 * caches[k].texel_bits for k in caches}, "side": side_bits})
        return req, out

    def elaborate(self, platform):
        m = Module()
        cs = [self.caches[k] for k in self.ports]
        for k, c in zip(self.ports, cs):
            m.submodules[k] = c
        # fork: a request enters every cache in the same clock; join: the texels leave when every cache has them
        ready_all, valid_all = cs[0].i.ready, cs[0].o.valid
        for c in cs[1:]:
            ready_all, valid_all = ready_all & c.i.ready, valid_all & c.o.valid
        m.d.comb += [self.i.ready.eq(ready_all), self.o.valid.eq(valid_all),
                     self.o.payload.side.eq(cs[0].o.payload.side)]
        for j, (k, c) in enumerate(zip(self.ports, cs)):
            others_in = [o.i.ready for i, o in enumerate(cs) if i != j]
            others_out = [o.o.valid for i, o in enumerate(cs) if i != j]
            rin, vout = self.i.valid, self.o.ready
            for r in others_in:
                rin = rin & r
            for v in others_out:
                vout = vout & v
            m.d.comb += [c.i.valid.eq(rin), c.o.ready.eq(vout), getattr(self.o.payload, k).eq(c.o.payload.texels)]
            req = getattr(self.i.payload, k)
            for f in ("surface", "x0", "x1", "y0", "y1") + (("skip",) if k in self.skips else ()):
                m.d.comb += getattr(c.i.payload, f).eq(getattr(req, f))
        m.d.comb += cs[0].i.payload.side.eq(self.i.payload.side)
        busy = cs[0].busy
        for c in cs[1:]:
            busy = busy | c.busy
        m.d.comb += self.busy.eq(busy)
        self._read_port(m, cs)
        return m

    def _read_port(self, m, caches):
        """``AR`` granted round robin (the cache after the last one granted first; held until its handshake),
        owners in order, ``R`` beats to the owner."""
        axi = self.mem
        n = len(caches)
        ob = max(1, (n - 1).bit_length())
        depth = sum(c.params.misses for c in caches)
        m.submodules.owners = owners = SyncFIFO(width=ob, depth=depth)
        last, locked, held = Signal(ob), Signal(), Signal(ob)
        want = [c.mem.arvalid for c in caches]
        pick = Signal(ob)
        for start in range(n):                      # after ``start``: the next wanting one, round robin
            order = [(start + 1 + i) % n for i in range(n)]
            choice = Const(order[-1], ob)
            for i in reversed(order[:-1]):
                choice = Mux(want[i], i, choice)
            with m.If(last == start):
                m.d.comb += pick.eq(choice)
        grant = Signal(ob)
        m.d.comb += grant.eq(Mux(locked, held, pick))
        src = [c.mem for c in caches]
        wanted = Array(want)[grant] if n > 1 else want[0]
        m.d.comb += axi.arvalid.eq(wanted & owners.w_rdy)
        for k, s_ in enumerate(src):
            m.d.comb += s_.arready.eq(axi.arready & owners.w_rdy & (grant == k))
        for f in _AR:
            m.d.comb += getattr(axi, f).eq(Array(getattr(s_, f) for s_ in src)[grant] if n > 1 else getattr(src[0], f))
        fire = axi.arvalid & axi.arready
        m.d.comb += [owners.w_en.eq(fire), owners.w_data.eq(grant)]
        with m.If(fire):
            m.d.sync += [last.eq(grant), locked.eq(0)]
        with m.Elif(axi.arvalid):
            m.d.sync += [locked.eq(1), held.eq(grant)]
        owner = owners.r_data
        for k, s_ in enumerate(src):
            m.d.comb += [s_.rvalid.eq(axi.rvalid & owners.r_rdy & (owner == k)), s_.rdata.eq(axi.rdata),
                         s_.rresp.eq(axi.rresp), s_.rlast.eq(axi.rlast), s_.rid.eq(axi.rid),
                         s_.awready.eq(0), s_.wready.eq(0), s_.bvalid.eq(0)]
        m.d.comb += [axi.rready.eq(owners.r_rdy & Array(s_.rready for s_ in src)[owner]),
                     owners.r_en.eq(axi.rvalid & axi.rready & axi.rlast),
                     axi.awvalid.eq(0), axi.wvalid.eq(0), axi.bready.eq(1)]
