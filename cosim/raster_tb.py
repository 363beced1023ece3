"""cocotb testbench of the scan converter (``rtl/raster.py``): triangle records in through a valid/ready stream,
fragments out through another, with optional random gaps on the input and random backpressure on the output.

The harness (:func:`cosim.raster.run`) writes ``job.json`` into the folder named by ``COSIM_JOB``: the packed
record payloads (hex integers, first field in the low bits), the probability that the source offers a record in
a cycle and the probability that the sink is ready. Each cycle the testbench sets ``i.valid``/``i.payload`` and
``o.ready`` on the falling edge, waits for the read-only phase, and counts a transfer on each side where
``valid & ready`` (taken at the next rising edge); a record once offered stays offered until taken (the stream
rule). It writes the packed fragments, the number of cycles with ``busy`` high and ``busy_span``, the cycles from
the first to the last with ``busy`` high (equal to the busy cycles when no clock between rows is lost)
(``meta["out"]``, ``fragments.json``). ``drain`` in ``job.json`` is how long the testbench waits with everything idle
after the last record was taken: the scan converter's fill latency, plus the pixel pipeline's latency for the engine
from the triangle (``rtl/engine.py``'s ``Engine``).
A hand-written driver rather than cocotbext-axi's AXI-Stream source/sink: the payloads are single words of
hundreds to thousands of bits with no byte lanes, which the AXI-Stream classes would split into ``tdata`` bytes.
"""

from __future__ import annotations

import json
import os
import random
from pathlib import Path

import cocotb
from cocotb.triggers import FallingEdge, ReadOnly
from tqdm import tqdm

from cosim.tb_common import Source, job_meta, start


@cocotb.test()
async def raster(dut):
    _, meta = job_meta()
    records = [int(r, 16) for r in meta["records"]]
    p_valid, p_ready = meta["p_valid"], meta["p_ready"]
    rng = random.Random(meta["seed"])
    start(dut)
    for _ in range(2):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    o_valid = dut.o__valid
    src = Source.on(dut, records, rng, p_valid)
    frags, busy, idle, cycles = [], 0, 0, 0
    first_busy = last_busy = None
    bar = tqdm(total=meta.get("expected", 0), desc=f"{dut._name} RTL", unit="px", mininterval=1.0,
               disable=os.environ.get("COSIM_PROGRESS", "0") == "0")
    while idle < meta.get("drain", 4):
        await FallingEdge(dut.clk)
        cycles += 1
        assert cycles < meta["max_cycles"], \
            f"no progress after {cycles} cycles ({len(frags)} fragments, {src.k} records)"
        src.drive()
        dut.o__ready.value = int(rng.random() < p_ready)
        await ReadOnly()
        src.taken()
        if int(o_valid.value) and int(dut.o__ready.value):
            frags.append(format(int(dut.o__payload.value), "x"))
        if int(dut.busy.value):
            busy += 1
            first_busy = cycles if first_busy is None else first_busy
            last_busy = cycles
        if cycles % 4096 == 0:
            bar.update(len(frags) - bar.n)
        idle = idle + 1 if (src.done and not int(dut.busy.value) and not int(o_valid.value)) else 0
    bar.close()
    span = 0 if first_busy is None else last_busy - first_busy + 1
    Path(meta["out"]).write_text(json.dumps({"fragments": frags, "busy_cycles": busy, "cycles": cycles,
                                                      "busy_span": span}))
