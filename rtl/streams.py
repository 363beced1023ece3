"""Stream interfaces with backpressure for every unit and the pixel pipeline (``amaranth.lib.stream``).

Every unit's RTL (``rtl/<unit>.py``) is a flat pipeline: ``i_valid`` plus one port per input, ``o_valid`` plus one
port per output, ``params.latency`` cycles later, one result per clock, and nothing can make it wait. The paper's
pipeline (section 4) takes one fragment per clock from the scan converter; whatever sits at either end on an FPGA
(a rasterizer with gaps, a frame-buffer port that is sometimes busy) needs the valid/ready handshake.
:class:`StreamUnit` gives any unit (and :class:`~rtl.pipeline.Pipeline`) that handshake:

- ``i``: ``In(stream.Signature(input_layout(params, side)))``, ``o``: ``Out(stream.Signature(output_layout(params,
  side)))``. The payloads are :class:`~amaranth.lib.data.StructLayout` views with one field per
  ``params.inputs`` / ``params.outputs`` entry (same names, shapes from the formats: no width typed twice), plus
  a field ``side`` when a sideband layout is given: data carried alongside the fragment with the unit's latency
  (the pixel's x, y and depth, for example), untouched.
- Design: the unit's flat pipeline runs under one stage enable ``en`` (Amaranth ``EnableInserter`` on its ``sync``
  domain: every register and every synchronous memory read port of the unit and its submodules holds while ``en``
  is low), the sideband rides a shift register under the same enable, and a two-entry skid buffer sits at the
  output. ``en`` is a flip-flop: it is set for the next cycle only if the buffer will have room for one more
  result whatever the consumer does (``count' + 1 <= 2``), so the consumer's ``ready`` reaches one register and
  the buffer's counters, never the pipeline's clock enables, and Fmax is the flat unit's. ``i.ready`` is ``en``
  (it does not depend on ``i.valid``).
- The buffer is a two-slot ring (``rp`` the oldest slot, ``count`` results held, the free slot ``rp ^ count[0]``).
  Whenever ``en`` is high the last stage's outputs are written into the free slot, whether or not they will be
  kept: there is always one free (``en`` high means ``count <= 1``), and the slot's write enable is then a
  function of three flip-flops (``en``, ``rp``, ``count[0]``), so neither the consumer's ``ready`` nor the last
  stage's valid reaches the wide payload registers. (A shift register that moved slot 1 into slot 0 on every pop
  put ``ready`` and ``valid`` on those enables: that path, routed to every payload bit, was the critical path of
  the units with wide outputs.) A result is kept (``count`` counts it) only if it does not go straight out.
- Timing: while the buffer is empty, the result in the pipeline's last stage goes straight to ``o`` (``o.valid =
  en & last stage valid``), so without stalls the latency is ``params.latency`` and one result flows per clock.
  A result leaves the last stage whenever ``en`` is high; if ``o`` does not take it in that cycle, or the buffer
  holds older results, it is kept in the buffer (order kept). ``o.payload`` and ``o.valid`` never change while
  ``o.valid & ~o.ready`` (the AXI-Stream rule). After a stall the buffer may keep one result while results flow
  at one per clock; a gap in the input drains it.
"""

from __future__ import annotations

from amaranth.hdl import EnableInserter, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from .fixed import shape
from .unit import Pipe, build

__all__ = ["payload_layout", "input_layout", "output_layout", "StreamUnit", "SKID_DEPTH"]

#: Results the output buffer holds: one for the result leaving the pipeline in the cycle ``ready`` falls (``en``
#: is a register, a cycle late), one so that the pipeline can keep running at one per clock after a stall.
SKID_DEPTH = 2
#: The sideband's field name in the payloads.
SIDE = "side"


def payload_layout(ports, side=None) -> data.StructLayout:
    """One field per port (name and shape from its format), plus ``side`` when a sideband shape is given."""
    fields = {p.name: shape(p.fmt) for p in ports}
    if side is not None:
        if SIDE in fields:
            raise ValueError(f"a port is named {SIDE!r}: the sideband field would hide it")
        fields[SIDE] = side
    return data.StructLayout(fields)


def input_layout(params, side=None) -> data.StructLayout:
    """Payload layout of the unit's input stream: ``params.inputs`` (and the sideband)."""
    return payload_layout(params.inputs, side)


