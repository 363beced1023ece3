"""AXI4 read-channel properties of a manager port (AMBA AXI4 ``AR`` and ``R``; modelled on the read half of
ZipCPU's ``faxi_master.v``, written anew in Amaranth), for any read manager: the texel caches and the read half
of :class:`formal.axi.AxiManagerCheck` (the ROP's port).

Asserted of the manager (names as in the solver's report):

- ``ar_hold``: ``ARVALID`` and every ``AR`` field (``ARID, ARADDR, ARLEN, ARSIZE, ARBURST``) hold until
  ``ARREADY``;
- ``ar_burst_type`` (not the reserved type), ``ar_size`` (within the bus), ``ar_4k`` (an ``INCR`` burst inside
  one 4 KB page), ``ar_wrap_len`` (2, 4, 8 or 16 beats), ``ar_fixed_len`` (at most 16), ``ar_one_id``;
- ``ar_len_declared``, ``ar_size_declared``, ``ar_burst_declared``: the burst the design declares (e.g. one
  cache line: ``beats_per_line - 1``, size 2, ``INCR``), when the caller gives it;
- ``ar_outstanding``: read bursts accepted and not finished (``RLAST`` taken) at most ``max_out``;
- ``aw_idle``, ``w_idle`` for a read-only manager (``read_only``): it never writes.

Assumed of the memory: ``R`` holds until ``RREADY`` (``r_hold``); ``r_after_request``: no ``R`` beat without an
accepted ``AR`` not yet finished; ``r_last``: ``RLAST`` exactly on the last beat of the oldest burst (its length
from a queue of the ``ARLEN`` values accepted); ``r_id``; bounded stalls: ``ARREADY`` within ``stall`` cycles of
``ARVALID`` (``ar_stall_bound``), an owed beat within ``stall`` cycles (``r_latency_bound``).

A manager that takes a burst's end before ``RLAST`` (or after) is caught by the design's own invariant that ties
its state to :attr:`AxiReadCheck.ar_pend` and :attr:`AxiReadCheck.r_beat` (e.g. "filling iff a burst is
outstanding"), and by ``ar_outstanding`` when it then issues one burst too many.
"""

from __future__ import annotations

from amaranth.hdl import Array, Cat, Mux, Signal

from .props import Harness, bits_for

__all__ = ["AxiReadCheck", "LenQueue", "burst_legal"]


class LenQueue:
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
        m = self.h.m
        tail = Signal(range(self.n), name=f"f_{self.name}_tail")
        m.d.comb += tail.eq(Mux(self.head + self.count >= self.n, self.head + self.count - self.n,
                                self.head + self.count))
        with m.If(push):
            m.d.sync += self.regs[tail].eq(value)
        with m.If(pop):
            m.d.sync += self.head.eq(Mux(self.head == self.n - 1, 0, self.head + 1))
        m.d.sync += self.count.eq(self.count + push - pop)
        self.h.check(~push | pop | (self.count < self.n), f"{self.name}_queue_room")


def burst_legal(h: Harness, axi, ch: str, data_bytes: int):
    """The burst rules of channel ``ch`` (``aw`` or ``ar``): type, size, 4 KB, WRAP and FIXED lengths."""
    valid, addr, ln, size, burst = (getattr(axi, f"{ch}{f}") for f in ("valid", "addr", "len", "size", "burst"))
    nbytes = (ln + 1) << size
    page = addr[:12]
    h.check(~valid | (burst != 3), f"{ch}_burst_type")
    h.check(~valid | (size <= (data_bytes - 1).bit_length()), f"{ch}_size")
    h.check(~valid | (burst != 1) | (page + nbytes <= 4096), f"{ch}_4k")
    h.check(~valid | (burst != 2) | (ln == 1) | (ln == 3) | (ln == 7) | (ln == 15), f"{ch}_wrap_len")
    h.check(~valid | (burst != 0) | (ln <= 15), f"{ch}_fixed_len")


def owed_bound(h: Harness, owed, valid, stall: int, name: str):
    """A response owed arrives within ``stall`` cycles (assumed): :meth:`Harness.stall_bound` with the response's
    ``valid`` in the place of ``ready`` (counter ``f_owed_<name>``, property ``<name>_latency_bound``)."""
    return h.stall_bound(owed, valid, stall, name, counter="owed", check="latency_bound")


