"""Property sets of the stream versions of the units (``rtl/streams.py``, :class:`~rtl.streams.StreamUnit`).

The sideband (``side``) carries a sequence number: the input is assumed to number its transfers 0, 1, 2, ...
(modulo ``2**t``, ``2**t`` above the unit's capacity ``buffer_depth``) and every output transfer must carry the
next number: a lost, repeated or reordered fragment breaks the sequence. The sideband rides a delay line of the
unit's latency beside the datapath (``rtl.streams._Core``), which ``rtl.unit.Pipe`` checks has the same number
of stages, so the payload computed from a fragment leaves with its number. What the solver reads of the
datapath is only its registers' values (never its arithmetic: the properties hold whatever the unit computes),
so the runs cut multipliers and lookup tables (``cutpoint``: free values, a sound abstraction).

Proven by k-induction at k = 1 (white-box invariants: the unit's ``used`` equals the transfers in minus out,
which equals the FIFO's level plus the valid bits of the unit's delay line, counted by a ghost line of input
counts beside it: :func:`stream_counts`; each valid stage of the sideband's delay line carries its ghost stage's
number): rule 2 on ``o``; the sequence on ``o`` (no loss, duplication or reordering); no output without an input;
``used`` never above the FIFO's depth (the credit FIFO cannot overflow); rule 3 as a bound (with fragments in
flight, ``o.valid`` rises within the latency whatever ``o.ready`` does). The FIFO's own contract (what is read was
written, in order: Amaranth's ``SyncFIFO``, which also asserts its pointers and level under the formal platform) is
assumed where it is read and asserted where it is written. Rule 3 as a combinational independence is the miter
of :mod:`formal.miter` (bounded).
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Cat, Signal
from amaranth.lib import data
from amaranth.lib.fifo import SyncFIFO

from rtl.streams import StreamUnit, buffer_depth, input_layout

from . import whitebox
from .miter import independence
from .props import Harness, bits_for

__all__ = ["stream_unit", "stream_counts", "stream_independence", "tag_bits", "cover_depth", "CUT"]

#: The datapath abstraction of the unit runs: multipliers and lookup tables (memories without write ports).
CUT = "t:$mul t:$mem_v2 r:WR_PORTS=0 %i %u"


def tag_bits(params) -> int:
    return bits_for(buffer_depth(params) + 1)


def cover_depth(params) -> int:
    """Steps of the cover run: a full FIFO and a stall of the latency (latency + depth + 4), and the sequence
    numbers' wrap (latency + 2**t + 2) where that is at most 64 steps."""
    base = params.latency + buffer_depth(params) + 4
    return max(base, params.latency + (1 << tag_bits(params)) + 2) if wrap_cover(params) else base


def wrap_cover(params) -> bool:
    return params.latency + (1 << tag_bits(params)) + 2 <= 64


def side_layout(params) -> data.StructLayout:
    """The sideband: one field ``tag``, the sequence number."""
    return data.StructLayout({"tag": tag_bits(params)})


def stream_unit(params, *, kind: str = "proof", wrap=None) -> Harness:
    """The property set of ``StreamUnit(params)`` with a sequence-number sideband; ``wrap`` (a broken variant
    of :mod:`formal.broken`) wraps the unit."""
    h = Harness(kind)
    m = h.m
    depth, lat, t = buffer_depth(params), params.latency, tag_bits(params)
    inner = StreamUnit(params, side_layout(params))
    dut = wrap(inner) if wrap else inner
    pre = "dut/" if wrap else ""
    frag = whitebox.elaborate(dut)
    m.submodules.dut = frag
    lay = input_layout(params, side_layout(params))
    i_valid, o_ready = h.free(1, "i_valid"), h.free(1, "o_ready")
    i_payload = h.free(lay.size, "i_payload")
    m.d.comb += [dut.i.valid.eq(i_valid), dut.i.payload.eq(i_payload), dut.o.ready.eq(o_ready)]
    x_in, x_out = dut.i.valid & dut.i.ready, dut.o.valid & dut.o.ready
    h.stream_hold(dut.i.valid, dut.i.ready, dut.i.payload.as_value(), "i", assume=True)
    n_in, n_out = h.counter(x_in, t, "in"), h.counter(x_out, t, "out")
    h.check(~dut.i.valid | (data.View(lay, i_payload).side.tag == n_in), "i_seq", assume=True)
    h.stream_hold(dut.o.valid, dut.o.ready, dut.o.payload.as_value(), "o")
    c = stream_counts(h, params, dut, frag, pre)
    out, level, line, g = c.out, c.level, c.line, c.g
    h.check(~dut.o.valid | (dut.o.payload.side.tag == n_out), "o_order")
    h.check(n_in == (n_out + out)[:t], "seq_counts")
    h.check(c.n_out_w[:t] == n_out, "counts_narrow")
    # a valid stage k carries the number g[k] (see :func:`stream_counts`)
    fifo = whitebox.origin(frag, pre + "fifo", SyncFIFO)
    sides = [whitebox.signal(frag, f"side{k}", pre + "core")[:t] for k in range(1, lat + 1)]
    for k in range(1, lat + 1):
        h.check(~line[k - 1] | (sides[k - 1] == g[k][:t]), f"line{k}_seq")
    # the FIFO is written in order, its head is the oldest (``SyncFIFO``'s contract: what is read was written,
    # in order), assumed where it is read
    h.check(~(fifo.w_en & fifo.w_rdy) | (fifo.w_data[-t:] == (n_out + level)[:t]), "fifo_write_seq")
    h.check(~fifo.r_rdy | (fifo.r_data[-t:] == n_out), "fifo_read_seq", assume=True)
    h.check(whitebox.signal(frag, "fifo_nonempty", pre) == fifo.r_rdy, "nonempty_register_agrees")
    # reachability: a full FIFO with the input held off, the longest stall released, a wrap of the numbers
    run = Signal(range(depth + 2), name="f_run")
    with m.If(dut.o.valid & ~dut.o.ready):
        with m.If(run <= depth):
            m.d.sync += run.eq(run + 1)
    with m.Else():
        m.d.sync += run.eq(0)
    h.cover(x_in, "any_in_reach")
    h.cover(dut.o.valid, "ovalid_reach")
    h.cover(line[0] & h.started, "line0_reach")
    h.cover(x_in & h.started, "in1_reach")
    h.cover(h.started & (level == depth) & ~dut.i.ready & dut.i.valid, "full_fifo_reach")
    h.cover((run >= lat) & x_out, "long_stall_reach")
    if wrap_cover(params):
        h.cover(x_out & (n_out == (1 << t) - 1), "seq_wrap_reach")
    return h


