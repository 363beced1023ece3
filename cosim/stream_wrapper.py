"""The generated HDL wrapper of the streaming co-simulation (:mod:`cosim.stream`).

:func:`wrapper_verilog` renders the testbench top (``stream_wrapper.v.j2``) around the stream version of a unit: it
loads chunks of binary words with ``$fread``, makes the clock and the stimulus patterns (:data:`PATTERNS`),
compares every output and counts mismatches and protocol errors. :func:`stand_in_verilog` is a unit with the
stream ports and no logic, whose rate is the harness' own cost. The memory word's layout
(:func:`memory_fields`) is shared with the vector files the model writes.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from fxmodel.core.vectors import layout

__all__ = ["PATTERNS", "DEPTH", "PERIOD_NS", "MAX_PATH", "TEMPLATE", "render", "wrapper_verilog", "stand_in_verilog",
           "clock_style", "memory_fields", "word_codes", "split_word"]

#: Words of the wrapper's vector memory (the largest chunk); fixed so every run reuses one build per unit.
DEPTH = 1 << 20
#: Longest path the wrapper's file-name registers hold.
MAX_PATH = 512
PERIOD_NS = 10


_KEYWORDS = set("""always and assign automatic begin buf bufif0 bufif1 case casex casez cell cmos config deassign
default defparam design disable edge else end endcase endconfig endfunction endgenerate endmodule endprimitive
endspecify endtable endtask event for force forever fork function generate genvar highz0 highz1 if ifnone incdir
include initial inout input instance integer join large liblist library localparam macromodule medium module nand
negedge nmos nor noshowcancelled not notif0 notif1 or output parameter pmos posedge primitive pull0 pull1 pulldown
pullup pulsestyle_onevent pulsestyle_ondetect rcmos real realtime reg release repeat rnmos rpmos rtran rtranif0
rtranif1 scalared showcancelled signed small specify specparam strong0 strong1 supply0 supply1 table task time tran
tranif0 tranif1 tri tri0 tri1 triand trior trireg unsigned use uwire vectored wait wand weak0 weak1 while wire wor
xnor xor bit byte logic int shortint longint string""".split())


def _vid(name: str) -> str:
    """A Verilog identifier for ``name`` (escaped, as Yosys writes it, if not a plain identifier)."""
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_$]*", name) and name not in _KEYWORDS:
        return name
    return f"\\{name} "


def memory_fields(params):
    """The fields of a memory word, most significant first: the input payload, then the output payload, each in
    the field order of ``rtl.streams`` (first port at the lowest bits), so that the word's input part is
    ``i__payload`` and its output part ``o__payload`` bit for bit."""
    return [(p.name, p.fmt) for p in params.inputs[::-1] + params.outputs[::-1]]


def word_codes(inputs, expected) -> np.ndarray:
    """Codes of inputs and expected outputs (port order) in :func:`memory_fields` order."""
    return np.concatenate([inputs[:, ::-1], expected[:, ::-1]], axis=1)


def split_word(word: int, ports, lsb: int = 0) -> list:
    """The codes of ``ports`` (in port order) in ``word``, packed as a payload (first port lowest) from bit
    ``lsb``."""
    out = []
    for p in ports:
        out.append(int(p.fmt.from_bits(np.array([(word >> lsb) & ((1 << p.fmt.width) - 1)], dtype=object))[0]))
        lsb += p.fmt.width
    return out


_CLOCKS = {
    # A zero-width pulse: the rising edge and the falling edge in one time step (the fall after #0, in the
    # inactive region, before the non-blocking updates). Posedge logic sees an ordinary clock, but the simulator
    # takes one time step a cycle instead of two: Verilator under cocotb spends about as much in its per-time-step
    # VPI bookkeeping as in the design, so this is measured 1.3 times faster there (Icarus: no change).
    "pulse": f"  always begin #{PERIOD_NS} clk = 1'b1; #0 clk = 1'b0; end  // zero-width pulse: see cosim/stream.py",
    # An ordinary 50 % clock: for a unit with negedge logic, and for waveforms (a zero-width pulse is invisible).
    "square": f"  always #{PERIOD_NS // 2} clk = ~clk;",
}


def clock_style(dut_text: str, waves: bool) -> str:
    """``pulse`` unless the unit has negedge logic or waveforms are wanted (then ``square``)."""
    return "square" if waves or re.search(r"\bnegedge\b", dut_text) else "pulse"


#: The wrapper's template (Jinja2), rendered by :func:`wrapper_verilog`.
TEMPLATE = Path(__file__).with_name("stream_wrapper.v.j2")
#: Stimulus patterns: name -> (input valid mode, output ready mode), the modes of the template's MODES comment:
#: 0 always on, 1 random 50 %, 2 bursts (runs of 1 to 64 cycles on and off), 3 stalls (on for 1 to 1024 cycles,
#: off for 256 to 767).
PATTERNS = {"none": (0, 0), "random": (1, 1), "bursts": (2, 2), "stalls": (1, 3)}


def render(template: Path, **values) -> str:
    """``template`` (a Jinja2 file) with ``values``; an undefined name in the template is an error."""
    import jinja2
    env = jinja2.Environment(undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    return env.from_string(template.read_text()).render(**values)


def wrapper_verilog(params, top: str, dut: str, *, depth: int = DEPTH, keep: int = 8, clock: str = "pulse",
                    expand: bool = False, busy: bool = False) -> str:
    """Verilog of the streaming testbench wrapper ``top`` around the stream version of the unit, module ``dut``
    (:class:`rtl.streams.StreamUnit`: ``clk``, ``rst``, ``i__valid``, ``i__ready``, ``i__payload``,
    ``o__valid``, ``o__ready``, ``o__payload``; payload fields at the offsets of ``rtl.streams.input_layout``
    and ``output_layout``), rendered from :data:`TEMPLATE`.

    The wrapper's own ports are written by cocotb: ``rst``, ``counter`` (inputs from the row counter
    ``chunk_base + position``, the file holding expected outputs only), ``chunk_base``, ``chunk_len`` (vectors in
    the chunk), ``pattern`` and ``seed`` (the chunk's stimulus, :data:`PATTERNS`), ``dump`` (write the outputs to
    ``out_<k>.hex``) and ``load_seq`` (set to ``k + 1`` once ``chunk_<k>.bin`` is ready in the folder named by
    the plusarg ``+STREAM_DIR=``); it answers by raising ``done_seq`` to ``k + 1`` once every output of chunk
    ``k`` has been compared.

    Counters (64 bits): ``checked``, ``mismatches``, ``valid_errors`` (under pattern ``none``: cycles where
    ``o__valid`` differs from the input handshake delayed by the latency), ``missing`` (vectors whose output
    never came), ``extra`` (outputs taken that no vector asked for), ``protocol_errors`` (an output offered and
    not taken that changed or was withdrawn), ``cycles``, ``stalled`` (cycles an output waited for ready),
    ``starved`` (cycles an input waited for ready). The first ``keep`` mismatches are kept in ``rec_index`` (run
    index, 64 bits each), ``rec_vector`` (the memory word: inputs and expected outputs; zeros for the inputs in
    counter mode) and ``rec_got`` (the unit's outputs), slot ``s`` at bits ``[s*width +: width]``. The
    ``depth``-word vector memory is the submodule ``<top>_mem``; ``clock`` is a key of ``_CLOCKS`` (see
    :func:`clock_style`).

    ``expand=True``: a design whose inputs give any number of outputs each (triangle records in, fragments out:
    :func:`run_records`). The memory word is the inputs only; two more ports, ``out_len`` (the outputs the
    chunk's inputs give, the model's count) and ``limit`` (cycles after which an unfinished chunk ends), and no
    comparison inside: every output taken is written to ``out_<k>.hex`` (``dump``) for the caller to compare, and
    ``missing`` / ``extra`` count against ``out_len``; no fixed-latency check. ``busy=True``: the design has an
    output ``busy`` (working on an input): the counter ``busy_cycles`` counts its cycles. In ``expand`` mode a
    chunk ends once every input was taken and no output came for ``latency + 8`` cycles with ``o.ready`` high
    (and ``busy`` low), or after ``limit`` cycles.
    """
    from rtl.streams import input_layout, output_layout

    fields = memory_fields(params)
    lay = layout(fields)
    n_in = len(params.inputs)
    ow = sum(p.fmt.width for p in params.outputs)
    iw = sum(p.fmt.width for p in params.inputs)
    lat = int(params.latency)
    if lat < 1:
        raise ValueError(f"{params.NAME}: latency {lat}: the streaming wrapper needs registered outputs "
                         "(latency >= 1)")
    if not 1 <= keep <= 64:
        raise ValueError(f"keep={keep}: keep 1 to 64 mismatch records")
    if depth < 1 or depth & (depth - 1):
        raise ValueError(f"depth={depth}: must be a power of two")
    if clock not in _CLOCKS:
        raise ValueError(f"clock={clock!r}: one of {', '.join(_CLOCKS)}")
    # the memory word's parts are the payloads: every field at its payload offset (rtl.streams layouts)
    lin, lout = input_layout(params), output_layout(params)
    offsets = {**{(0, n): f.offset for n, f in lin}, **{(1, n): f.offset for n, f in lout}}
    if lin.size != iw or lout.size != ow:
        raise AssertionError(f"{params.NAME}: the payloads are {lin.size} and {lout.size} bits, the ports {iw} "
                             f"and {ow}")
    for k, (name, _, _, lsb) in enumerate(lay):
        out = k >= n_in
        if offsets[(int(out), name)] != (lsb if out else lsb - ow):
            raise AssertionError(f"{params.NAME}: field {name} of the memory word is not at its payload offset")
    rows = [{"name": name, "fmt": str(fmt), "msb": msb, "lsb": lsb} for name, fmt, msb, lsb in lay]
    # expand mode: the memory word is the input payload alone
    inputs = [{**r, "msb": r["msb"] - ow, "lsb": r["lsb"] - ow} for r in rows[:n_in]] if expand else rows[:n_in]
    # counter mode: row i of the whole input space is the bit pattern of i with each signed field's top bit
    # inverted (code = min_code + digit, first port slowest, i.e. most significant; see Unit.all_inputs), its
    # fields then rearranged into the payload's order (first port lowest)
    rows_lay = layout([(p.name, p.fmt) for p in params.inputs])
    sign_mask = sum(1 << msb for _, fmt, msb, _ in rows_lay if fmt.signed)
    counted = "row" if len(rows_lay) == 1 else \
        "{" + ", ".join(f"row[{msb}:{lsb}]" for _, _, msb, lsb in rows_lay[::-1]) + "}"
    return render(TEMPLATE, unit=params.NAME, top=top, dut=dut, dut_id=_vid(dut), fields=rows,
                  inputs=inputs, outputs=rows[n_in:], iw=iw, ow=ow, depth=depth, keep=keep, latency=lat,
                  period=PERIOD_NS, sign_mask=sign_mask, counted=counted, clock=_CLOCKS[clock],
                  max_path=MAX_PATH, expand=expand, busy=busy,
                  vpipe_next="take_in" if lat == 1 else f"{{vpipe[{lat - 2}:0], take_in}}")



def stand_in_verilog(params, name: str, optimize: bool = False) -> str:
    """Verilog of a stand-in with the stream ports of ``params``' unit and none of its logic: one register from
    ``i`` to ``o`` that takes a new input whenever it is empty or ``o`` takes its output (the payload bits copied
    as far as they go). The streaming wrapper
    around it costs what the harness itself costs a cycle: the floor under any unit's rate
    (:func:`measure_throughput` with ``stand_in=True``). ``optimize``: written as the units are for Icarus
    (:func:`rtl.verilog.component_verilog`)."""
    from amaranth.hdl import Module
    from amaranth.lib import stream, wiring
    from amaranth.lib.wiring import In, Out

    from rtl.streams import input_layout, output_layout

    class StandIn(wiring.Component):
        def __init__(self):
            super().__init__({"i": In(stream.Signature(input_layout(params))),
                              "o": Out(stream.Signature(output_layout(params)))})

        def elaborate(self, platform):
            m = Module()
            m.d.comb += self.i.ready.eq(self.o.ready | ~self.o.valid)
            with m.If(self.i.ready):
                m.d.sync += [self.o.valid.eq(self.i.valid),
                             self.o.payload.as_value().eq(self.i.payload.as_value())]
            return m
    from rtl.verilog import component_verilog
    return component_verilog(StandIn(), name, optimize)
