"""Property set of the raster-operations unit behind its AXI4 port (``rtl/rop.py``, :class:`~rtl.rop.Rop`).

- the AXI4 manager properties of :mod:`formal.axi` on ``axi``, the memory free within them (bounded stalls of
  :data:`STALL` cycles: a slot then lives at most ``2 STALL + SLOT_OVERHEAD`` cycles);
- rule 2 assumed on ``i``;
- the depth test's hazard rule (white-box): no two busy slots hold one pixel (the fragments of a pixel are
  never in flight at once), and a slot is freed only in the cycle after a failed test (the compare stage's
  fragment not strictly nearer than the stored depth) or a write response;
- the slots count the fragments in flight: busy slots = reads outstanding + the compare stage + the write queue
  + writes issued and not acknowledged; reads outstanding never exceed the slots.
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Array, Cat, Mux

from fxmodel.core.fixed import Fmt
from fxmodel.units.rop import RopParams
from rtl.rop import WRITE_QUEUE, Rop

from . import whitebox
from .axi import AxiManagerCheck
from .props import Harness
from .readers import drive_inputs

__all__ = ["small_rop", "rop_set", "rop_props", "STALL"]

#: The memory's bounded stall (cycles) assumed by the ROP's proofs.
STALL = 3


def small_rop(**kw) -> RopParams:
    """The ROP the proofs use: a 4 x 4 frame, 3 slots, 4-bit depths, a 12-bit address (the control logic is
    that of any size; the frame's size sets only the pixel index's width)."""
    args = dict(width=4, height=4, max_size=4, z_in=Fmt(True, 2, 2), outstanding=3, addr_bits=12)
    return RopParams(**(args | kw))


def rop_set(params: RopParams | None = None, *, kind: str = "proof", wrap=None) -> Harness:
    P = params or small_rop()
    h = Harness(kind)
    dut, _, top = whitebox.attach(h, Rop(P), wrap)
    drive_inputs(h, dut)            # free inputs: the fragment stream and every input of the AXI port
    h.stream_hold(dut.i.valid, dut.i.ready, dut.i.payload.as_value(), "i", assume=True)
    rop_props(h, P, dut, top)
    return h


def rop_props(h: Harness, P: RopParams, dut, top) -> SimpleNamespace:
    """The ROP's properties (its AXI4 port, the hazard rule, the slot accounting) on ``dut`` (a
    :class:`~rtl.rop.Rop` whose fragment is ``top``); rule 2 on its ``i`` is the caller's. Returns the checker and
    the slot state."""
    sig = lambda name: whitebox.signal(top, name)        # noqa: E731
    axi = AxiManagerCheck(h, dut.axi, max_out=P.outstanding, stall=STALL)
    N = P.outstanding
    busy = sig("slot_busy")
    index = [sig(f"slot{k}_index") for k in range(N)]
    for j in range(N):
        for k in range(j + 1, N):
            h.check(~(busy[j] & busy[k] & (index[j] == index[k])), f"hazard_{j}_{k}")
    c_valid, c_z, c_stored = sig("cmp_valid"), sig("cmp_z"), sig("cmp_stored")
    fail = c_valid & ~(c_z > c_stored)
    b_x = dut.axi.bvalid & dut.axi.bready
    was = h.past(busy, "busy")
    freed = was & ~busy
    h.check(~h.started | (sum(freed[k] for k in range(N)) <= h.past(fail, "fail") + h.past(b_x, "b")),
            "slot_freed_by_fail_or_b")
    q_count, w_done, aw_done = sig("q_count"), sig("w_done"), sig("aw_done")
    issued_pending = axi.aw_pend - aw_done
    h.check(axi.wb_pend - w_done == issued_pending, "w_matches_aw")
    h.check(sum(busy[k] for k in range(N)) == axi.ar_pend + c_valid + q_count + issued_pending, "slots_count")
    _slot_stages(h, sig, N, busy, axi.ar_pend, c_valid, q_count, issued_pending)
    # the checker's view of the single-beat bursts agrees with the write queue's head (for induction)
    h.check(~(aw_done | w_done) | (q_count != 0), "done_has_head")
    h.check(axi.w_early == (w_done & ~aw_done), "w_early_is_w_done")
    h.check(~axi.w_early | (axi.w_early_beats == 1), "w_early_one_beat")
    h.check((axi.w_beat == 0) & (axi.r_beat == 0), "single_beats")
    h.check(axi.aw_queue.count == (aw_done & ~w_done), "aw_queue_is_aw_done")
    h.check(axi.ar_queue.count == axi.ar_pend, "ar_queue_count")
    for q in (axi.aw_queue, axi.ar_queue):
        h.check(Cat(q.regs) == 0, f"{q.name}_queue_single_beats")
    # reachability: a hazard stall, every slot busy, a burst written, a failed test, the longest stall
    s_valid = sig("s_valid") if whitebox.has_signal(top, "s_valid") else None
    if s_valid is not None:
        conflict = Cat(busy[k] & (index[k] == sig("s_index")) for k in range(N)).any()
        h.cover(s_valid & conflict & dut.i.valid, "hazard_reach")
    h.cover(busy.all(), "all_slots_busy_reach")
    h.cover(dut.axi.wvalid & dut.axi.wready & dut.axi.wlast & (axi.aw_pend != 0), "burst_reach")
    h.cover(fail, "failed_test_reach")
    for ch in ("aw", "ar"):
        h.cover((axi.stalls[ch] == STALL - 1) & getattr(dut.axi, f"{ch}valid") & getattr(dut.axi, f"{ch}ready"),
                f"{ch}_longest_stall_reach")
    return SimpleNamespace(axi=axi, busy=busy, fail=fail, b_x=b_x, s_valid=s_valid, N=N)


def _mod(value, n: int):
    """``value`` modulo ``n`` for ``0 <= value < 2 n``."""
    return Mux(value >= n, value - n, value)


def _slot_stages(h: Harness, sig, N: int, busy, ar_pend, c_valid, q_count, b_pend):
    """Each slot is busy iff exactly one stage holds it: the read ring (``rd`` up to ``alloc``), the compare
    stage, the write queue, the ring of writes awaiting ``B`` (``b_head`` up to ``b_tail``); the rings' fill
    levels are the reads and writes outstanding on the bus (the invariants that make k-induction close)."""
    alloc, rd, b_head, b_tail = sig("alloc"), sig("rd"), sig("b_head"), sig("b_tail")
    c_slot = sig("cmp_slot")
    q_slot = [sig(f"wq{k}_slot") for k in range(WRITE_QUEUE)]
    b_slot = [sig(f"b{k}_slot") for k in range(N)]
    for ptr, name in ((alloc, "alloc"), (rd, "rd"), (b_head, "b_head"), (b_tail, "b_tail")):
        h.check(ptr < N, f"ring_{name}_range")
    h.check(q_count <= WRITE_QUEUE, "queue_range")
    h.check(alloc == _mod(rd + ar_pend, N), "ring_reads")
    h.check(b_tail == _mod(b_head + b_pend, N), "ring_writes")
    for k in range(N):
        in_reads = Cat(_mod(rd + j, N) == k for j in range(N)) & Cat(ar_pend > j for j in range(N))
        in_queue = Cat((q_slot[j] == k) & (q_count > j) for j in range(WRITE_QUEUE))
        in_b = Cat((Array(b_slot)[_mod(b_head + j, N)] == k) & (b_pend > j) for j in range(N))
        holders = sum(in_reads[j] for j in range(N)) + (c_valid & (c_slot == k)) \
            + sum(in_queue[j] for j in range(WRITE_QUEUE)) + sum(in_b[j] for j in range(N))
        h.check(holders == busy[k], f"slot{k}_one_stage")
