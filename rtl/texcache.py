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

    def elaborate(self, platform):
        m = Module()
        P, L = self.params, self.layout
        B, W, S = P.block, P.ways, P.sets
        lb = B.bit_length() - 1                              # log2 B
        cb = self.coord_bits
        bank_words = P.lines * P.line_texels // 4
        banks = []
        for b in range(4):
            mem = Memory(shape=P.texel_bits, depth=bank_words, init=[])
            m.submodules[f"bank{b}"] = mem
            banks.append((mem.write_port(), mem.read_port(domain="sync")))

        line_bits = self.addr_bits
        xs = [Signal(cb, name=f"x{k}") for k in range(4)]
        ys = [Signal(cb, name=f"y{k}") for k in range(4)]
        ways = [Signal(range(max(W, 2)), name=f"way{k}") for k in range(4)]
        tags = Array(Signal(line_bits, name=f"tag{j}") for j in range(S * W))
        valid = Array(Signal(name=f"valid{j}") for j in range(S * W))
        age = Array(Signal(range(max(W, 2)), init=j % W, name=f"age{j}") for j in range(S * W))

        def line_of(x, y):
            bx, by = x >> lb, y >> lb
            return (int(L.first_line[0]) + by * int(L.blocks_per_row[0]) + bx)[:line_bits], bx, by

        def set_of(x, y):
            line, bx, by = line_of(x, y)
            if S == 1:
                return Const(0, 1)
            s = S.bit_length() - 1
            if P.index == "linear":
                return line[:s]
            h = (s + 1) // 2
            return (bx ^ (by << h) ^ (by >> (s - h)) ^ int(L.first_line[0]))[:s]

        lines = [line_of(xs[k], ys[k])[0] for k in range(4)]
        sets = [set_of(xs[k], ys[k]) for k in range(4)]
        k = Signal(2)
        line_k, set_k = Array(lines)[k], Array(sets)[k]
        way_sel = Array(ways)
        # a duplicate of an earlier corner's line: its way
        dup = Signal()
        dup_way = Signal.like(ways[0])
        for j in reversed(range(3)):
            with m.If((j < k) & (lines[j] == line_k)):
                m.d.comb += [dup.eq(1), dup_way.eq(ways[j])]
        # tag check of corner k
        hit, hit_way = Signal(), Signal.like(ways[0])
        free, free_way, old_way = Signal(), Signal.like(ways[0]), Signal.like(ways[0])
        for w in reversed(range(W)):
            j = set_k * W + w
            with m.If(valid[j] & (tags[j] == line_k)):
                m.d.comb += [hit.eq(1), hit_way.eq(w)]
            with m.If(~valid[j]):
                m.d.comb += [free.eq(1), free_way.eq(w)]
            with m.If(age[j] == W - 1):
                m.d.comb += old_way.eq(w)
        victim = Signal.like(ways[0])
        m.d.comb += victim.eq(Mux(free, free_way, old_way))

        def touch(w):
            """LRU: way ``w`` of set ``set_k`` becomes the youngest; the ways younger than it age by one."""
            base = set_k * W
            for v in range(W):
                with m.If(w == v):
                    m.d.sync += age[base + v].eq(0)
                with m.Elif(age[base + v] < age[base + w]):
                    m.d.sync += age[base + v].eq(age[base + v] + 1)

        beat = Signal(range(P.line_texels))
        axi = self.mem
        m.d.comb += [axi.arid.eq(0), axi.arlen.eq(P.beats_per_line - 1), axi.arsize.eq(2), axi.arburst.eq(1),
                     axi.araddr.eq(line_k * P.line_bytes), axi.awvalid.eq(0), axi.wvalid.eq(0), axi.bready.eq(1)]
        slot_k = (set_k * W + way_sel[k]) * (P.line_texels // 4)
        r, c = beat >> lb, beat & (B - 1)
        fill_bank = Cat(c[0], r[0])
        fill_addr = slot_k + (r >> 1) * (B // 2) + (c >> 1)
        for b, (wp, _) in enumerate(banks):
            m.d.comb += [wp.addr.eq(fill_addr), wp.data.eq(axi.rdata[:P.texel_bits]),
                         wp.en.eq(axi.rvalid & axi.rready & (fill_bank == b))]
        # the read of the four texels: each bank at the corner of its parity
        for b, (_, rp) in enumerate(banks):
            for q in range(4):
                with m.If(Cat(xs[q][0], ys[q][0]) == b):
                    slot = (sets[q] * W + ways[q]) * (P.line_texels // 4)
                    m.d.comb += rp.addr.eq(slot + ((ys[q] & (B - 1)) >> 1) * (B // 2) + ((xs[q] & (B - 1)) >> 1))
        rdata = Array(rp.data for _, rp in banks)
        m.d.comb += self.o.payload.eq(Cat(*(rdata[Cat(xs[q][0], ys[q][0])] for q in range(4))))

        def next_corner():
            with m.If(k == 3):
                m.next = "READ"
            with m.Else():
                m.d.sync += k.eq(k + 1)
                m.next = "CHECK"

        with m.FSM():
            with m.State("IDLE"):
                m.d.comb += self.i.ready.eq(1)
                with m.If(self.i.valid):
                    p = self.i.payload
                    m.d.sync += [xs[0].eq(p[:cb]), xs[1].eq(p[cb:2 * cb]), xs[2].eq(p[:cb]), xs[3].eq(p[cb:2 * cb]),
                                 ys[0].eq(p[2 * cb:3 * cb]), ys[1].eq(p[2 * cb:3 * cb]), ys[2].eq(p[3 * cb:]),
                                 ys[3].eq(p[3 * cb:]), k.eq(0)]
                    m.next = "CHECK"
            with m.State("CHECK"):
                m.d.comb += self.busy.eq(1)
                with m.If(dup):
                    m.d.sync += way_sel[k].eq(dup_way)
                    next_corner()
                with m.Elif(hit):
                    m.d.sync += way_sel[k].eq(hit_way)
                    touch(hit_way)
                    next_corner()
                with m.Else():
                    m.d.sync += [way_sel[k].eq(victim), tags[set_k * W + victim].eq(line_k),
                                 valid[set_k * W + victim].eq(1), beat.eq(0)]
                    touch(victim)
                    m.next = "AR"
            with m.State("AR"):
                m.d.comb += [self.busy.eq(1), axi.arvalid.eq(1)]
                with m.If(axi.arready):
                    m.next = "FILL"
            with m.State("FILL"):
                m.d.comb += [self.busy.eq(1), axi.rready.eq(1)]
                with m.If(axi.rvalid):
                    m.d.sync += beat.eq(beat + 1)
                    with m.If(axi.rlast):
                        next_corner()
            with m.State("READ"):
                m.d.comb += self.busy.eq(1)
                for _, rp in banks:
                    m.d.comb += rp.en.eq(1)
                m.next = "OUT"
            with m.State("OUT"):
                m.d.comb += [self.busy.eq(1), self.o.valid.eq(1)]
                for _, rp in banks:
                    m.d.comb += rp.en.eq(0)
                with m.If(self.o.ready):
                    m.next = "IDLE"
        return m

