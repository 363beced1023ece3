"""cocotb testbench of the texel cache (``rtl/texcache.py``), driven by :func:`cosim.texcache.run`.

``job.json`` in the folder named by ``COSIM_JOB`` holds the request words (hex), the memory image of the map and its
base address, the probabilities that the source offers a request in a cycle (``p_valid``; an offered request stays
offered until taken), that the sink is ready (``p_ready``) and of a wait state on each AXI read channel
(``p_pause``). Behind ``mem`` is cocotbext-axi's ``AxiRam``. The testbench records every ``AR`` transfer's address
and length, counts the ``R`` beats and collects the outputs, and writes them to ``result.json``.
"""

from __future__ import annotations

import json
import logging
import os
import random
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly


def _pauses(rng: random.Random, p: float):
    while True:
        yield rng.random() < p


@cocotb.test()
async def texcache(dut):
    from cocotbext.axi import AxiBus, AxiRam
    job = Path(os.environ["COSIM_JOB"])
    meta = json.loads((job / "job.json").read_text())
    reqs = [int(r, 16) for r in meta["requests"]]
    rng = random.Random(meta["seed"])
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.i__valid.value = 0
    dut.i__payload.value = 0
    dut.o__ready.value = 0
    image = bytes.fromhex(meta["image"])
    size = 1 << max(12, (meta["base"] + len(image)).bit_length())
    ram = AxiRam(AxiBus.from_prefix(dut, "mem_"), dut.clk, dut.rst, size=size)
    ram.write(meta["base"], image)
    for side in (ram.write_if, ram.read_if):
        side.log.setLevel(logging.WARNING)
    for k, ch in enumerate((ram.read_if.ar_channel, ram.read_if.r_channel)):
        if meta["p_pause"] > 0:
            ch.set_pause_generator(_pauses(random.Random(meta["seed"] * 7 + k), meta["p_pause"]))
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    k, offered, cycles, beats, ar, outputs = 0, False, 0, 0, [], []
    while len(outputs) < len(reqs):
        await FallingEdge(dut.clk)
        cycles += 1
        assert cycles < meta["max_cycles"], f"no progress after {cycles} cycles ({len(outputs)} of {len(reqs)})"
        if k < len(reqs) and not offered:
            offered = rng.random() < meta["p_valid"]
            if offered:
                dut.i__payload.value = reqs[k]
        dut.i__valid.value = int(offered)
        dut.o__ready.value = int(rng.random() < meta["p_ready"])
        await ReadOnly()
        if offered and int(dut.i__ready.value):
            k += 1
            offered = False
        if int(dut.o__valid.value) and int(dut.o__ready.value):
            outputs.append(format(int(dut.o__payload.value), "x"))
        if int(dut.mem__arvalid.value) and int(dut.mem__arready.value):
            ar.append([int(dut.mem__araddr.value), int(dut.mem__arlen.value)])
        beats += int(dut.mem__rvalid.value) & int(dut.mem__rready.value)
    (job / "result.json").write_text(json.dumps({"outputs": outputs, "ar": ar, "beats": beats, "cycles": cycles}))
