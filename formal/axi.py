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

The read channels are :class:`formal.axiread.AxiReadCheck` (the set every AXI4 read manager gets); this class adds
the write channels.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Mux, Signal

from .axiread import AxiReadCheck, LenQueue, burst_legal, owed_bound
from .props import Harness, bits_for

__all__ = ["AxiManagerCheck"]


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
        h.stream_hold(a.bvalid, a.bready, Cat(a.bid, a.bresp), "b", assume=True)
        burst_legal(h, a, "aw", data_bytes)
        h.check(~a.awvalid | (a.awid == id_value), "aw_one_id")
        h.check(~a.bvalid | (a.bid == id_value), "b_id", assume=True)
        self.stalls = {ch: h.stall_bound(getattr(a, f"{ch}valid"), getattr(a, f"{ch}ready"), stall, ch, assume=True)
                       for ch in ("aw", "w")}
        self._writes()
        # the read channels: the property set of any AXI4 read manager (formal/axiread.py)
        self.read = rd = AxiReadCheck(h, a, max_out=max_out, stall=stall, id_value=id_value)
        self.stalls["ar"] = rd.stall_run
        self.ar_pend, self.r_beat, self.ar_queue = rd.ar_pend, rd.r_beat, rd.queue

    def _writes(self):
        h, a, m = self.h, self.axi, self.h.m
        n = self.max_out + 1
        cw = bits_for(n + 2)
        aw_x, w_x, b_x = a.awvalid & a.awready, a.wvalid & a.wready, a.bvalid & a.bready
        self.aw_pend = aw_pend = Signal(cw, name="f_aw_pending")     # AW accepted, no B yet
        self.wb_pend = wb_pend = Signal(cw, name="f_wb_pending")     # W bursts complete, no B yet
        m.d.sync += [aw_pend.eq(aw_pend + aw_x - b_x), wb_pend.eq(wb_pend + (w_x & a.wlast) - b_x)]
        h.check(~a.bvalid | ((aw_pend != 0) & (wb_pend != 0)), "b_after_request", assume=True)
        owed_bound(h, (aw_pend != 0) & (wb_pend != 0), a.bvalid, self.stall, "b")
        h.check(aw_pend <= self.max_out, "aw_outstanding")
        h.check(wb_pend <= self.max_out, "w_outstanding")
        # WLAST: the current W burst's length from the AW queue, or from the AW accepted in this cycle
        q = LenQueue(h, n, "aw")
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
