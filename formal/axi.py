"""AXI4 manager properties (AMBA AXI4; modelled on the properties of ZipCPU's ``faxi_master.v``, written anew in
Amaranth): what a manager port must do is asserted, what the memory behind it may do is assumed.

Asserted of the manager: ``AW``, ``W``, ``AR`` valid and every field hold until ready; bursts legal (not the
reserved type, size within the bus, an INCR burst inside one 4 KB page, WRAP lengths 2/4/8/16); ``WLAST`` exactly
on the last beat of its burst (the burst lengths of ``AW`` kept in a queue, ``W`` allowed to lead ``AW`` by one
burst); one ID; bursts outstanding on each channel at most ``max_out``.

Assumed of the memory: ``B`` and ``R`` hold until ready; no response without a request (``B`` only for a burst
whose address and last data beat were sent, ``R`` only for an accepted ``AR``, ``RLAST`` on the last beat of the
oldest read burst); the manager's ID on every response; bounded stalls: each ready within ``stall`` cycles of
its valid, a response owed arrives within ``stall`` cycles.
"""

from __future__ import annotations

from amaranth.hdl import Array, Cat, Mux, Signal

from .props import Harness, bits_for

__all__ = ["AxiManagerCheck"]


class _LenQueue:
    """Burst lengths in a ring of registers (push at the tail, pop at the head)."""

    def __init__(self, h: Harness, n: int, name: str):
        self.n = n
        self.regs = Array(Signal(8, name=f"f_{name}_len{k}") for k in range(n))
        self.head = Signal(range(n), name=f"f_{name}_head")
        self.count = Signal(range(n + 1), name=f"f_{name}_count")
        self.h, self.name = h, name

    def head_len(self):
        return self.regs[self.head]

    def update(self, push, value, pop):
        m = self.m = self.h.m
        tail = Signal(range(self.n), name=f"f_{self.name}_tail")
        m.d.comb += tail.eq(Mux(self.head + self.count >= self.n, self.head + self.count - self.n,
                                self.head + self.count))
        with m.If(push):
            m.d.sync += self.regs[tail].eq(value)
        with m.If(pop):
            m.d.sync += self.head.eq(Mux(self.head == self.n - 1, 0, self.head + 1))
        m.d.sync += self.count.eq(self.count + push - pop)
        self.h.check(~push | pop | (self.count < self.n), f"{self.name}_queue_room")


