"""cocotb testbench of the raster-operations unit (``rtl/rop.py``) and of the engine with its depth test, driven
by :func:`cosim.rop.run` and :func:`cosim.rop.run_engine`.

``job.json`` in the folder named by ``COSIM_JOB`` holds the packed input words (fragments, or triangle records for
the engine; hex, first field in the low bits), the probability ``p_valid`` that the source offers a word in a
cycle (a word once offered stays offered until taken: the stream rule), the wait-state probability ``p_pause`` of
every AXI channel, the bench's latency ``lat``, the frame's initial memory image and ``drain``, the cycles
``busy`` must stay low before the run ends (the engine's pixel pipeline holds fragments that ``busy`` does not
see: its latency). Behind the port the memory is cocotbext-axi's ``AxiRam`` with a pause generator on each of
its five channels; the testbench counts ``AR`` and ``AW`` transfers. At the end it writes the memory image of the
frame (or, on chip, the words read out through ``fb``) and the counts into ``frame.json``.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly

from cosim.tb_common import Source, axi_ram, job_meta, start


@cocotb.test()
async def rop(dut):
    _, meta = job_meta()
    frags = [int(f, 16) for f in meta["words"]]
    rng = random.Random(meta["seed"])
    on_chip = meta["on_chip"]
    start(dut, output_ready=False)
    ram = None
    if on_chip:
        dut.fb__read.value = 0
        dut.fb__clear.value = 0
        dut.fb__addr.value = 0
    else:
        dut.lat.value = meta["latency"]
        ram = axi_ram(dut, meta["base"], bytes.fromhex(meta["init"]), meta["seed"], meta["p_pause"])
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    busy = [dut.busy] + ([dut.rop_busy] if meta["on_chip"] and meta["engine"] else [])
    src = Source.on(dut, frags, rng, meta["p_valid"])
    idle, cycles, reads, writes, accept_cycles = 0, 0, 0, 0, 0
    while idle < meta["drain"]:
        await FallingEdge(dut.clk)
        cycles += 1
        assert cycles < meta["max_cycles"], f"no progress after {cycles} cycles ({src.k} of {len(frags)} fragments)"
        src.drive()
        await ReadOnly()
        if src.taken():
            accept_cycles = cycles
        if not on_chip:
            reads += int(dut.mem__arvalid.value) & int(dut.mem__arready.value)
            writes += int(dut.mem__awvalid.value) & int(dut.mem__awready.value)
        idle = idle + 1 if src.done and not any(int(b.value) for b in busy) else 0
    status = int(dut.status.value)
    result = {"cycles": cycles, "accept_cycles": accept_cycles, "reads": reads, "writes": writes, "status": status}
    if on_chip:
        await FallingEdge(dut.clk)                       # out of the read-only phase
        dut.fb__read.value = 1
        dut.fb__clear.value = 1                      # the read-out clears: a second read-out sees the clear words
        result["words"] = await read_out(dut, meta["pixels"], meta["readout_latency"])
        dut.fb__clear.value = 0
        result["cleared"] = await read_out(dut, meta["pixels"], meta["readout_latency"])
        result["status_cleared"] = int(dut.status.value)        # the clearing read-out cleared the flags
    else:
        result["image"] = ram.read(meta["base"], meta["frame_bytes"]).hex()
    Path(meta["out"]).write_text(json.dumps(result))


async def read_out(dut, pixels: int, latency: int) -> list:
    """The frame's words through ``fb`` (``fb.read`` set): an address each clock, its word ``latency`` clock
    edges later (``RopParams.readout_latency``); returns them as hex strings."""
    words = []
    for a in range(pixels + latency):
        dut.fb__addr.value = min(a, pixels - 1)
        await FallingEdge(dut.clk)
        if a >= latency - 1 and len(words) < pixels:
            words.append(format(int(dut.fb__data.value), "x"))
    return words
