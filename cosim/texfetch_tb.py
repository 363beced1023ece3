"""cocotb testbench of the decoupled texel cache (``rtl/texcache_decoupled.py`` in ``cosim.texfetch.FetchBench``),
driven by :func:`cosim.texfetch.run`.

``job.json`` (folder ``COSIM_JOB``) holds the request words (hex), the memory image of the surfaces and its base,
the bench's latency, the probabilities that the source offers a request in a cycle (``p_valid``; an offered
request stays offered until taken), that the sink is ready (``p_ready``) and of a wait state on each AXI read
channel (``p_pause``). Behind ``mem`` is cocotbext-axi's ``AxiRam``. Recorded: every ``AR`` transfer's address and
length (at the memory, after the delay queue), the ``R`` beats, the outputs, and the cycles from reset to the last
output; written to ``result.json``.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly

from cosim.tb_common import axi_ram, job_meta, start


@cocotb.test()
async def texfetch(dut):
    _, meta = job_meta()
    reqs = [int(r, 16) for r in meta["requests"]]
    rng = random.Random(meta["seed"])
    start(dut)
    dut.lat.value = meta["latency"]
    _ram = axi_ram(dut, meta["base"], bytes.fromhex(meta["image"]), meta["seed"], meta["p_pause"],
                   write=False)                            # the memory model lives as long as the test
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
    Path(meta["out"]).write_text(json.dumps({"outputs": outputs, "ar": ar, "beats": beats, "cycles": cycles}))