class AxiManagerCheck:
    """The properties of one AXI4 manager port ``axi`` (members named as :func:`rtl.rop.axi_signature`).

    Parameters
    ----------
    h : Harness
    axi : the port (the design's interface object)
    max_out : int
        Bursts outstanding per channel at most (asserted).
    stall : int
        The memory's bounded stalls (assumed).
    id_value : int
        The one ID the manager uses.
    """

    def __init__(self, h: Harness, axi, *, max_out: int, stall: int, id_value: int = 0):
        self.h, self.axi, self.max_out, self.stall = h, axi, max_out, stall
        data_bytes = len(axi.wdata) // 8
        a = axi
        h.stream_hold(a.awvalid, a.awready, Cat(a.awid, a.awaddr, a.awlen, a.awsize, a.awburst), "aw")
        h.stream_hold(a.wvalid, a.wready, Cat(a.wdata, a.wstrb, a.wlast), "w")
        h.stream_hold(a.arvalid, a.arready, Cat(a.arid, a.araddr, a.arlen, a.arsize, a.arburst), "ar")
        h.stream_hold(a.bvalid, a.bready, Cat(a.bid, a.bresp), "b", assume=True)
        h.stream_hold(a.rvalid, a.rready, Cat(a.rid, a.rdata, a.rresp, a.rlast), "r", assume=True)
        for ch in ("aw", "ar"):
            self._burst_legal(ch, data_bytes)
            h.check(~getattr(a, f"{ch}valid") | (getattr(a, f"{ch}id") == id_value), f"{ch}_one_id")
        h.check(~a.bvalid | (a.bid == id_value), "b_id", assume=True)
        h.check(~a.rvalid | (a.rid == id_value), "r_id", assume=True)
        self.stalls = {ch: h.stall_bound(getattr(a, f"{ch}valid"), getattr(a, f"{ch}ready"), stall, ch, assume=True)
                       for ch in ("aw", "w", "ar")}
        self._writes()
        self._reads()

    def _burst_legal(self, ch: str, data_bytes: int):
        h, a = self.h, self.axi
        valid, addr, ln, size, burst = (getattr(a, f"{ch}{f}") for f in ("valid", "addr", "len", "size", "burst"))
        nbytes = (ln + 1) << size
        page = addr[:12]
        h.check(~valid | (burst != 3), f"{ch}_burst_type")
        h.check(~valid | (size <= (data_bytes - 1).bit_length()), f"{ch}_size")
        h.check(~valid | (burst != 1) | (page + nbytes <= 4096), f"{ch}_4k")
        h.check(~valid | (burst != 2) | (ln == 1) | (ln == 3) | (ln == 7) | (ln == 15), f"{ch}_wrap_len")
        h.check(~valid | (burst != 0) | (ln <= 15), f"{ch}_fixed_len")

    def _owed(self, owed, valid, name: str):
        """A response owed arrives within ``stall`` cycles (assumed)."""
        h = self.h
        wait = Signal(bits_for(self.stall + 1), name=f"f_owed_{name}")
        with h.m.If(owed & ~valid):
            with h.m.If(wait <= self.stall):
                h.m.d.sync += wait.eq(wait + 1)
        with h.m.Else():
            h.m.d.sync += wait.eq(0)
        h.check(~owed | valid | (wait < self.stall), f"{name}_latency_bound", assume=True)

    def _writes(self):
        h, a, m = self.h, self.axi, self.h.m
        n = self.max_out + 1
        cw = bits_for(n + 2)
        aw_x, w_x, b_x = a.awvalid & a.awready, a.wvalid & a.wready, a.bvalid & a.bready
        self.aw_pend = aw_pend = Signal(cw, name="f_aw_pending")     # AW accepted, no B yet
        self.wb_pend = wb_pend = Signal(cw, name="f_wb_pending")     # W bursts complete, no B yet
        m.d.sync += [aw_pend.eq(aw_pend + aw_x - b_x), wb_pend.eq(wb_pend + (w_x & a.wlast) - b_x)]
        h.check(~a.bvalid | ((aw_pend != 0) & (wb_pend != 0)), "b_after_request", assume=True)
        self._owed((aw_pend != 0) & (wb_pend != 0), a.bvalid, "b")
        h.check(aw_pend <= self.max_out, "aw_outstanding")
        h.check(wb_pend <= self.max_out, "w_outstanding")
        # WLAST: the current W burst's length from the AW queue, or from the AW accepted in this cycle
        q = _LenQueue(h, n, "aw")
        w_beat = Signal(9, name="f_w_beat")
        early, early_beats = Signal(name="f_w_early"), Signal(9, name="f_w_early_beats")
        known = (q.count != 0) | (aw_x & ~early)
        cur_len = Mux(q.count != 0, q.head_len(), a.awlen)
        h.check(~(w_x & known) | (a.wlast == (w_beat == cur_len)), "wlast")
        h.check(~(w_x & ~known & a.wlast) | ~early, "w_ahead_one")
        h.check(~(aw_x & early) | (a.awlen + 1 == early_beats), "wlast_early_burst")
        with m.If(w_x):
            m.d.sync += w_beat.eq(Mux(a.wlast, 0, w_beat + 1))
            with m.If(~known & a.wlast):
                m.d.sync += [early.eq(1), early_beats.eq(w_beat + 1)]
        with m.If(aw_x & early):
            m.d.sync += early.eq(0)
        ends_now = w_x & a.wlast
        push = aw_x & ~early & ~((q.count == 0) & ends_now)
        pop = (q.count != 0) & ends_now
        q.update(push, a.awlen, pop)
        self.w_beat, self.w_early, self.w_early_beats, self.aw_queue = w_beat, early, early_beats, q

    def _reads(self):
        h, a, m = self.h, self.axi, self.h.m
        n = self.max_out + 1
        ar_x, r_x = a.arvalid & a.arready, a.rvalid & a.rready
        self.ar_pend = ar_pend = Signal(bits_for(n + 2), name="f_ar_pending")
        last_x = r_x & a.rlast
        m.d.sync += ar_pend.eq(ar_pend + ar_x - last_x)
        h.check(~a.rvalid | (ar_pend != 0), "r_after_request", assume=True)
        self._owed(ar_pend != 0, a.rvalid, "r")
        h.check(ar_pend <= self.max_out, "ar_outstanding")
        q = _LenQueue(h, n, "ar")
        r_beat = Signal(9, name="f_r_beat")
        h.check(~a.rvalid | (q.count == 0) | (a.rlast == (r_beat == q.head_len())), "r_last", assume=True)
        with m.If(r_x):
            m.d.sync += r_beat.eq(Mux(a.rlast, 0, r_beat + 1))
        q.update(ar_x, a.arlen, last_x)
        self.r_beat, self.ar_queue = r_beat, q
