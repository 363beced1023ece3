"""cocotb testbench shared by every unit: streams one input vector per clock, records every output.

The harness (``cosim.harness``) writes ``inputs.npy`` (bit patterns, one column per input port) and
``meta.json`` (port names, latency) into the job folder named by ``COSIM_JOB``; this testbench drives the ports
of the same names, checks that ``o_valid`` follows ``i_valid`` by exactly the documented latency, and writes the
raw output bit patterns to ``rtl_outputs.npy`` for the harness to compare with the model.

Inputs change on the falling edge and outputs are sampled on the falling edge, half a cycle away from the
rising edge where registers update, so no sampling race is possible on any simulator.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge
from tqdm import tqdm


@cocotb.test()
async def stream(dut):
    job = Path(os.environ["COSIM_JOB"])
    meta = json.loads((job / "meta.json").read_text())
    vectors = np.load(job / "inputs.npy").tolist()
    latency = meta["latency"]
    ins = [getattr(dut, name) for name in meta["inputs"]]
    outs = [getattr(dut, name) for name in meta["outputs"]]

    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.i_valid.value = 0
    for port in ins:
        port.value = 0
    for _ in range(2):
        await FallingEdge(dut.clk)
    dut.rst.value = 0

    results = []
    o_valid = dut.o_valid
    total = len(vectors)
    bar = tqdm(total=total, desc=f"{dut._name} RTL", unit="vec", mininterval=1.0,
               disable=os.environ.get("COSIM_PROGRESS", "0") == "0")
    for cycle in range(total + latency):
        if cycle % 4096 == 0 and cycle < total:
            bar.update(min(4096, total - cycle))
        if cycle < total:
            dut.i_valid.value = 1
            for port, value in zip(ins, vectors[cycle]):
                port.value = value
        else:
            dut.i_valid.value = 0
        await FallingEdge(dut.clk)          # one rising edge since these inputs were applied
        valid = int(o_valid.value)
        expect_valid = latency - 1 <= cycle < total + latency - 1
        assert valid == expect_valid, (f"o_valid={valid} at cycle {cycle}, expected {int(expect_valid)} "
                                       f"(latency {latency})")
        if valid:
            results.append([int(port.value) for port in outs])
    bar.close()
    np.save(meta["result"], np.array(results, dtype=np.uint64).reshape(-1, len(outs)))
