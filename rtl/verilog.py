"""Verilog of a unit: its stream version (``rtl/streams.py``, what ``make verilog`` and ``make fpga`` write) or
the flat pipeline of :func:`rtl.unit.build`, optionally through Yosys' equivalence-preserving optimizations.
"""

from __future__ import annotations

import re
from pathlib import Path

from .streams import StreamUnit
from .unit import build, stream_native

__all__ = ["verilog_text", "write_verilog", "component_verilog"]


def verilog_text(params, name: str, optimize: bool = False, flat: bool = False) -> str:
    """Verilog of the unit as module ``name``: its stream version (:class:`rtl.streams.StreamUnit`, what
    ``make verilog`` and ``make fpga`` write), or with ``flat=True`` the flat pipeline of :func:`build`
    (``i_valid``, one port per input, ``o_valid``, one port per output: the per-vector co-simulation drives it).
    A design with stream ports of its own (:func:`rtl.unit.stream_native`: the scan converter, the engine from the
    triangle) is written as it is.

    ``optimize=True`` flattens the hierarchy and runs Yosys' logic optimizations (``opt -full``, ``wreduce``)
    before writing: the same design (Yosys' equivalence-preserving passes, as any synthesis flow runs them), in a
    form event-driven simulators evaluate far faster. Measured on the reflection unit: Icarus 18 times faster.
    """
    # a design with stream ports of its own (the ROP, the scan converter, the engine from the triangle)
    stream = flat or stream_native(params)
    return component_verilog(build(params) if stream else StreamUnit(params), name, optimize)


def component_verilog(comp, name: str, optimize: bool = False, rename: bool = False) -> str:
    """Verilog of any Amaranth component as module ``name`` (optionally optimized: :func:`verilog_text`).
    ``rename=True`` lets Yosys give its internal names plain identifiers: Icarus cannot read the functions
    ``write_verilog -norename`` writes for a parallel multiplexer (``$pmux``) under their ``$`` names."""
    if not optimize:
        from amaranth.back import verilog
        return verilog.convert(comp, name=name, emit_src=False)
    from amaranth._toolchain.yosys import find_yosys
    from amaranth.back import rtlil
    text = rtlil.convert(comp, name=name, emit_src=False)
    script = [f"read_rtlil <<rtlil\n{text}\nrtlil", "proc", "flatten", "opt -full", "wreduce",
              "opt_clean", "memory_collect", "write_verilog -noattr" + ("" if rename else " -norename")]
    return find_yosys(lambda ver: ver >= (0, 40)).run(["-q", "-"], "\n".join(script), ignore_warnings=True)


def write_verilog(params, path, optimize: bool = False, flat: bool = False) -> Path:
    """Write the unit's Verilog (:func:`verilog_text`) to ``path`` as module ``path.stem``, with every character that is not a letter,
    digit or ``_`` made ``_`` (``pipeline_tin-plane-fit_tin-plane.v`` holds ``pipeline_tin_plane_fit_tin_plane``:
    a plain identifier rather than an escaped one)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(verilog_text(params, re.sub(r"\W", "_", path.stem), optimize, flat))
    return path
