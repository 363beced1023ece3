"""cocotb testbench of the board's engine system (``board/frame.py``'s ``BoardSim``): the pixel clock ``clk`` and
the engine's ``engine_clk`` (periods from ``job.json``), both reset together; the host's bytes into ``rx`` through
cocotbext-uart's ``UartSource`` at the board's rate, the answers from ``tx`` through its ``UartSink``. Once the
display shows the drawn buffer (``front`` changes, at the start of a vertical blanking) the three TMDS words are
recorded every pixel clock for ``clocks`` clocks into ``words.npy``; then the STATUS frame (``job.json``'s
``status_frame``) is sent and its answer awaited, as ``bumpmap send`` asks the board after SWAP. ``result.json``
holds the answers, STATUS's apart, the flags, and the simulated times.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, First, SimTimeoutError, Timer, with_timeout
from cocotb.utils import get_sim_time
from cocotbext.uart import UartSink, UartSource


@cocotb.test()
async def system(dut):
    job = Path(os.environ["COSIM_JOB"])
    meta = json.loads((job / "job.json").read_text())
    pix_ns, eng_ns = meta["pixel_ns"], meta["engine_ns"]
    baud = 1e9 / (pix_ns * meta["divisor"])
    dut.rx.value = 1
    dut.rst.value = 1
    dut.engine_rst.value = 1
    cocotb.start_soon(Clock(dut.clk, pix_ns, unit="ns").start())
    cocotb.start_soon(Clock(dut.engine_clk, eng_ns, unit="ns").start())
    if "dram_ns" in meta:                        # the frame in SDRAM: the SDRAM's clock of its own
        dut.dram_rst.value = 1
        cocotb.start_soon(Clock(dut.dram_clk, meta["dram_ns"], unit="ns").start())
    source, sink = UartSource(dut.rx, baud=baud, bits=8), UartSink(dut.tx, baud=baud, bits=8)
    for side in (source, sink):                  # not a log line per byte
        side.log.setLevel(logging.WARNING)
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    dut.engine_rst.value = 0
    if "dram_ns" in meta:
        dut.dram_rst.value = 0
    await source.write(bytes.fromhex(meta["data"]))
    await source.wait()
    sent_ns = get_sim_time("ns")
    await First(dut.front.value_change, Timer(meta["timeout_ns"], unit="ns"))
    shown_ns = get_sim_time("ns")
    rows = np.zeros(meta["clocks"], dtype=np.uint32)
    if int(dut.front.value):                     # shown (else the harness reports the timeout)
        words = dut.words
        for k in range(meta["clocks"]):
            await FallingEdge(dut.clk)
            rows[k] = int(words.value)
        np.save(job / "words.npy", rows)
    replies = bytes(sink.read_nowait())
    await source.write(bytes.fromhex(meta["status_frame"]))
    try:                                         # the frame's bytes and the answer's ten bits, twice over
        answer = (await with_timeout(sink.read(1), 2 * 20 * 10 * 1e9 / baud, "ns")).hex()
    except SimTimeoutError:
        answer = None
    (job / "result.json").write_text(json.dumps({
        "replies": replies.hex(), "state_answer": answer, "error": int(dut.error.value),
        "overrun": int(dut.overrun.value),
        "status": int(dut.status.value), "front": int(dut.front.value), "sent_ns": sent_ns, "shown_ns": shown_ns,
        "end_ns": get_sim_time("ns"),
        **{k: int(getattr(dut, k).value) for k in ("underrun", "mem_error", "upload_bad", "dram_ready")
           if hasattr(dut, k)}}))
