"""Texel cache with its tag check decoupled from its data (Igehy, Eldridge & Proudfoot, EGGH 1998): the RTL of
:mod:`fxmodel.units.texcache` that keeps taking lookups while its misses are in flight.

The pixel pipeline (paper, sections 3.2 and 4) makes bilinear lookups into maps that live in external memory; a
lookup is a footprint ``(x0 | x1, y0 | y1)`` on a surface of the model's blocked
:class:`~fxmodel.units.texcache.Layout` (a map and a MIP level: more surfaces are more entries of the layout, the
request names one by its index). Organisation (``docs/texcache.md``):

- **Input FIFO** (:data:`INPUT_DEPTH` lookups): ``i.ready`` is a register, so a stall does not travel up the
  stream in the clock the tag stage decides it.
- **Set stage**: the next lookup with its corners' lines (computed from the FIFO's output register) and sets
  (computed as the lookup enters that register, and held beside it), in registers, so that the sets address the
  tag store from flip-flops.
- **Prefetch stage**: the next lookup, its corners' lines and sets, each corner's set's row read from the tag
  store (:mod:`rtl.texcache_tags`, LUT RAM) and the compares of those rows with the lines, all in registers, the
  rows kept equal to the store while it waits.
- **Tag stage**: the lookup's up to four distinct lines in corner order ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)``
  against the tags (each corner's set's row and its compare's outcome taken from the prefetch stage, kept equal
  to the store), LRU or round robin, the lowest invalid way first, a duplicate line skipped -- exactly
  :func:`fxmodel.units.texcache.simulate`. LRU: all remaining lines in one clock when they fall in distinct sets
  and at most one of them misses (the common case: one line, or two neighbouring blocks, which the XOR index puts
  in different sets); otherwise one line a clock, in order (which of the two, and whether the step misses, is
  decided a clock ahead into registers: :meth:`DecoupledTexCache._decide_ahead`). Round robin: the lines up to
  the first miss in one clock, the fill of that line in the next. A fill changes tags, so the outcomes are then
  compared again from the held rows (a clock). A miss allocates its way at once and queues its line's ``AR``
  burst (``INCR``, ``B^2`` beats of one 32-bit texel), so several bursts are outstanding, in order (one ID).
- **Step write** (registers after the tag stage's step): the rows a step writes, with their sets, reach the tag
  store and every held row of their sets a clock later; meanwhile the step and the compares read the held rows
  with that pending write over them (:mod:`rtl.texcache_stepwrite`), so the behaviour is clock for clock the
  same.
- **Lookup FIFO** (:attr:`~fxmodel.units.texcache.TexCacheParams.lookup_depth` entries): each lookup's four bank
  word addresses, the bank of each corner, its fill count and its sideband, from the tag stage to the data stage.
- **Fill buffer** (:attr:`~fxmodel.units.texcache.TexCacheParams.misses` lines, four banks by texel parity): the
  ``R`` beats land there as they come (``rready`` is always high: a line's space is reserved when its miss is
  queued). The data stage copies a lookup's fills into the data banks (four texels a clock) only when that lookup
  is at the head of the FIFO, so a line replaced at tag time by a later miss is intact for every earlier lookup: no
  line locking. Then it reads the four banks (one read per bank) and the texels leave on ``o`` with the sideband,
  in order, two clocks later: the banks are read through their blocks' output registers (:mod:`rtl.bram`), so the
  texels leave flip-flops for the bank multiplexer and the consumer, not a block RAM's array (whose word comes
  more than half a 100 MHz clock after the edge); the read and the output are two stages that ``o.ready`` holds,
  the read taking the head whenever it is empty.
- **Stalls** only through the streams: the tag stage holds while the lookup FIFO is full, or a miss finds the
  outstanding budget (``misses``) spent, and ``i.ready`` falls when the input FIFO fills behind it; ``o.ready``
  low holds the data stage.

The memory traffic is the model's, burst for burst (the ``AR`` sequence is ``simulate``'s fills). Round robin
(``replacement = "fifo"``): a set's row holds one pointer instead of an age per way; a hit leaves the row as it is, a
fill moves the pointer past its way, and the victim skips the ways earlier steps of the same lookup used in that set
(their registered ways). Limits: LRU or round robin, a 32-bit bus (``bus_bytes = texel_bytes = 4``), no bank conflicts
and no self-evictions (the model counts both).
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from fxmodel.core.unit import require
from fxmodel.units.texcache import Layout, TexCacheParams
from rtl.rop import axi_signature

from .bram import RegisteredMemory
from .streams import TailFIFOBuffered
from .texcache_step import StepControl
from .texcache_stepwrite import compare_over, held_rows, step_write
from .texcache_tags import age_bits, compare, new_rows, row_states, state_bits, tag_store, victim
from .unit import with_next

__all__ = ["DecoupledTexCache", "request_layout", "INPUT_DEPTH", "HELD", "AFTER"]

#: Lookups the input FIFO holds: a ``SyncFIFOBuffered`` (registered ``w_rdy`` and output; here
#: :class:`rtl.streams.TailFIFOBuffered`, the corners' sets in its output register) takes one a clock from depth 3
#: (its inner FIFO of 2 has room while one entry leaves; at depth 2 it would take one every other clock).
INPUT_DEPTH = 3

#: Lookups held in registers between the input FIFO and the lookup FIFO: the set stage's (the next lookup with its
#: corners' lines and sets), the prefetch stage's and the tag stage's.
HELD = 3

#: Lookups held in registers after the lookup FIFO: its head (so that the data stage decides from flip-flops, not
#: from the block RAM's unregistered output), the data banks' read (stage 1) and their output registers (stage 2).
AFTER = 3


def request_layout(layout: Layout, side_bits: int = 0, skip: bool = False) -> data.StructLayout:
    """A lookup: ``surface`` (index into ``layout.surfaces``), ``x0, x1, y0, y1`` (wide enough for the largest
    surface), ``skip`` when ``skip`` (a lookup that is not needed: it passes through in order, its sideband with
    it, and touches no line: no tag, no replacement state, no fill; its texels are undefined), and ``side``
    (``side_bits``, carried to the output untouched) when ``side_bits > 0``."""
    cb = max(1, max(max(h, w) - 1 for _, h, w in layout.surfaces).bit_length())
    fields = {"surface": max(1, (len(layout.surfaces) - 1).bit_length()), "x0": cb, "x1": cb, "y0": cb, "y1": cb}
    if skip:
        fields["skip"] = 1
    if side_bits:
        fields["side"] = side_bits
    return data.StructLayout(fields)


def _corner_xy(req) -> tuple:
    """The corners' texel coordinates of a request, in corner order ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)``."""
    return [req.x0, req.x1, req.x0, req.x1], [req.y0, req.y0, req.y1, req.y1]


