"""cocotb testbench of the frame in SDRAM (``cosim/sdram_frame.py``'s ``SdramFrameBench``), driven by
:func:`cosim.sdram_frame.run`: the pixel clock ``clk`` and the memory's ``dram_clk`` (periods from ``job.json``), an
``AxiRam`` on ``mem`` (every channel paused with probability ``p_pause``), the copies' words offered on ``i`` (each
clock with probability ``p_valid``; each copy's place and ``show`` beside them). Every pixel clock ``x``, ``y``,
``color`` are recorded (``clocks.npy``) until the last copy has been shown for ``extra_frames`` frames; every ``AW``
and ``AR`` (address, beats), the copies' ``copied`` pulses, the flags and both buffers' contents go into
``result.json``.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly

from cosim.tb_common import Source, job_meta, pauses


async def _feed(dut, copies, rng, p_valid, state):
    """Offer the copies' words on ``i`` (``dram`` clock), an offered word held until taken; each copy's place and
    ``show`` set before its first word and held until its last write (``copied``), as the board's tile copy does."""
    for k, c in enumerate(copies):
        while state["copied"] < k:
            await FallingEdge(dut.dram_clk)
        for port in ("col", "row"):                      # (absent when the grid has one column, one row)
            if hasattr(dut, port):
                getattr(dut, port).value = c[port]
        dut.show.value = c["show"]
        src = Source.on(dut, c["words"], rng, p_valid)
        while not src.done:
            await FallingEdge(dut.dram_clk)
            src.drive()
            await ReadOnly()
            src.taken()
        await FallingEdge(dut.dram_clk)
        dut.i__valid.value = 0


async def _watch(dut, state):
    """Count ``copied`` and record every ``AW`` and ``AR`` (``dram`` clock)."""
    while True:
        await FallingEdge(dut.dram_clk)
        await ReadOnly()
        state["copied"] += int(dut.copied.value)
        for ch, out in (("aw", state["aw"]), ("ar", state["ar"])):
            if int(getattr(dut, f"mem__{ch}valid").value) and int(getattr(dut, f"mem__{ch}ready").value):
                out.append([int(getattr(dut, f"mem__{ch}addr").value), int(getattr(dut, f"mem__{ch}len").value) + 1])


async def _count(dut, state):
    """Count ``copied`` and note when the LiteDRAM core's port opened (``ready``)."""
    from cocotb.utils import get_sim_time
    while True:
        await FallingEdge(dut.dram_clk)
        await ReadOnly()
        state["copied"] += int(dut.copied.value)
        if "ready_ns" not in state and int(dut.ready.value):
            state["ready_ns"] = get_sim_time("ns")


@cocotb.test()
async def sdram_frame(dut):
    from cocotbext.axi import AxiBus, AxiRam
    _, meta = job_meta()
    rng = random.Random(meta["seed"])
    cocotb.start_soon(Clock(dut.clk, meta["pixel_ns"], unit="ns").start())
    cocotb.start_soon(Clock(dut.dram_clk, meta["dram_ns"], unit="ns").start())
    dut.rst.value = 1
    dut.dram_rst.value = 1
    dut.i__valid.value = 0
    dut.i__payload.value = 0
    ram = None
    if not meta["litedram"]:
        ram = AxiRam(AxiBus.from_prefix(dut, "mem_"), dut.dram_clk, dut.dram_rst, size=meta["mem_bytes"])
        for side in (ram.write_if, ram.read_if):
            side.log.setLevel("WARNING")
    if ram is not None and meta["p_pause"] > 0:
        for k, ch in enumerate((ram.write_if.aw_channel, ram.write_if.w_channel, ram.write_if.b_channel,
                                ram.read_if.ar_channel, ram.read_if.r_channel)):
            ch.set_pause_generator(pauses(random.Random(meta["seed"] * 7 + k), meta["p_pause"]))
    for _ in range(4):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    dut.dram_rst.value = 0
    state = {"copied": 0, "aw": [], "ar": []}
    if ram is not None:                                   # (the LiteDRAM bench's AXI port is inside)
        cocotb.start_soon(_watch(dut, state))
    else:
        cocotb.start_soon(_count(dut, state))
    cocotb.start_soon(_feed(dut, meta["copies"], rng, meta["p_valid"], state))
    n, frame = sum(c["show"] for c in meta["copies"]), meta["frame_clocks"]
    limit = frame * (4 * len(meta["copies"]) + 8 + meta["extra_frames"])
    rows, flips, last_front, after = [], 0, 0, None
    while len(rows) < limit:
        await FallingEdge(dut.clk)
        rows.append((int(dut.x.value), int(dut.y.value), int(dut.color.value)))
        front = int(dut.front.value)
        flips += front != last_front
        last_front = front
        if after is None and flips >= n:
            after = len(rows)
        if after is not None and len(rows) >= after + frame * (meta["extra_frames"] + 1):
            break
    job = Path(meta["out"]).parent
    np.save(job / "clocks.npy", np.array(rows, dtype=np.int64))
    buffers = [] if ram is None else [b"".join(ram.read(a, 2 * meta["width"]) for a in lines).hex()
                                      for lines in meta["buffers"]]
    Path(meta["out"]).write_text(json.dumps({
        "copied": state["copied"], "flips": flips, "aw": state["aw"], "ar": state["ar"],
        "underrun": int(dut.underrun.value), "error": int(dut.error.value), "cycles": len(rows),
        "buffers": buffers, "ready_ns": state.get("ready_ns")}))
