"""The simulation build of the streaming co-simulation (:mod:`cosim.stream`), made once per content.

:func:`build` writes the unit's Verilog (or the stand-in's, :func:`cosim.stream_wrapper.stand_in_verilog`) and the
wrapper into a build folder keyed by the parameters, the sources and the build options, and compiles them with
the options of :mod:`cosim.simulators`; a stamp of the texts skips a rebuild, a lock serializes concurrent runs.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

from fxmodel.core.paths import build_dir
from rtl.digest import params_key

from .simulators import build_args, verilator_env
from .stream_wrapper import DEPTH, clock_style, stand_in_verilog, wrapper_verilog

__all__ = ["BUILD", "STAND_IN", "Build", "build", "verbose", "tail"]

BUILD = build_dir("stream")
#: The variant name of :func:`~cosim.stream_wrapper.stand_in_verilog` builds.
STAND_IN = "stand-in"


@dataclass
class Build:
    """A built simulation: simulator, build folder, top module, seconds the build took, ``busy`` counted."""

    sim: str
    bdir: Path
    top: str
    seconds: float
    busy: bool = False



def build(params, rtl_params, variant: str, sim: str, keep: int, waves: bool, stand_in: bool = False,
           expand: bool = False, depth: int = DEPTH, optimize: bool | None = None) -> Build:
    """Generate the unit's Verilog (from ``rtl_params``) and the wrapper, and build the simulation once per
    content: the build folder is keyed by :func:`cosim.harness.params_key` (parameters and sources) and the
    variant; a stamp of the Verilog texts and build options skips rebuilding. Concurrent runs (pytest-xdist)
    serialize on a lock file. ``expand``: the wrapper's ``expand`` mode for a design whose inputs give any number
    of outputs (with stream ports of its own, ``rtl.unit.stream_native``: the engine from the triangle)
    (:func:`~cosim.stream_wrapper.wrapper_verilog`), with its ``busy`` output
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
        args = build_args(sim, timing=True)
        stamp = bdir / "build.stamp"
        digest = hashlib.sha1((src.read_text() + text + repr(args) + str(waves)).encode()).hexdigest()
        if not (stamp.exists() and stamp.read_text() == digest):
            stamp.unlink(missing_ok=True)
            log = bdir / "build.log"
            if sim == "verilator":
                verilator_env()
            try:
                get_runner(sim).build(sources=[src, wrapper], hdl_toplevel=top, build_dir=bdir,
                                      timescale=("1ns", "1ps"), waves=waves, build_args=args, always=True,
                                      log_file=None if verbose() else log)
            except (RuntimeError, SystemExit) as exc:
                raise RuntimeError(f"building the {sim} simulation of {params.NAME} failed ({exc}); "
                                   f"log: {log}\n{tail(log)}") from None
            stamp.write_text(digest)
    return Build(sim, bdir, top, time.perf_counter() - t0, busy)


def verbose() -> bool:
    """``STREAM_VERBOSE`` set: simulator output to the terminal instead of log files."""
    return os.environ.get("STREAM_VERBOSE", "0") not in ("", "0")


def tail(path: Path, lines: int = 15) -> str:
    """The last ``lines`` lines of a log file (empty if it cannot be read)."""
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""