class DecoupledTexCache(StepControl, wiring.Component):
    """The decoupled cache of ``params`` over the surfaces of ``layout`` (module docstring).

    With ``skip``, a request has a ``skip`` bit (:func:`request_layout`): such a lookup checks no line (the
    model's trace leaves it out) and only keeps its place in the order.

    Ports: ``i`` (stream of :func:`request_layout`), ``o`` (stream of ``texels``, four of ``texel_bits``, corner 0
    in the low bits, and ``side``), ``mem`` (AXI4 manager, ``addr_bits`` address bits, 32-bit data; the read
    channels only), ``busy`` (a lookup or a fill anywhere inside).

    The **step write** stage (``docs/texcache.md``): a step's write -- per corner whether it writes, its set (and
    one-hot set) and its new row (tags, valid bits, LRU state or the round-robin pointer) -- goes into registers
    (``wp_*``, :func:`rtl.texcache_stepwrite.step_write`) and is applied in the next clock, from those registers, to
    the tag store's LUT RAMs and to every held row of the prefetch and tag stages in its set. So the step's victim
    and new row (from a held row's valid bits and LRU state) end in its own corner's registers, not in the held rows of
    the other corners of the same set, the prefetch stage's rows and the store's write ports. In the clock the write
    waits, the held rows and the store are a clock behind; whatever reads a row then reads it with the pending write
    over it (:func:`rtl.texcache_stepwrite.overlay`: the pending row of the corner that wrote its set, else the held
    row; a one-hot AND-OR whose selects, ``fw*`` and ``p_fw*``, are registers decided with the write): the step's
    victim and new row, the tag stage's compares taken again after a fill, the prefetch stage's compares and the
    rows the tag stage takes from the prefetch stage. The prefetch stage's load reads the store with the pending
    write over it in the same way. Nothing waits for the write: the behaviour is clock for clock that of a write in
    the step's own clock (formal invariants ``wp_*`` and ``fw*_is_pending_sets`` in ``formal/fetch.py``; the held
    rows and the store agree, both a clock behind).
    """

    def __init__(self, params: TexCacheParams, layout: Layout, side_bits: int = 0, addr_bits: int = 32,
                 skip: bool = False):
        require(params.replacement in ("lru", "fifo"), "replacement", params.replacement,
                "must be 'lru' or 'fifo' in this RTL")
        require(params.bus_bytes == 4 and params.texel_bytes == 4, "bus_bytes/texel_bytes",
                (params.bus_bytes, params.texel_bytes), "must both be 4 in this RTL (one texel a beat)")
        require(layout.block == params.block and layout.texel_bytes == params.texel_bytes, "layout",
                (layout.block, layout.texel_bytes), "must have the cache's block and texel_bytes")
        require(params.beats_per_line <= 256, "block", params.block, "must give a line of one burst (B^2 <= 256)")
        require(layout.base + layout.size_bytes <= 1 << addr_bits, "addr_bits", addr_bits, "too few for the layout")
        self.params, self.layout, self.side_bits, self.addr_bits = params, layout, side_bits, addr_bits
        last_line = layout.base // layout.line_bytes + layout.size_bytes // layout.line_bytes
        self.line_bits = max(1, (last_line - 1).bit_length())
        self.req = request_layout(layout, side_bits, skip)
        self.skip = skip
        out = {"texels": 4 * params.texel_bits}
        if side_bits:
            out["side"] = side_bits
        super().__init__({"i": In(stream.Signature(self.req)), "o": Out(stream.Signature(data.StructLayout(out))),
                          "mem": Out(axi_signature(addr_bits, 32)), "busy": Out(1)})

    # ---- geometry -----------------------------------------------------------------------------------------------
    def _line_set(self, surf, x, y):
        """Line number and set of texel ``(x, y)`` of surface ``surf`` (``Layout.blocks``, ``Layout.set_of``)."""
        P, L = self.params, self.layout
        lb = P.block.bit_length() - 1
        bx, by = x >> lb, y >> lb
        lines = [(int(L.first_line[k]) + by * int(L.blocks_per_row[k]) + bx)[:self.line_bits]
                 for k in range(len(L.surfaces))]
        line = Array(lines)[surf] if len(lines) > 1 else lines[0]
        if P.sets == 1:
            return line, Const(0, 1)
        s = P.sets.bit_length() - 1
        if P.index == "linear":
            return line, line[:s]
        h = (s + 1) // 2
        salt = Array(Const(int(v), self.line_bits) for v in L.first_line)[surf]
        return line, (bx ^ (by << h) ^ (by >> (s - h)) ^ salt)[:s]

    @property
    def _words(self) -> int:
        """Words a data bank holds per line (``B^2 / 4``)."""
        return self.params.line_texels // 4

    def _word(self, x, y):
        """Word of texel ``(x, y)`` within its line's quarter in its parity bank."""
        lb = self.params.block.bit_length() - 1
        return Cat(x[1:lb], y[1:lb])

    # ---- elaboration --------------------------------------------------------------------------------------------
    def elaborate(self, platform):
        m = Module()
        P = self.params
        slot_bits = max(1, (P.lines - 1).bit_length())
        f = SimpleNamespace(
            lfifo=SyncFIFOBuffered(width=self._entry_layout().size, depth=P.lookup_depth),
            arq=SyncFIFOBuffered(width=self.line_bits, depth=P.misses),
            slots=SyncFIFOBuffered(width=slot_bits, depth=P.misses),
            inflight=Signal(range(P.misses + 1), name="inflight"), miss_now=Signal(name="miss_now"),
            copy_done=Signal(name="copy_done"))
        m.submodules.lfifo, m.submodules.arq, m.submodules.slots = f.lfifo, f.arq, f.slots
        f.inflight_next = with_next(m, f.inflight)
        m.d.comb += f.inflight_next.eq(f.inflight + f.miss_now - f.copy_done)
        self._tag_stage(m, f, platform)
        self._memory_port(m, f)
        self._data_stage(m, f, platform)
        return m

    def _entry_layout(self) -> data.StructLayout:
        """One lookup-FIFO entry: a word address per data bank, the bank of each corner, the fill count, the
        sideband (:attr:`fxmodel.units.texcache.TexCacheParams.lookup_bits` plus ``side_bits``)."""
        ab = max(1, (self.params.lines * self._words - 1).bit_length())
        fields = {"addr": data.ArrayLayout(ab, 4), "bank": data.ArrayLayout(2, 4), "fills": 3}
        if self.side_bits:
            fields["side"] = self.side_bits
        return data.StructLayout(fields)

    def corner_lines(self, req) -> list[tuple]:
        """The line and set of each corner of ``req`` (corner order ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)``), as
        expressions of ``req``."""
        xs, ys = _corner_xy(req)
        return [self._line_set(req.surface, xs[q], ys[q]) for q in range(4)]

    def _lines(self, m, req, prefix):
        """The line and set of each corner of ``req`` (:meth:`corner_lines`) in signals named with ``prefix``."""
        c = [SimpleNamespace() for _ in range(4)]
        for q, (line, set_) in enumerate(self.corner_lines(req)):
            c[q].line, c[q].set = Signal.like(line, name=f"{prefix}line{q}"), Signal.like(set_, name=f"{prefix}set{q}")
            m.d.comb += [c[q].line.eq(line), c[q].set.eq(set_)]
        return c

    @staticmethod
    def _relations(m, c, prefix):
        """Whether each corner of ``c`` repeats an earlier corner's line (and the earliest such corner, ``dup`` and
        ``src`` added to ``c``), and which corners share a set (returned)."""
        for q in range(4):
            c[q].dup, c[q].src = Signal(name=f"{prefix}dup{q}"), Signal(2, name=f"{prefix}src{q}")
            m.d.comb += c[q].src.eq(q)
            for j in reversed(range(q)):                        # the earliest corner with the same line
                with m.If(c[j].line == c[q].line):
                    m.d.comb += [c[q].dup.eq(1), c[q].src.eq(j)]
        same = {}
        for q in range(4):
            for j in range(q):
                same[q, j] = Signal(name=f"{prefix}same{q}_{j}")
                m.d.comb += same[q, j].eq(c[q].set == c[j].set)
        return same

    def _input_stage(self, m):
        """The input FIFO and a register stage after it (``s_valid``) that holds the next lookup with its corner
        lines and sets: ``(ififo, s_valid, nreq, nc, nsame)``, so that the sets address the tag store from
        flip-flops (each corner's ``next_set``: the set the stage loads, for the tag store's live-value table read
        a clock early); the duplicates and equal sets (:meth:`_relations`) are compared there. The lines are
        computed from the FIFO's output register (:meth:`_lines`); the sets as the lookup enters that register,
        which holds them beside it (:class:`rtl.streams.TailFIFOBuffered`), so that ``next_set`` is a register
        itself: it selects a table entry of every set, through the forwarding, into the read ports' registers (the
        Berlin wall engine's caches missed their target there, from the FIFO's output through the XOR index)."""
        def corner_sets(word):
            return Cat(*(set_ for _, set_ in self.corner_lines(self.req(word))))

        m.submodules.ififo = ififo = TailFIFOBuffered(width=self.req.size, depth=INPUT_DEPTH, tail=corner_sets)
        sb = len(ififo.r_tail) // 4
        m.d.comb += [ififo.w_en.eq(self.i.valid), ififo.w_data.eq(self.i.payload), self.i.ready.eq(ififo.w_rdy)]
        freq = Signal(self.req, name="freq")
        m.d.comb += freq.eq(ififo.r_data)
        fc = self._lines(m, freq, "f_")
        for q in range(4):      # the sets the register took with the lookup: the lines' (formal ``ififo_tail``)
            fc[q].set = ififo.r_tail[q * sb:(q + 1) * sb]
        s_valid, nreq = Signal(name="s_valid"), Signal(self.req, name="nreq")
        nc = [SimpleNamespace(line=Signal.like(fc[q].line, name=f"nline{q}"),
                              set=Signal(sb, name=f"nset{q}"), next_set=fc[q].set) for q in range(4)]
        with m.If(ififo.r_en):
            m.d.sync += [s_valid.eq(ififo.r_rdy), nreq.eq(freq)]
            m.d.sync += [x.eq(y) for q in range(4) for x, y in ((nc[q].line, fc[q].line), (nc[q].set, fc[q].set))]
        return ififo, s_valid, nreq, nc, self._relations(m, nc, "n")

    def _held(self, m, nc, prefix):
        """A lookup held in registers: its request, valid bit, corners (line, set, duplicate and its source, the set
        one-hot, the set's row) and which corners share a set, named with ``prefix``."""
        P = self.params
        valid = f"{prefix}valid" if prefix else "t_valid"
        h = SimpleNamespace(req=Signal(self.req, name=f"{prefix}req"), valid=Signal(name=valid))
        h.valid_next = with_next(m, h.valid)
        h.c = [SimpleNamespace() for _ in range(4)]
        for q, cq in enumerate(h.c):
            cq.line = Signal.like(nc[q].line, name=f"{prefix}line{q}")
            cq.set = Signal.like(nc[q].set, name=f"{prefix}set{q}")
            cq.dup, cq.src = Signal(name=f"{prefix}dup{q}"), Signal(2, name=f"{prefix}src{q}")
            cq.hot = Signal(P.sets, name=f"{prefix}hot{q}")  # the set, one-hot (the store's enables: wp_hot)
            cq.tags = [Signal(self.line_bits, name=f"{prefix}row_tag{q}_{w}") for w in range(P.ways)]
            cq.valids = [Signal(name=f"{prefix}row_valid{q}_{w}") for w in range(P.ways)]
            cq.states = [Signal(state_bits(P), name=f"{prefix}row_state{q}_{w}") for w in range(row_states(P))]
        h.same = {(q, j): Signal(name=f"{prefix}same{q}_{j}") for q in range(4) for j in range(q)}
        return h

    def _load(self, m, dst, src, sets):
        """``dst``'s request, corners and set equalities from ``src`` (``sets``: the one-hot sets computed or held)."""
        m.d.sync += dst.req.eq(src.req)
        m.d.comb += dst.valid_next.eq(1)
        for q in range(4):
            d, s_ = dst.c[q], src.c[q]
            m.d.sync += [d.line.eq(s_.line), d.set.eq(s_.set), d.dup.eq(s_.dup), d.src.eq(s_.src), d.hot.eq(sets[q])]
        m.d.sync += [dst.same[key].eq(src.same[key]) for key in dst.same]

    def _tag_stage(self, m, f, platform):
        """The input FIFO, the set stage, the prefetch stage and the tag stage: the held lookup's corners against
        its sets' rows, a step of one or more corners a clock.

        Timing (``docs/texcache.md``): ``i.ready`` is the input FIFO's registered ``w_rdy``, so no decision of
        the tag stage reaches the stream before it. The **set stage** (:meth:`_input_stage`) holds the next lookup
        with its corners' lines and sets in registers. The **prefetch stage** takes it from there with its
        duplicates and each corner's set's row from the tag store
        (:func:`rtl.texcache_tags.tag_store`, the pending write over it), all into registers, keeps those rows
        equal to the store while it holds them (a step's write reaches every held row of its set with the store), and
        compares them with its lines. The **tag stage** takes the lookup from the prefetch stage with its rows (the
        pending write over them) and its compares' outcomes (hit, way): a register copy. A step decides from those
        registers; a fill changes tags, so after it the outcomes are taken again from the held rows (a clock; with LRU
        a second one, in which the step is decided from them: :meth:`_outcomes`). The
        compares never reach the lookup's acceptance, and the store's read never reaches the tag stage. The step's
        write waits a clock in registers (the **step write** stage: the class's docstring,
        :mod:`rtl.texcache_stepwrite`) before it reaches the store and the held rows, which are read with it over
        them meanwhile."""
        P = self.params
        W = P.ways
        wb = age_bits(W)
        rr = P.replacement == "fifo"
        ififo, s_valid, nreq, nc, nsame = self._input_stage(m)
        pre, t = self._held(m, nc, "p_"), self._held(m, nc, "")
        req, t_valid, c, same = t.req, t.valid, t.c, t.same
        k, nf = Signal(2, name="k"), Signal(3, name="nf")  # next corner to check, fills so far
        k_next = with_next(m, k)
        way_reg = [Signal(wb, name=f"way_reg{q}") for q in range(4)]
        # the step's write, pending a clock, and the held rows with it over them (rtl/texcache_stepwrite.py)
        sw = step_write(m, P, self.line_bits, c, pre, nc)
        wp, eff = sw.wp, sw.eff
        # the outcomes: the prefetch stage's compares (term by term, under the pending write); the tag stage's,
        # registered, and whether they are current
        for q in range(4):
            pre.c[q].hit, pre.c[q].hit_way = compare_over(m, pre.c[q], wp, sw.pfw[q], pre.c[q].line, f"p_{q}_")
            c[q].cmp_hit, c[q].cmp_way = compare(m, eff[q].tags, eff[q].valids, c[q].line, f"t_{q}_")
            c[q].hit, c[q].hit_way = Signal(name=f"hit{q}"), Signal(wb, name=f"hit_way{q}")
        hits_ok = Signal(name="hits_ok")
        # LRU: the outcomes taken again after a fill, the decision not yet (it is taken from them a clock later)
        fresh = None if rr else Signal(name="hits_fresh")
        for q in range(4):
            # round robin: the ways of this corner's set that earlier steps of the lookup used (its victim skips them)
            used = [sum((k > j) & ~c[j].dup & same[q, j] & (way_reg[j] == v) for j in range(q)) != 0 if q else Const(0)
                    for v in range(W)] if rr else None
            c[q].victim = victim(m, P, eff[q].valids, eff[q].states, used, f"c{q}_")
        live = self._live(m, c, req, lambda q: q >= k, "live")  # distinct and not yet checked
        upd, mq = Signal(name="upd"), Signal(2, name="mq")     # round robin: corner mq's fill is this step
        if rr:
            act, step_miss, last, first = self._steps_two_phase(m, c, live, upd, mq)
        else:
            act, step_miss, last, ahead = self._steps_one_phase(m, c, live, same, k, platform)
        fire, accept, p_load, room = self._handshake(m, f, (s_valid, ififo), pre.valid, (t_valid, hits_ok), last,
                                                     step_miss, None if rr else ahead, platform)
        if not rr:
            self._decide_ahead(m, ahead, (c, req, live, same, k), pre, fresh, accept, fire & ~last)
        with m.If(p_load):
            self._load(m, pre, SimpleNamespace(req=nreq, c=nc, same=nsame),
                       [Const(1, P.sets) << nc[q].set for q in range(4)])
        with m.Elif(accept):
            m.d.comb += pre.valid_next.eq(0)
        self._advance(m, (pre, t), (fire, accept, last, step_miss),
                      SimpleNamespace(k=k, k_next=k_next, nf=nf, upd=upd, mq=mq, first=first if rr else None))
        # whether a corner that acts fills its victim: on a miss (LRU), in the fill step only (round robin)
        filling = [upd if rr else ~c[q].hit for q in range(4)]
        # ways: this step's, else the registered ones; a duplicate takes its source's
        way_now = [Signal(wb, name=f"way_now{q}") for q in range(4)]
        for q in range(4):
            m.d.comb += way_now[q].eq(Mux(act[q], Mux(filling[q], c[q].victim, c[q].hit_way), way_reg[q]))
            with m.If(fire & act[q]):
                m.d.sync += way_reg[q].eq(way_now[q])
        way_of = Array(way_now)
        ways = [Signal(wb, name=f"way_eff{q}") for q in range(4)]
        for q in range(4):
            m.d.comb += ways[q].eq(way_of[c[q].src])
        # the rows a step writes: every checked corner's (LRU), the filled corner's only (round robin: a hit
        # changes no row); a fill changes tags, so the outcomes are taken again
        wr = [Signal(name=f"wr{q}") for q in range(4)]
        for q in range(4):
            m.d.comb += wr[q].eq(fire & act[q] & (upd if rr else 1))
        fills = [act[q] & filling[q] for q in range(4)]
        hits_ok_next = self._outcomes(m, c, pre, hits_ok, accept, fire & (sum(fills) != 0), fresh)
        if not rr:   # the step's firing and whether it is the lookup's last, from the registers' next values
            self._fire_ahead(m, ahead, SimpleNamespace(t_valid=t.valid_next, hits_ok=hits_ok_next, room=room[1],
                                                       allin=ahead.allin_next, k=k_next,
                                                       step_miss=ahead.step_miss_next, inflight=f.inflight_next))
        new = new_rows(m, P, self.line_bits, [SimpleNamespace(line=c[q].line, tags=eff[q].tags, valids=eff[q].valids,
                                                             states=eff[q].states, hit=c[q].hit, victim=c[q].victim)
                                              for q in range(4)], way_now)
        stored = tag_store(m, P, self.line_bits, wp, [wp[j].en for j in range(4)], [wp[j].row for j in range(4)],
                           platform, read_sets=[nc[q].set for q in range(4)], load=ififo.r_en,
                           next_sets=[nc[q].next_set for q in range(4)])
        held_rows(m, P, sw, c, pre, nc, same, wr, new, p_load, accept, stored)
        self._queue(m, f, c, req, fills, fire, last, step_miss, nf, ways)
        f.tag_busy = t_valid | pre.valid | s_valid | (ififo.level != 0)   # a lookup in the input FIFO or held

    def _queue(self, m, f, c, req, fills, fire, last, step_miss, nf, ways):
        """The step's miss (at most one: the corner ``fills`` names) into the ``AR`` queue and the slot queue; the
        lookup's entry into the lookup FIFO when its last step fires."""
        P = self.params
        W = P.ways
        xs, ys = _corner_xy(req)
        mline, mslot = Signal(self.line_bits), Signal(f.slots.width)
        for q in reversed(range(4)):
            with m.If(fills[q]):
                m.d.comb += [mline.eq(c[q].line), mslot.eq(c[q].set * W + c[q].victim)]
        m.d.comb += [f.miss_now.eq(fire & step_miss), f.arq.w_en.eq(f.miss_now), f.arq.w_data.eq(mline),
                     f.slots.w_en.eq(f.miss_now), f.slots.w_data.eq(mslot)]
        # the lookup's entry when its last step fires
        entry = Signal(self._entry_layout())
        m.d.comb += entry.fills.eq(nf + step_miss)
        if self.side_bits:
            m.d.comb += entry.side.eq(req.side)
        for q in range(4):
            m.d.comb += entry.bank[q].eq(Cat(xs[q][0], ys[q][0]))
        for b in range(4):
            for q in reversed(range(4)):                         # the first corner of this bank's parity
                with m.If(Cat(xs[q][0], ys[q][0]) == b):
                    slot = c[q].set * W + ways[q]
                    m.d.comb += entry.addr[b].eq(slot * self._words + self._word(xs[q], ys[q]))
        m.d.comb += [f.lfifo.w_en.eq(fire & last), f.lfifo.w_data.eq(entry)]

    def _memory_port(self, m, f):
        """``AR`` from the queue; ``R`` beats into the fill buffer (beat ``n`` = texel ``(n mod B, n div B)``)."""
        P, axi = self.params, self.mem
        lb = P.block.bit_length() - 1
        m.d.comb += [axi.arid.eq(0), axi.arlen.eq(P.beats_per_line - 1), axi.arsize.eq(2), axi.arburst.eq(1),
                     axi.araddr.eq(f.arq.r_data * P.line_bytes), axi.arvalid.eq(f.arq.r_rdy),
                     f.arq.r_en.eq(axi.arready), axi.awvalid.eq(0), axi.wvalid.eq(0), axi.bready.eq(1),
                     axi.rready.eq(1)]
        beat, wring = Signal(range(P.line_texels), name="beat"), Signal(range(P.misses), name="wring")
        f.filled = Signal(range(P.misses + 1))                  # complete lines in the buffer
        f.line_in = Signal()
        r = SimpleNamespace(c=beat[:lb], r=beat[lb:2 * lb])
        word = Cat(r.c[1:], r.r[1:])
        f.fill_banks = []
        for b in range(4):
            mem = Memory(shape=P.texel_bits, depth=P.misses * self._words, init=[])
            m.submodules[f"fill{b}"] = mem
            wp = mem.write_port()
            addr = Cat(word, wring) if P.misses > 1 else word
            m.d.comb += [wp.addr.eq(addr), wp.data.eq(axi.rdata[:P.texel_bits]),
                         wp.en.eq(axi.rvalid & (Cat(r.c[0], r.r[0]) == b))]
            f.fill_banks.append(mem.read_port(domain="sync"))
        with m.If(axi.rvalid):
            m.d.sync += beat.eq(beat + 1)
            with m.If(beat == P.line_texels - 1):
                m.d.comb += f.line_in.eq(1)
                m.d.sync += wring.eq(wring + 1 if P.misses > 1 else 0)

    def _data_stage(self, m, f, platform):
        """Copy the head lookup's fills into the data banks, then read its four texels (one read per bank). The
        head is a register loaded from the lookup FIFO (``h_valid``, ``head``): the fill count, the bank addresses
        and the corners' banks come from flip-flops, not from the FIFO's block RAM. Whether the head is ready to
        leave (it holds a lookup whose fills are all copied, none being copied) is a register too (``head_ready``),
        decided a clock ahead: a new head's is that it has no fills, a kept head's that its fills are copied after
        this clock's copy; the FIFO's read picks at the last level (formal invariant ``head_ready_decided_ahead``).
        The read is the FIFO's read enable, and through its inner read the lookup FIFO's room and the tag stage's
        firing decided ahead: it ran from the compare of the copied fills across the die into them."""
        P = self.params
        Q = self._words
        ent, h_valid = Signal(self._entry_layout(), name="head"), Signal(name="h_valid")
        m.d.sync += f.filled.eq(f.filled + f.line_in - f.copy_done)
        done, copying = Signal(3, name="done"), Signal(name="copying")
        cc, rring = Signal(range(Q + 1), name="cc"), Signal(range(P.misses), name="rring")
        start = h_valid & (done != ent.fills) & (f.filled != 0) & ~copying
        with m.If(start):
            m.d.sync += [copying.eq(1), cc.eq(0)]
        finish = copying & (cc == Q)                             # a fill's last word copied in this clock
        with m.If(copying):
            m.d.sync += cc.eq(cc + 1)
        with m.If(finish):
            m.d.comb += [f.copy_done.eq(1), f.slots.r_en.eq(1)]
            m.d.sync += [copying.eq(0), done.eq(done + 1), rring.eq(rring + 1 if P.misses > 1 else 0)]
        rd_word = cc[:(Q - 1).bit_length()]
        for rp in f.fill_banks:
            m.d.comb += rp.addr.eq(Cat(rd_word, rring) if P.misses > 1 else rd_word)
        # the read (stage 1: the banks' read registers) and the output (stage 2: their output registers), each
        # with its valid bit, bank selects and sideband; the read takes the head when it is empty or moves on
        o_valid, sel = Signal(name="o_valid"), Signal(data.ArrayLayout(2, 4), name="sel")
        rd_valid, rd_sel = Signal(name="rd_valid"), Signal(data.ArrayLayout(2, 4), name="rd_sel")
        side, rd_side = Signal(max(1, self.side_bits)), Signal(max(1, self.side_bits), name="rd_side")
        advance = ~o_valid | self.o.ready
        read = Signal(name="read")
        m.d.comb += read.eq(~rd_valid | advance)
        ready = Signal(name="head_ready")
        kept = h_valid & ((done + finish)[:len(done)] == ent.fills) & ~(start | (copying & ~finish))
        new = f.lfifo.r_rdy & (data.View(self._entry_layout(), f.lfifo.r_data).fills == 0)
        m.d.sync += ready.eq(Mux(f.lfifo.r_en, new, kept))
        if platform == "formal":   # the same from this clock's registers (invariant head_ready_decided_ahead)
            m.d.comb += Signal(name="now_head_ready").eq(h_valid & (done == ent.fills) & ~copying)
        banks = []
        for b in range(4):
            mem = RegisteredMemory(P.texel_bits, P.lines * Q, name=f"bank{b}", enables=True)
            m.submodules[f"bank{b}"] = mem
            wp = mem.write_port()
            banks.append(mem)
            slot_word = (f.slots.r_data * Q + (cc - 1))[:len(wp.addr)]
            m.d.comb += [wp.addr.eq(slot_word), wp.data.eq(f.fill_banks[b].data), wp.en.eq(copying & (cc != 0)),
                         mem.r_addr.eq(ent.addr[b]), mem.r_en.eq(read), mem.o_en.eq(advance)]
        take = Signal(name="take")                               # the head's texels read: it leaves
        m.d.comb += take.eq(read & ready)
        with m.If(read):
            m.d.sync += [rd_valid.eq(ready), rd_sel.eq(ent.bank), rd_side.eq(ent.side if self.side_bits else 0)]
        with m.If(take):
            m.d.sync += done.eq(0)
        with m.If(advance):
            m.d.sync += [o_valid.eq(rd_valid), sel.eq(rd_sel), side.eq(rd_side)]
        m.d.comb += f.lfifo.r_en.eq(~h_valid | take)
        with m.If(f.lfifo.r_en):
            m.d.sync += [h_valid.eq(f.lfifo.r_rdy), ent.eq(f.lfifo.r_data)]
        rdata = Array(mem.r_data for mem in banks)
        m.d.comb += [self.o.valid.eq(o_valid), self.o.payload.texels.eq(Cat(*(rdata[sel[q]] for q in range(4))))]
        if self.side_bits:
            m.d.comb += self.o.payload.side.eq(side)
        m.d.comb += self.busy.eq(f.tag_busy | f.lfifo.r_rdy | h_valid | rd_valid | o_valid | (f.inflight != 0))
