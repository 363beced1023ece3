"""cocotb testbench of the board's UART command link: ``job.json`` gives the bytes, the clock period, the clocks a bit
and the board's state on the link's ``state`` input. cocotbext-uart's ``UartSource`` drives ``rx`` and its
``UartSink`` reads ``tx``; each payload byte (``data_valid``) and each good frame (``done``) is recorded as it
happens, a frame's payload being the bytes since its start, and each FRAME_START's place (``col``, ``row`` at its
``done``). Writes ``parsed.json``: the commands, the places, the replies, the error state at the end."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge, Timer
from cocotbext.uart import UartSink, UartSource

from host.protocol import Cmd


@cocotb.test()
async def link(dut):
    job = Path(os.environ["COSIM_JOB"])
    meta = json.loads((job / "job.json").read_text())
    data = bytes.fromhex(meta["data"])
    baud = 1e9 / (meta["clock_ns"] * meta["divisor"])
    dut.rx.value = 1
    dut.state.value = meta["board_state"]
    dut.rst.value = 1
    cocotb.start_soon(Clock(dut.clk, meta["clock_ns"], unit="ns").start())
    source, sink = UartSource(dut.rx, baud=baud, bits=8), UartSink(dut.tx, baud=baud, bits=8)
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    payload, commands, places = [], [], []

    async def bytes_():
        while True:
            await RisingEdge(dut.data_valid)
            await ReadOnly()
            if int(dut.index.value) == 0:
                payload.clear()
            assert int(dut.index.value) == len(payload), "payload bytes out of order"
            payload.append(int(dut.data.value))

    async def frames():
        while True:
            await RisingEdge(dut.done)
            await ReadOnly()
            n = int(dut.length.value)
            commands.append([int(dut.cmd.value), bytes(payload[:n] if n else []).hex()])
            if int(dut.cmd.value) == Cmd.FRAME_START:
                places.append([int(dut.col.value), int(dut.row.value)])
            payload.clear()

    cocotb.start_soon(bytes_())
    cocotb.start_soon(frames())
    await source.write(data)
    await source.wait()
    await Timer(meta["clock_ns"] * meta["divisor"] * 30, unit="ns")       # the last reply's ten bits and more
    replies = sink.read_nowait()
    (job / "parsed.json").write_text(json.dumps({"commands": commands, "places": places,
                                                 "replies": bytes(replies).hex(), "error": int(dut.error.value),
                                                 "code": int(dut.code.value)}))
