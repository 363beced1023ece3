"""Stream interfaces with backpressure for every unit and the pixel pipeline (``amaranth.lib.stream``).

Every unit's RTL (``rtl/<unit>.py``) is a flat pipeline: ``i_valid`` plus one port per input, ``o_valid`` plus one
port per output, ``params.latency`` cycles later, one result per clock, and nothing can make it wait. The paper's
pipeline (section 4) takes one fragment per clock from the scan converter; whatever sits at either end on an FPGA
(a rasterizer with gaps, a frame-buffer port that is sometimes busy) needs the valid/ready handshake.
:class:`StreamUnit` gives any unit (and :class:`~rtl.pixel.Pipeline`) that handshake:

- ``i``: ``In(stream.Signature(input_layout(params, side)))``, ``o``: ``Out(stream.Signature(output_layout(params,
  side)))``. The payloads are :class:`~amaranth.lib.data.StructLayout` views with one field per
  ``params.inputs`` / ``params.outputs`` entry (same names, shapes from the formats: no width typed twice), plus
  a field ``side`` when a sideband layout is given: data carried alongside the fragment with the unit's latency
  (the pixel's x, y and depth, for example), untouched.
- Design: the unit's flat pipeline runs free, with no stage enable, and a first-word-fall-through FIFO of
  :func:`buffer_depth` ``= params.latency + 1`` results sits at its output. A counter ``used`` counts the results in
  flight and in the FIFO; ``i.ready`` is ``used < buffer_depth`` (a register, equal to that compare on every clock:
  it does not depend on ``i.valid`` or on ``o.ready`` in the same clock), so every accepted input has a FIFO slot
  waiting for its result and nothing can overflow. Neither the consumer's ``ready`` nor any enable reaches the
  pipeline's registers: Fmax is the flat unit's. (The design before this one held every register of the pipeline
  under one stage enable, a flip-flop with a fan-out of every register: on the pixel pipeline, 13 500 flip-flops, it
  alone was an 11 ns route and held the fitted pipeline at 85 MHz.) The FIFO's memory has an asynchronous read port
  (LUT RAM on an FPGA; no block RAM or multiplier), the sideband rides a shift register beside the pipeline.
- Timing: while the FIFO is empty, the result in the pipeline's last stage goes straight to ``o`` (``o.valid =``
  the last stage's valid), so without stalls the latency is ``params.latency`` and one result flows per clock
  (``used`` stays at the latency, below the depth). A result that ``o`` does not take in the cycle it appears,
  or that arrives behind older results, enters the FIFO (order kept). ``o.payload`` and ``o.valid`` never
  change while ``o.valid & ~o.ready`` (the AXI-Stream rule). After a stall the FIFO may keep results while
  results flow at one per clock; a gap in the input drains it.
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Assert, Module, Mux, Signal, Value
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.fifo import SyncFIFO, SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from .fixed import shape
from .unit import Pipe, build

__all__ = ["payload_layout", "input_layout", "output_layout", "StreamUnit", "buffer_depth", "CreditFIFO",
           "less_one_if", "TailFIFOBuffered"]

def buffer_depth(params, in_stages: int = 0) -> int:
    """Results the output FIFO holds: one per pipeline stage (``in_stages`` input registers included) and one more,
    so that ``i.ready`` (``used`` below this) stays high while results flow at one per clock (``used`` is then the
    latency)."""
    return int(params.latency) + in_stages + 1


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


def less_one_if(sel, base, test=lambda v: v):
    """``test(base - sel)`` with ``sel`` at the last logic level only: ``test`` of ``base`` and of ``base - 1``
    (sums of registers) side by side, ``sel`` choosing (a late control signal, a consumer's ``ready``, feeds no
    carry chain)."""
    return Mux(sel, test(base - 1), test(base))


def buffered_room(m, fifo, depth: int, w, name: str):
    """A register equal on every clock to ``fifo.w_rdy`` of an Amaranth ``SyncFIFOBuffered`` of ``depth`` (at
    least 2) words, for a writer that decides late: ``w_rdy`` is a compare of the FIFO's inner level (a counter),
    and through the writer's decision it led into whatever that decision loads (the texel cache's lookup FIFO:
    its level, the tag stage's step, the next lookup's acceptance and the prefetch stage's load were the texture
    fetch's slowest path). ``w`` is the FIFO's write (its ``w_en``, which the writer gates with this room). The
    inner level is counted beside the FIFO's own (its read: the inner FIFO holds a word and the output register
    is empty or read), and the room after the clock is chosen by the write and the read at the last logic level.
    Returns the room and what it is after the clock, ``after``: the FIFO's inner ``read`` of this clock (late:
    the reader decides it) and the room after the clock if it reads (``if_read``) and if not (``if_not``), from
    this clock's write alone, so that a writer deciding a clock ahead takes the read at its last level too. The
    formal sets check the room and the count (``{name}_room``, ``{name}_inner``) against the FIFO's
    (``formal/fetch.py``)."""
    if depth < 2:
        raise ValueError(f"buffered_room: depth {depth} must be at least 2 (SyncFIFOBuffered's register alone)")
    top = depth - 1                                       # the inner FIFO's depth
    inner = Signal(range(top + 1), name=f"{name}_inner")
    room = Signal(name=f"{name}_room", init=1)
    after = SimpleNamespace(read=Signal(name=f"{name}_read"), if_read=Mux(w, room, 1),
                            if_not=Mux(w, inner != top - 1, room))
    m.d.comb += after.read.eq((inner != 0) & (~fifo.r_rdy | fifo.r_en))    # SyncFIFOBuffered's inner read
    with m.If(w & ~after.read):
        m.d.sync += inner.eq(inner + 1)
    with m.Elif(after.read & ~w):
        m.d.sync += inner.eq(inner - 1)
    m.d.sync += room.eq(Mux(after.read, after.if_read, after.if_not))
    return room, after


class TailFIFOBuffered(SyncFIFOBuffered):
    """Amaranth's ``SyncFIFOBuffered`` (its ports, its timing, clock for clock; depth at least 2) whose output
    register also holds ``r_tail``: ``tail(word)`` of the word it holds (as wide as ``tail`` makes it), computed
    as the word leaves the inner FIFO for the output register, so that a reader has a function of the word from
    flip-flops, not through that function's logic (the texel cache's corner sets from its input FIFO's output:
    :mod:`rtl.texcache_decoupled`). The inner FIFO holds the words alone; ``r_tail`` is current whenever
    ``r_rdy``, which a proof can state from registers alone (``formal/fetch.py``, ``ififo_tail``), where a tail
    carried through the FIFO's memory would need every slot's contents. Its inner level is named ``inner_level``,
    as in ``SyncFIFOBuffered`` (:func:`buffered_room`, the formal sets)."""

    def __init__(self, *, width: int, depth: int, tail):
        if depth < 2:
            raise ValueError(f"TailFIFOBuffered: depth {depth} must be at least 2 (an inner FIFO and the register)")
        super().__init__(width=width, depth=depth)
        self.tail = tail
        self.r_tail = Signal(len(Value.cast(tail(Signal(width)))), name="r_tail")

    def elaborate(self, platform):
        m = Module()
        m.submodules.inner = inner = SyncFIFO(width=self.width, depth=self.depth - 1)
        inner_level = Signal(range(self.depth), name="inner_level")
        load = Signal(name="load")                    # the inner FIFO's read: the output register takes its word
        m.d.comb += [inner_level.eq(inner.level), self.w_rdy.eq(inner.w_rdy), inner.w_en.eq(self.w_en),
                     inner.w_data.eq(self.w_data), load.eq(inner.r_rdy & (~self.r_rdy | self.r_en)),
                     inner.r_en.eq(load), self.level.eq(inner_level + self.r_rdy),
                     self.w_level.eq(self.level), self.r_level.eq(self.level)]
        with m.If(load):
            m.d.sync += [self.r_data.eq(inner.r_data), self.r_tail.eq(self.tail(inner.r_data)), self.r_rdy.eq(1)]
        with m.Elif(self.r_en):
            m.d.sync += self.r_rdy.eq(0)
        return m


class _Core(wiring.Component):
    """The flat unit and the sideband's delay line."""

    def __init__(self, params, side, unit=None):
        self.params, self.side, self.unit = params, side, unit
        members = {"i_valid": In(1), "i_payload": In(input_layout(params, side)),
                   "o_valid": Out(1), "o_payload": Out(output_layout(params, side))}
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        m.submodules.unit = unit = build(self.params) if self.unit is None else self.unit
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
    unit : UnitComponent, optional
        The flat unit to wrap, built from ``params`` (default ``rtl.build(params)``; the pipeline with its texel
        memories' write bus, ``rtl.pixel.Pipeline(params, writes)``).
    in_stages : int, optional
        Registers between ``i`` and the flat unit's first stage, holding nothing but the accepted input and its
        valid (default 0): the producer's output (a FIFO's LUT RAM read through its multiplexer, the engine's scan
        converter) then meets no logic of the unit's first stage in the same clock. The latency is
        ``params.latency + in_stages`` (:attr:`latency`), the FIFO :func:`buffer_depth` ``(params, in_stages)``.

    Ports
    -----
    i : ``In(stream.Signature(input_layout(params, side)))``
        ``i.payload.<input>`` in the input's format (e.g. ``i.payload.w`` in ``RecipParams.in_fmt``);
        ``i.ready`` is a register (room for the results in flight and buffered), not a function of ``i.valid``.
    o : ``Out(stream.Signature(output_layout(params, side)))``
        ``o.payload.<output>`` in the output's format; the result of the input accepted ``params.latency``
        cycles earlier when nothing stalled.

    Verilog ports (``rtl.verilog_text``): ``clk``, ``rst``, ``i__valid``, ``i__ready``, ``i__payload`` (field ``f``
    at bits ``[offset +: width]`` of ``input_layout``, first field lowest), ``o__valid``, ``o__ready``,
    ``o__payload``.
    """

    def __init__(self, params, side=None, unit=None, in_stages: int = 0):
        if not (isinstance(in_stages, int) and in_stages >= 0):
            raise ValueError(f"in_stages={in_stages!r}: must be an int >= 0")
        self.params, self.side, self.unit, self.in_stages = params, side, unit, in_stages
        self.latency = int(params.latency) + in_stages
        super().__init__({"i": In(stream.Signature(input_layout(params, side))),
                          "o": Out(stream.Signature(output_layout(params, side)))})

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = _Core(self.params, self.side, self.unit)
        depth = buffer_depth(self.params, self.in_stages)
        lay = output_layout(self.params, self.side)
        m.submodules.fifo = fifo = SyncFIFO(width=lay.size, depth=depth)
        used = Signal(range(depth + 1), name="used")      # results in flight and in the FIFO
        take_in = self.i.valid & self.i.ready
        valid, payload = take_in, self.i.payload.as_value()
        for k in range(1, self.in_stages + 1):            # the input registers (``in_stages``)
            v, p = Signal(name=f"in{k}_valid"), Signal(len(payload), name=f"in{k}_payload")
            m.d.sync += [v.eq(valid), p.eq(payload)]
            valid, payload = v, p
        # ``i.ready`` is a register equal on every clock to ``used < depth`` (the formal set checks it), the
        # compares on ``used`` side by side and the handshakes choosing at the last level: the compare and its
        # route led into the producer's read enables (the texel caches' lookup FIFOs before the back of
        # ``rtl/pixel_fetch.py``: ``docs/fpga/placement-texcache.json``)
        room = Signal(name="room", init=1)
        take_out = self.o.valid & self.o.ready
        m.d.sync += room.eq(Mux(take_out, 1, Mux(take_in, used < depth - 1, room)))
        m.d.comb += [self.i.ready.eq(room), core.i_valid.eq(valid), core.i_payload.eq(payload)]
        # the last stage's result goes straight out while the FIFO is empty, else the FIFO's oldest. Whether it
        # is empty is a register of its own, kept beside the FIFO's level (equal to ``~fifo.r_rdy``: the formal
        # set checks it): ``r_rdy`` is a compare of the level, and through the output multiplexer it led into the
        # consumer's logic (the pixel index of the frame's depth test: a path of the board's engine)
        nonempty = Signal(name="fifo_nonempty")
        empty = ~nonempty
        m.d.comb += [self.o.valid.eq(Mux(empty, core.o_valid, 1)),
                     self.o.payload.eq(Mux(empty, core.o_payload.as_value(), fifo.r_data)),
                     fifo.w_data.eq(core.o_payload),
                     fifo.w_en.eq(core.o_valid & ~(empty & self.o.ready)),
                     fifo.r_en.eq(self.o.ready & ~empty)]
        m.d.sync += [used.eq(used + take_in - (self.o.valid & self.o.ready)),
                     nonempty.eq(less_one_if(fifo.r_en, fifo.level + fifo.w_en, lambda v: v != 0))]
        return m


class CreditFIFO(wiring.Component):
    """A first-word-fall-through FIFO of ``depth`` words of ``width`` bits (LUT RAM, an asynchronous read port)
    for a writer that holds credits: it writes only when it knows a place is free, so ``w_en`` is not checked
    against the level (``amaranth.lib.fifo.SyncFIFO`` gates every write with ``level != depth``: on the scan
    converter's output FIFO that check and the level's adder after it were a five-LUT path from the level to the
    level, and the write enable of every LUT RAM slice waited for it). ``r_rdy`` (not empty) is a register,
    computed beside the level with the read at the last logic level (:func:`less_one_if`).

    Ports: ``w_en``, ``w_data`` in; ``r_en``, out ``r_rdy``, ``r_data`` (the oldest word while ``r_rdy``); ``level``
    out (the words held) and ``w_rdy`` (``level != depth``, as ``SyncFIFO``'s, for the writer's proofs: nothing in
    the FIFO reads it). A write into a full FIFO is the writer's error: ``overflow`` (out, registered, sticky)
    says it happened (tests check it stays 0; nothing reads it in hardware).
    """

    def __init__(self, width: int, depth: int):
        if depth < 2:
            raise ValueError(f"CreditFIFO: depth {depth} must be at least 2")
        self.width, self.depth = width, depth
        super().__init__({"w_en": In(1), "w_data": In(width), "r_en": In(1), "r_rdy": Out(1),
                          "r_data": Out(width), "level": Out(range(depth + 1)), "w_rdy": Out(1),
                          "overflow": Out(1)})

    def elaborate(self, platform):
        m = Module()
        n = self.depth
        m.submodules.storage = mem = memory.Memory(shape=self.width, depth=n, init=[])
        wp, rp = mem.write_port(), mem.read_port(domain="comb")
        wptr, rptr = Signal(range(n)), Signal(range(n))
        take = self.r_en & self.r_rdy
        m.d.comb += [wp.addr.eq(wptr), wp.data.eq(self.w_data), wp.en.eq(self.w_en),
                     rp.addr.eq(rptr), self.r_data.eq(rp.data), self.w_rdy.eq(self.level != n)]
        with m.If(self.w_en):
            m.d.sync += wptr.eq(Mux(wptr == n - 1, 0, wptr + 1))
        with m.If(take):
            m.d.sync += rptr.eq(Mux(rptr == n - 1, 0, rptr + 1))
        after_write = self.level + self.w_en
        m.d.sync += [self.level.eq(less_one_if(take, after_write)),
                     self.r_rdy.eq(less_one_if(take, after_write, lambda v: v != 0))]
        with m.If(self.w_en & ~self.w_rdy):
            m.d.sync += self.overflow.eq(1)
        if platform == "formal":
            # the FIFO's own invariants, as Amaranth's SyncFIFO asserts its own on this platform (they make the
            # induction of any set around it go through), and every word held, for the proof of the contract
            # (formal/credit_fifo.py)
            m.d.comb += [Assert(self.level <= n, "credit_fifo_level"),
                         Assert(self.r_rdy == (self.level != 0), "credit_fifo_r_rdy"),
                         Assert(wptr == (rptr + self.level) % n, "credit_fifo_pointers"),
                         Assert(rptr < n, "credit_fifo_head_range")]      # a depth not a power of two
            head = Signal(range(n), name="head")           # the read pointer, named for the proofs
            m.d.comb += head.eq(rptr)
            for k in range(n):
                port, slot = mem.read_port(domain="comb"), Signal(self.width, name=f"slot{k}")
                m.d.comb += [port.addr.eq(k), slot.eq(port.data)]
        return m
