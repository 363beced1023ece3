"""Texel cache in front of an AXI4 memory: the blocking first version of :mod:`fxmodel.units.texcache`.

One lookup at a time: a request ``(x0, x1, y0, y1)`` (the bilinear footprint of one map in the model's blocked
:class:`~fxmodel.units.texcache.Layout`) comes in on the stream ``i``; its up to four distinct lines are checked in
corner order ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)`` exactly as :func:`fxmodel.units.texcache.simulate` does
(LRU, the lowest invalid way first, a duplicate line skipped without touching the replacement state); each miss
fetches its line with one AXI4 ``INCR`` burst of ``B^2`` beats (one 32-bit texel a beat) on the read channels of
``mem``, written into four data banks by texel parity; then the four texels are read, one per bank, and leave on
the stream ``o`` (corner 0 in the low bits). The memory traffic is therefore the model's, burst for burst
(``cosim/test_rtl_texcache.py`` checks the AR addresses and the beats against ``simulate``).

This version stalls on each miss for the memory's latency; the decoupled organisation that hides it (tags ahead of
the data, a lookup FIFO, fills written in lookup order; Igehy, Eldridge & Proudfoot 1998) is described in
``docs/texcache.md``. Limits: LRU only, a 32-bit bus (``bus_bytes = texel_bytes = 4``), no bank conflicts (no
``repeat`` across an odd map size), and no footprint whose lines evict each other (the model's ``self_evictions``
must be 0).
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from fxmodel.core.unit import require
from fxmodel.units.texcache import Layout, TexCacheParams
from rtl.rop import axi_signature

__all__ = ["TexCache"]


class TexCache(wiring.Component):
    """The cache of ``params`` over one map of ``height x width`` texels stored at ``base`` (a
    :class:`~fxmodel.units.texcache.Layout` of one surface). Ports: ``i`` (stream of ``x0, x1, y0, y1``, each
    :attr:`coord_bits` wide, ``x0`` in the low bits), ``o`` (stream of four texels of ``texel_bits``), ``mem``
    (AXI4 manager, ``addr_bits`` address bits, 32-bit data; only the read channels are used), ``busy``."""

    def __init__(self, params: TexCacheParams, height: int, width: int, base: int = 0, addr_bits: int = 32):
        require(params.replacement == "lru", "replacement", params.replacement, "must be 'lru' in this RTL")
        require(params.bus_bytes == 4 and params.texel_bytes == 4, "bus_bytes/texel_bytes",
                (params.bus_bytes, params.texel_bytes), "must both be 4 in this RTL (one texel a beat)")
        self.params = params
        self.layout = Layout(((("map", 0), height, width),), params.block, params.texel_bytes, base)
        require(self.layout.size_bytes + base <= 1 << addr_bits, "addr_bits", addr_bits, "too few for the map")
        self.addr_bits = addr_bits
        self.coord_bits = max(1, (max(height, width) - 1).bit_length())
        super().__init__({"i": In(stream.Signature(4 * self.coord_bits)),
                          "o": Out(stream.Signature(4 * params.texel_bits)),
                          "mem": Out(axi_signature(addr_bits, 32)), "busy": Out(1)})

    def _line_of(self, x, y):
        """``(line number, bx, by)`` of texel ``(x, y)`` (the layout's one surface)."""
        L, lb = self.layout, self.params.block.bit_length() - 1
        bx, by = x >> lb, y >> lb
        return (int(L.first_line[0]) + by * int(L.blocks_per_row[0]) + bx)[:self.addr_bits], bx, by

    def _set_of(self, x, y):
        """The set of texel ``(x, y)``'s line (:meth:`fxmodel.units.texcache.Layout.set_of`)."""
        P = self.params
        line, bx, by = self._line_of(x, y)
        if P.sets == 1:
            return Const(0, 1)
        s = P.sets.bit_length() - 1
        if P.index == "linear":
            return line[:s]
        h = (s + 1) // 2
        return (bx ^ (by << h) ^ (by >> (s - h)) ^ int(self.layout.first_line[0]))[:s]

    def _slot(self, set_, way):
        """First bank word of line slot ``(set, way)``."""
        return (set_ * self.params.ways + way) * (self.params.line_texels // 4)

    def elaborate(self, platform):
        m = Module()
        P = self.params
        W, S, cb = P.ways, P.sets, self.coord_bits
        t = SimpleNamespace(
            xs=[Signal(cb, name=f"x{k}") for k in range(4)], ys=[Signal(cb, name=f"y{k}") for k in range(4)],
            ways=[Signal(range(max(W, 2)), name=f"way{k}") for k in range(4)], k=Signal(2),
            tags=Array(Signal(self.addr_bits, name=f"tag{j}") for j in range(S * W)),
            valid=Array(Signal(name=f"valid{j}") for j in range(S * W)),
            age=Array(Signal(range(max(W, 2)), init=j % W, name=f"age{j}") for j in range(S * W)),
            beat=Signal(range(P.line_texels)))
        t.lines = [self._line_of(t.xs[k], t.ys[k])[0] for k in range(4)]
        t.sets = [self._set_of(t.xs[k], t.ys[k]) for k in range(4)]
        t.line_k, t.set_k, t.way_sel = Array(t.lines)[t.k], Array(t.sets)[t.k], Array(t.ways)
        self._tag_check(m, t)
        self._banks(m, t)
        self._fsm(m, t)
        return m

    def _tag_check(self, m, t):
        """Corner ``k``'s duplicate of an earlier corner's line (``dup``, ``dup_way``), hit (``hit``, ``hit_way``)
        and victim (the lowest invalid way, else the oldest)."""
        W = self.params.ways
        like = t.ways[0]
        t.dup, t.dup_way = Signal(), Signal.like(like)
        for j in reversed(range(3)):                         # the earliest matching corner wins
            with m.If((j < t.k) & (t.lines[j] == t.line_k)):
                m.d.comb += [t.dup.eq(1), t.dup_way.eq(t.ways[j])]
        t.hit, t.hit_way = Signal(), Signal.like(like)
        free, free_way, old_way = Signal(), Signal.like(like), Signal.like(like)
        for w in reversed(range(W)):                         # the lowest way wins
            j = t.set_k * W + w
            with m.If(t.valid[j] & (t.tags[j] == t.line_k)):
                m.d.comb += [t.hit.eq(1), t.hit_way.eq(w)]
            with m.If(~t.valid[j]):
                m.d.comb += [free.eq(1), free_way.eq(w)]
            with m.If(t.age[j] == W - 1):
                m.d.comb += old_way.eq(w)
        t.victim = Signal.like(like)
        m.d.comb += t.victim.eq(Mux(free, free_way, old_way))

    def _touch(self, m, t, w):
        """LRU: way ``w`` of set ``set_k`` becomes the youngest; the ways younger than it age by one."""
        W = self.params.ways
        base = t.set_k * W
        for v in range(W):
            with m.If(w == v):
                m.d.sync += t.age[base + v].eq(0)
            with m.Elif(t.age[base + v] < t.age[base + w]):
                m.d.sync += t.age[base + v].eq(t.age[base + v] + 1)

    def _banks(self, m, t):
        """The four data banks: fills from the ``R`` channel (beat ``n`` = texel ``(n mod B, n div B)`` of the
        line), reads at each corner's texel, and the AXI ``AR`` fields."""
        P = self.params
        B, lb = P.block, P.block.bit_length() - 1
        axi = self.mem
        m.d.comb += [axi.arid.eq(0), axi.arlen.eq(P.beats_per_line - 1), axi.arsize.eq(2), axi.arburst.eq(1),
                     axi.araddr.eq(t.line_k * P.line_bytes), axi.awvalid.eq(0), axi.wvalid.eq(0), axi.bready.eq(1)]
        r, c = t.beat >> lb, t.beat & (B - 1)
        fill_bank = Cat(c[0], r[0])
        fill_addr = self._slot(t.set_k, t.way_sel[t.k]) + (r >> 1) * (B // 2) + (c >> 1)
        t.read_ports = []
        for b in range(4):
            mem = Memory(shape=P.texel_bits, depth=P.lines * P.line_texels // 4, init=[])
            m.submodules[f"bank{b}"] = mem
            wp, rp = mem.write_port(), mem.read_port(domain="sync")
            t.read_ports.append(rp)
            m.d.comb += [wp.addr.eq(fill_addr), wp.data.eq(axi.rdata[:P.texel_bits]),
                         wp.en.eq(axi.rvalid & axi.rready & (fill_bank == b))]
            for q in range(4):                               # the corner of this bank's parity
                with m.If(Cat(t.xs[q][0], t.ys[q][0]) == b):
                    m.d.comb += rp.addr.eq(self._slot(t.sets[q], t.ways[q]) + ((t.ys[q] & (B - 1)) >> 1) * (B // 2)
                                           + ((t.xs[q] & (B - 1)) >> 1))
        rdata = Array(rp.data for rp in t.read_ports)
        m.d.comb += self.o.payload.eq(Cat(*(rdata[Cat(t.xs[q][0], t.ys[q][0])] for q in range(4))))

    def _fsm(self, m, t):
        """IDLE (take a request) -> CHECK each corner [-> AR -> FILL on a miss] -> READ -> OUT."""
        cb, W, axi = self.coord_bits, self.params.ways, self.mem

        def next_corner():
            with m.If(t.k == 3):
                m.next = "READ"
            with m.Else():
                m.d.sync += t.k.eq(t.k + 1)
                m.next = "CHECK"

        with m.FSM():
            with m.State("IDLE"):
                m.d.comb += self.i.ready.eq(1)
                with m.If(self.i.valid):
                    x0, x1, y0, y1 = (self.i.payload[q * cb:(q + 1) * cb] for q in range(4))
                    m.d.sync += [t.xs[0].eq(x0), t.xs[1].eq(x1), t.xs[2].eq(x0), t.xs[3].eq(x1),
                                 t.ys[0].eq(y0), t.ys[1].eq(y0), t.ys[2].eq(y1), t.ys[3].eq(y1), t.k.eq(0)]
                    m.next = "CHECK"
            with m.State("CHECK"):
                m.d.comb += self.busy.eq(1)
                with m.If(t.dup):
                    m.d.sync += t.way_sel[t.k].eq(t.dup_way)
                    next_corner()
                with m.Elif(t.hit):
                    m.d.sync += t.way_sel[t.k].eq(t.hit_way)
                    self._touch(m, t, t.hit_way)
                    next_corner()
                with m.Else():
                    j = t.set_k * W + t.victim
                    m.d.sync += [t.way_sel[t.k].eq(t.victim), t.tags[j].eq(t.line_k), t.valid[j].eq(1),
                                 t.beat.eq(0)]
                    self._touch(m, t, t.victim)
                    m.next = "AR"
            with m.State("AR"):
                m.d.comb += [self.busy.eq(1), axi.arvalid.eq(1)]
                with m.If(axi.arready):
                    m.next = "FILL"
            with m.State("FILL"):
                m.d.comb += [self.busy.eq(1), axi.rready.eq(1)]
                with m.If(axi.rvalid):
                    m.d.sync += t.beat.eq(t.beat + 1)
                    with m.If(axi.rlast):
                        next_corner()
            with m.State("READ"):                           # the read ports' enable is on (their default)
                m.d.comb += self.busy.eq(1)
                m.next = "OUT"
            with m.State("OUT"):                            # hold the read data while the sink waits
                m.d.comb += [self.busy.eq(1), self.o.valid.eq(1)]
                for rp in t.read_ports:
                    m.d.comb += rp.en.eq(0)
                with m.If(self.o.ready):
                    m.next = "IDLE"