class AxiReadCheck:
    """The read-channel properties of one AXI4 manager port ``axi`` (members named as
    :func:`rtl.rop.axi_signature`).

    Parameters
    ----------
    h : Harness
    axi : the port (the design's interface object)
    max_out : int
        Read bursts outstanding at most (asserted).
    stall : int
        The memory's bounded stalls (assumed).
    id_value : int
        The one ID the manager uses.
    arlen, arsize, arburst : int, optional
        The burst the design declares (asserted on every ``AR``).
    read_only : bool
        Also assert that ``AWVALID`` and ``WVALID`` stay low.

    Attributes
    ----------
    ar_pend : Signal
        Bursts accepted on ``AR`` whose ``RLAST`` has not been taken.
    r_beat : Signal
        Beats taken of the current burst.
    queue : LenQueue
        The ``ARLEN`` of each outstanding burst, oldest at the head.
    stall_run : Signal
        Cycles ``AR`` has waited so far.
    """

    def __init__(self, h: Harness, axi, *, max_out: int, stall: int, id_value: int = 0, arlen: int | None = None,
                 arsize: int | None = None, arburst: int | None = None, read_only: bool = False):
        self.h, self.axi, self.max_out, self.stall = h, axi, max_out, stall
        a, m = axi, h.m
        h.stream_hold(a.arvalid, a.arready, Cat(a.arid, a.araddr, a.arlen, a.arsize, a.arburst), "ar")
        h.stream_hold(a.rvalid, a.rready, Cat(a.rid, a.rdata, a.rresp, a.rlast), "r", assume=True)
        burst_legal(h, a, "ar", len(a.rdata) // 8)
        h.check(~a.arvalid | (a.arid == id_value), "ar_one_id")
        h.check(~a.rvalid | (a.rid == id_value), "r_id", assume=True)
        for field, want in (("len", arlen), ("size", arsize), ("burst", arburst)):
            if want is not None:
                h.check(~a.arvalid | (getattr(a, f"ar{field}") == want), f"ar_{field}_declared")
        if read_only:
            h.check(~a.awvalid, "aw_idle")
            h.check(~a.wvalid, "w_idle")
        self.stall_run = h.stall_bound(a.arvalid, a.arready, stall, "ar", assume=True)
        n = max_out + 1
        ar_x, r_x = a.arvalid & a.arready, a.rvalid & a.rready
        self.ar_pend = ar_pend = Signal(bits_for(n + 2), name="f_ar_pending")
        last_x = r_x & a.rlast
        m.d.sync += ar_pend.eq(ar_pend + ar_x - last_x)
        h.check(~a.rvalid | (ar_pend != 0), "r_after_request", assume=True)
        self.r_wait = owed_bound(h, ar_pend != 0, a.rvalid, stall, "r")
        h.check(ar_pend <= max_out, "ar_outstanding")
        q = LenQueue(h, n, "ar")
        r_beat = Signal(9, name="f_r_beat")
        h.check(~a.rvalid | (q.count == 0) | (a.rlast == (r_beat == q.head_len())), "r_last", assume=True)
        with m.If(r_x):
            m.d.sync += r_beat.eq(Mux(a.rlast, 0, r_beat + 1))
        q.update(ar_x, a.arlen, last_x)
        self.r_beat, self.queue = r_beat, q

    def invariants(self, arlen: int):
        """Invariants for k-induction of a manager whose every burst is ``arlen + 1`` beats: the queue holds one
        entry per outstanding burst, each ``arlen``; the beat count is within the burst (0 with nothing
        outstanding)."""
        h, q = self.h, self.queue
        h.check(q.count == self.ar_pend, "ar_queue_count")
        h.check(q.head < q.n, "ar_queue_head")
        for j in range(q.n):
            slot = Mux(q.head + j >= q.n, q.head + j - q.n, q.head + j)
            h.check((q.count <= j) | (q.regs[slot] == arlen), f"ar_queue_len{j}")
        h.check(Mux(self.ar_pend == 0, self.r_beat == 0, self.r_beat <= arlen), "r_beat_range")
