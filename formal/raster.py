"""Property set of the scan converter (``rtl/raster.py``, :class:`~rtl.raster.Raster`).

The scan converter computes its output (it has no sideband), so nothing is lost, repeated or invented is shown
by conservation of counts with white-box invariants, all proven by k-induction:

- **rows**: the rows owed by the accepted records (``rows + 1`` each) less the rows the Pixel Calculator took
  from the row FIFO equal the rows the generator has still to issue plus the rows issued and not yet taken
  (in the span pipeline's valid bits or in the FIFO); the generator's credit counter equals the latter and never
  exceeds the row FIFO's depth, so the span pipeline, which runs free, never writes a full FIFO.
- **pixels**: the pixels owed by the rows taken (``n + 1`` for a row that is not empty) less the fragments
  transferred on ``o`` equal the pixels the Pixel Calculator has still to produce plus the one in the rounding
  stage plus the output FIFO's level; its place counter equals the rounding stage plus the level, and never
  lets a write into a full output FIFO happen.
- the control copies (module docstring of ``rtl/raster.py``, "Fan-out") agree with copy 0 in every cycle.
- rule 2 on ``o``; ``i.ready`` from registers only (the miter, bounded).

Order: the output FIFO keeps order (``CreditFIFO``, proven by ``formal/credit_fifo.py``) and the Pixel Calculator
takes rows in FIFO order, one at a time; the fragments' values are not followed (the datapath is cut: ``cutpoint`` on
the multipliers).
"""

from __future__ import annotations

from amaranth.hdl import Mux, Signal
from amaranth.lib import data
from amaranth.lib.fifo import SyncFIFO

from fxmodel.core.fixed import Fmt
from fxmodel.units.raster import RasterParams
from rtl.raster import Raster, record_layout, row_layout
from rtl.streams import CreditFIFO
from rtl.unit import COPY_SUFFIX

from . import whitebox
from .miter import independence
from .props import Harness, bits_for

__all__ = ["small_raster", "raster_set", "raster_props", "raster_independence"]

CUT = "t:$mul"


def small_raster() -> RasterParams:
    """The scan converter the proofs use: one attribute, a 16-pixel viewport (control widths shrink with
    ``max_size``; the control logic is the same for any size)."""
    return RasterParams(attrs=(("Z", Fmt(True, 2, 6)),), max_size=16, subpixel_bits=2, guard_pixels=16,
                        extra_guard=0)


def _copies(frag, stem: str) -> list:
    out, k = [], 0
    while whitebox.has_signal(frag, f"{stem}_{k}"):
        out.append(whitebox.signal(frag, f"{stem}_{k}"))
        k += 1
    return out


def _relayed(h: Harness, top, stem: str, stages: range, copies: int) -> list:
    """The registers :func:`rtl.raster._relay` built for each of ``copies`` control copies, stage by stage, checked
    equal across the copies (``copy_{stem}_{s}_{k}``); returns copy 0's register of each stage."""
    out = []
    for s in stages:
        regs = [whitebox.signal(top, f"{stem}_{k}_{s}{COPY_SUFFIX}") for k in range(copies)]
        for k, r in enumerate(regs[1:], 1):
            h.check(r == regs[0], f"copy_{stem}_{s}_{k}")
        out.append(regs[0])
    return out


def raster_set(params: RasterParams | None = None, *, kind: str = "proof", wrap=None) -> Harness:
    P = params or small_raster()
    h = Harness(kind)
    m = h.m
    dut, frag, _ = whitebox.attach(h, Raster(P), wrap)
    pre = "dut" if wrap else ""
    i_valid, o_ready = h.free(1, "i_valid"), h.free(1, "o_ready")
    i_payload = h.free(record_layout(P).size, "i_payload")
    m.d.comb += [dut.i.valid.eq(i_valid), dut.i.payload.eq(i_payload), dut.o.ready.eq(o_ready)]
    h.stream_hold(dut.i.valid, dut.i.ready, dut.i.payload.as_value(), "i", assume=True)
    raster_props(h, P, dut, frag, pre)
    return h


