"""cocotb testbench of the DVI output (``board/dvi.py``'s ``DisplayTest``): the pixel clock ``clk`` (50 ns) and the
serializer's five-times clock ``tmds_clk`` (10 ns, its edges 1 ns after the pixel clock's, as a PLL's outputs
with a small skew), both reset together. ``job.json`` says what to record for how many pixel clocks: the four
serial lanes at every ``tmds_clk`` edge (the double-data-rate output: two bit times a clock), or the three
encoders' 30-bit word at every falling edge of the pixel clock (the serializer's clock left still).
The samples go to ``samples.npy`` for ``cosim/board_dvi.py``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, Timer


@cocotb.test()
async def display(dut):
    job = Path(os.environ["COSIM_JOB"])
    meta = json.loads((job / "job.json").read_text())
    dut.rst.value = 1
    dut.tmds_rst.value = 1
    cocotb.start_soon(Clock(dut.clk, 50, unit="ns").start())
    if meta["serial"]:                   # the words need no serializer clock (and Icarus runs 5 times fewer edges)
        await Timer(1, unit="ns")
        cocotb.start_soon(Clock(dut.tmds_clk, 10, unit="ns").start())
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    dut.tmds_rst.value = 0
    rows = []
    if meta["serial"]:
        serial = dut.serial
        for _ in range(10 * meta["clocks"]):
            await dut.tmds_clk.value_change
            await ReadOnly()
            rows.append([(int(serial.value) >> k) & 1 for k in range(4)])
        np.save(meta["out"], np.array(rows, dtype=np.uint8))
    else:
        words = dut.words
        for _ in range(meta["clocks"]):
            await FallingEdge(dut.clk)
            rows.append(int(words.value))
        np.save(meta["out"], np.array(rows, dtype=np.uint64))