def output_layout(params, side=None) -> data.StructLayout:
    """Payload layout of the unit's output stream: ``params.outputs`` (and the sideband)."""
    return payload_layout(params.outputs, side)


class _Core(wiring.Component):
    """The flat unit and the sideband's delay line: everything that runs under the stage enable."""

    def __init__(self, params, side):
        self.params, self.side = params, side
        members = {"i_valid": In(1), "i_payload": In(input_layout(params, side)),
                   "o_valid": Out(1), "o_payload": Out(output_layout(params, side))}
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        m.submodules.unit = unit = build(self.params)
        m.d.comb += unit.i_valid.eq(self.i_valid)
        for p in self.params.inputs:
            m.d.comb += getattr(unit, p.name).eq(getattr(self.i_payload, p.name))
        for p in self.params.outputs:
            m.d.comb += getattr(self.o_payload, p.name).eq(getattr(unit, p.name))
        m.d.comb += self.o_valid.eq(unit.o_valid)
        if self.side is not None:
            side = Pipe(m).delay(getattr(self.i_payload, SIDE).as_value(), self.params.latency, "side")
            m.d.comb += getattr(self.o_payload, SIDE).eq(side)
        return m


class StreamUnit(wiring.Component):
    """A unit (any registered parameter object, the pipeline included) with stream interfaces.

    Parameters
    ----------
    params : Unit
        The unit's parameter object (``rtl.build(params)`` is the flat pipeline inside).
    side : ShapeLike, optional
        Sideband layout carried from ``i.payload.side`` to ``o.payload.side`` with the unit's latency.

    Ports
    -----
    i : ``In(stream.Signature(input_layout(params, side)))``
        ``i.payload.<input>`` in the input's format (e.g. ``i.payload.w`` in ``RecipParams.in_fmt``);
        ``i.ready`` is a register (the stage enable), independent of ``i.valid``.
    o : ``Out(stream.Signature(output_layout(params, side)))``
        ``o.payload.<output>`` in the output's format; the result of the input accepted ``params.latency``
        cycles earlier when nothing stalled.

    Verilog ports (``rtl.verilog_text``): ``clk``, ``rst``, ``i__valid``, ``i__ready``, ``i__payload`` (field ``f``
    at bits ``[offset +: width]`` of ``input_layout``, first field lowest), ``o__valid``, ``o__ready``,
    ``o__payload``.
    """

    def __init__(self, params, side=None):
        self.params, self.side = params, side
        super().__init__({"i": In(stream.Signature(input_layout(params, side))),
                          "o": Out(stream.Signature(output_layout(params, side)))})

    def elaborate(self, platform):
        m = Module()
        en = Signal(init=1)                                  # the stage enable: a flip-flop
        m.submodules.core = core = EnableInserter({"sync": en})(_Core(self.params, self.side))
        m.d.comb += [core.i_valid.eq(self.i.valid), core.i_payload.eq(self.i.payload), self.i.ready.eq(en)]

        # the skid buffer: a two-slot ring, `count` results from slot `rp` on
        lay = output_layout(self.params, self.side)
        buf = [Signal(lay, name=f"skid{k}") for k in range(SKID_DEPTH)]
        count = Signal(range(SKID_DEPTH + 1))
        rp = Signal(range(SKID_DEPTH))                       # the oldest result's slot
        free = Signal(range(SKID_DEPTH))                     # the slot the last stage is written into
        leaving = Signal()                                   # the last stage's result leaves the pipeline
        m.d.comb += [leaving.eq(en & core.o_valid), free.eq(rp ^ count[0])]
        m.d.comb += [self.o.valid.eq(Mux(count == 0, leaving, 1)),
                     self.o.payload.eq(Mux(count == 0, core.o_payload.as_value(),
                                           Mux(rp, buf[1].as_value(), buf[0].as_value())))]
        # the leaving result is kept unless it goes straight out (buffer empty, consumer ready)
        push = leaving & ~((count == 0) & self.o.ready)
        popped = self.o.valid & self.o.ready & (count != 0)  # the oldest buffered result goes out
        count_next = count + push - popped
        m.d.sync += [count.eq(count_next), en.eq(count_next < SKID_DEPTH), rp.eq(rp ^ popped)]
        # the free slot takes the last stage's outputs on every enabled cycle (kept or not: see the module notes)
        for k in range(SKID_DEPTH):
            with m.If(en & (free == k)):
                m.d.sync += buf[k].eq(core.o_payload)
        return m