def stream_counts(h: Harness, params, dut, frag, pre: str) -> SimpleNamespace:
    """The counts of a :class:`~rtl.streams.StreamUnit` ``dut`` (at path ``pre``, ``""`` or ending in ``/``, of
    ``frag``) that need no sideband: transfers in - out (``out``) = ``used`` = FIFO level + the delay line's valid
    bits, never above the FIFO's depth, the room register (``i.ready``) equal to ``used < depth``; no output
    without an input; rule 3 as a bound. Returns the counters."""
    m = h.m
    unit = dut
    while not hasattr(unit, "in_stages"):       # a broken variant's wrapper (formal/broken.py) around the StreamUnit
        unit = unit.inner
    n_in = unit.in_stages
    depth, lat = buffer_depth(params, n_in), params.latency + n_in
    x_in, x_out = dut.i.valid & dut.i.ready, dut.o.valid & dut.o.ready
    out = Signal(range(depth + 2), name="f_outstanding")
    m.d.sync += out.eq(out + x_in - x_out)
    used = whitebox.signal(frag, "used", pre)
    level = whitebox.origin(frag, pre + "fifo", SyncFIFO).level
    # the delay line: the input registers (``in_stages``), then the flat unit's stages
    line = Cat(*(whitebox.signal(frag, f"in{k}_valid", pre) for k in range(1, n_in + 1)),
               *(whitebox.signal(frag, f"valid{k}", pre + "core/unit") for k in range(1, params.latency + 1)))
    h.check(out <= depth, "o_capacity")
    h.check(~x_out | (out != 0), "o_no_dup")
    h.check(used == out, "o_used")
    h.check(whitebox.signal(frag, "room", pre) == (used < depth), "room_register_agrees")    # i.ready, a register
    # the delay line counted without counting its valid bits (a population count defeats the solver at latency
    # 74): a ghost line g beside the delay line, g[0] the inputs accepted so far, g[k] = g[k - 1] one cycle ago.
    # Stage k holds the input accepted k cycles ago, so g[k - 1] - g[k] is stage k's valid bit (its number, in a
    # sequence, is g[k]), and g[latency] (the next number to leave the delay line) follows those output and in
    # the FIFO. Widths: 2 depth > FIFO + delay line, so nothing wraps.
    w = bits_for(2 * depth + 1)
    g = [h.counter(x_in, w, "in_wide")] + [Signal(w, name=f"f_g{k}") for k in range(1, lat + 1)]
    n_out_w = h.counter(x_out, w, "out_wide")
    m.d.sync += [g[k].eq(g[k - 1]) for k in range(1, lat + 1)]
    h.check(g[0] == (n_out_w + out)[:w], "counts_wide")
    h.check(g[lat] == (n_out_w + level)[:w], "line_end_seq")
    h.check(out == (level + g[0] - g[lat])[:w], "o_inflight")
    for k in range(1, lat + 1):
        h.check((g[k - 1] - g[k])[:w] == line[k - 1], f"line{k}_step")
    # rule 3 as a bound: with fragments in flight and ``o.valid`` low, the oldest is in the delay line and
    # reaches the output within the latency, whatever ``o.ready`` does
    wait = Signal(range(lat + 2), name="f_wait")
    with m.If((out != 0) & ~dut.o.valid):
        with m.If(wait <= lat):
            m.d.sync += wait.eq(wait + 1)
    with m.Else():
        m.d.sync += wait.eq(0)
    h.check(wait < lat, "o_wait")
    h.check((wait == 0) | Cat(line[k] & (wait <= k) for k in range(lat)).any(), "o_wait_oldest")
    return SimpleNamespace(out=out, used=used, level=level, line=line, g=g, w=w, n_out_w=n_out_w)


def stream_independence(params, *, kind: str = "proof", wrap=None) -> Harness:
    """The independence miter (:mod:`formal.miter`) on two copies of ``StreamUnit(params)``."""
    h = Harness(kind)
    def make():
        inner = StreamUnit(params, side_layout(params))
        return wrap(inner) if wrap else inner
    independence(h, make, input_layout(params, side_layout(params)).size, payload=False)
    return h