def raster_props(h: Harness, P: RasterParams, dut, frag, pre: str):
    """The scan converter's properties (rule 2 on ``o``, the credits, the conservation of rows and pixels) on
    ``dut`` (a :class:`~rtl.raster.Raster`, at path ``pre`` of ``frag``); rule 2 on its ``i`` is the caller's."""
    m = h.m
    top = whitebox.subfragment(frag, pre)
    sig = lambda name: whitebox.signal(top, name)        # noqa: E731
    h.stream_hold(dut.o.valid, dut.o.ready, dut.o.payload.as_value(), "o")
    rows = whitebox.origin(frag, f"{pre}/rows" if pre else "rows", SyncFIFO)
    out = whitebox.origin(frag, f"{pre}/out" if pre else "out", CreditFIFO)
    h.check(~rows.w_en | rows.w_rdy, "rows_no_overflow")
    h.check(~out.w_en | out.w_rdy, "out_no_overflow")        # the write is not gated (``CreditFIFO``): never full
    h.check(~out.overflow, "out_no_overflow_flag")
    # the control copies agree with copy 0
    for stem in ("gen_valid", "rows_in_flight", "room", "last_row", "busy", "nonempty", "px_left", "last_px",
                 "out_used", "advance", "row_count", "has_row"):
        copies = _copies(top, stem)
        for k, c in enumerate(copies[1:], 1):
            h.check(c == copies[0], f"copy_{stem}_{k}")
    gv, inflight, room = sig("gen_valid_0"), sig("rows_in_flight_0"), sig("room_0")
    s_rem, busy, nonempty, npx = sig("s_rem"), sig("busy_0"), sig("nonempty_0"), sig("px_left_0")
    last_px, used, advance, r_valid = sig("last_px_0"), sig("out_used_0"), sig("advance_0"), sig("rnd_valid")
    span = [sig(f"span_s{k}_valid") for k in range(1, P.SPAN_STAGES)]
    depth, odepth = P.ROW_FIFO_DEPTH, P.OUT_FIFO_DEPTH
    h.check(inflight == rows.level + sum(span), "rows_credit")
    h.check(inflight <= depth, "rows_capacity")
    h.check(room == (inflight != depth), "rows_room")
    h.check(~gv | (sig("last_row_0") == (s_rem == 0)), "gen_last")
    # a read reaches the copies' counts through POP_STAGES registers: pop_seen, then each copy's relay
    n_pc = len(_copies(top, "out_used"))
    pops = [sig("pop_seen"), *_relayed(h, top, "pop_seen", range(1, P.POP_STAGES), n_pc)]
    h.check(used == out.level + r_valid + sum(pops), "out_credit")
    h.check(advance == (used <= odepth - 2), "out_advance")
    # a write reaches each copy's count through ROW_SEEN_STAGES registers of its own
    seen = _relayed(h, top, "row_seen", range(P.ROW_SEEN_STAGES), n_pc)
    h.check((sig("row_count_0") + sum(seen) == rows.level) & (sig("has_row_0") == (sig("row_count_0") != 0)),
            "rows_count")
    h.check(~(busy & nonempty) | (last_px == (npx == 0)), "px_last")
    # a row's ``single`` agrees with its length: asserted where the span pipeline writes the row FIFO, assumed
    # where the Pixel Calculator reads it (the FIFO returns what was written, in order: ``SyncFIFO``'s contract)
    wv = data.View(row_layout(P), rows.w_data)
    h.check(~rows.w_en | ~wv.nonempty | (wv.single == (wv.n == 0)), "rows_single")
    rv = data.View(row_layout(P), rows.r_data)
    h.check(~rows.r_rdy | ~rv.nonempty | (rv.single == (rv.n == 0)), "rows_single_read", assume=True)
    # conservation of rows and pixels
    taken = rows.r_en & rows.r_rdy
    rec = dut.i.payload
    wrows = bits_for(2 * P.max_size + depth + 8) + 1
    f_rows = Signal(wrows, name="f_rows_owed")
    m.d.sync += f_rows.eq(f_rows + Mux(dut.i.valid & dut.i.ready, rec.rows + 1, 0) - taken)
    h.check(f_rows == Mux(gv, s_rem + 1, 0) + inflight, "rows_conserved")
    f_px = Signal(wrows, name="f_px_owed")
    m.d.sync += f_px.eq(f_px + Mux(taken & rv.nonempty, rv.n + 1, 0) - (dut.o.valid & dut.o.ready))
    h.check(f_px == Mux(busy & nonempty, npx + 1, 0) + r_valid + out.level, "px_conserved")
    # reachability
    h.cover(~rows.w_rdy & h.started, "rows_full_reach")
    h.cover(used == odepth - 1, "out_credit_full_reach")
    h.cover(dut.o.valid & dut.o.ready & (f_px > 1), "fragment_reach")
    h.cover(dut.i.valid & ~dut.i.ready & gv, "input_stall_reach")


def raster_independence(params: RasterParams | None = None, *, kind: str = "proof", wrap=None) -> Harness:
    P = params or small_raster()
    h = Harness(kind)
    independence(h, lambda: wrap(Raster(P)) if wrap else Raster(P), record_layout(P).size, payload=False)
    return h
