"""What the cocotb testbenches share (no tests here: cocotb collects the tests of the module it is given, so the
helpers live apart from them): the job's inputs, the clock and reset, random pause generators, and an AXI4 memory
model (cocotbext-axi's ``AxiRam``) with the design's memory image and optional random wait states."""

from __future__ import annotations

import json
import logging
import os
import random
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly

__all__ = ["job_meta", "pauses", "start", "axi_ram", "Source", "read_manager_walk"]


def job_meta(variable: str = "COSIM_JOB") -> tuple[Path, dict]:
    """The job folder named by the environment ``variable`` and its ``job.json``."""
    job = Path(os.environ[variable])
    return job, json.loads((job / "job.json").read_text())


def pauses(rng: random.Random, p: float):
    """An endless pause pattern: each cycle paused with probability ``p``."""
    while True:
        yield rng.random() < p


def start(dut, *, output_ready: bool = True) -> None:
    """Start the 10 ns clock and hold the design in reset with its input stream idle (and, with ``output_ready``,
    its output stream not ready)."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.i__valid.value = 0
    dut.i__payload.value = 0
    if output_ready:
        dut.o__ready.value = 0


def axi_ram(dut, base: int, image: bytes, seed: int, p_pause: float, write: bool = True):
    """An ``AxiRam`` on the design's ``mem_`` AXI4 port holding ``image`` at ``base`` (size a power of two, at least
    4 KB), its channels (the read channels only unless ``write``) paused at random with probability ``p_pause``."""
    from cocotbext.axi import AxiBus, AxiRam
    size = 1 << max(12, (base + len(image) - 1).bit_length())
    ram = AxiRam(AxiBus.from_prefix(dut, "mem_"), dut.clk, dut.rst, size=size)
    ram.write(base, image)
    for side in (ram.write_if, ram.read_if):
        side.log.setLevel(logging.WARNING)               # one line per transfer otherwise
    channels = ((ram.write_if.aw_channel, ram.write_if.w_channel, ram.write_if.b_channel) if write else ()) \
        + (ram.read_if.ar_channel, ram.read_if.r_channel)
    for k, ch in enumerate(channels):
        if p_pause > 0:
            ch.set_pause_generator(pauses(random.Random(seed * 7 + k), p_pause))
    return ram


class Source:
    """A stream source in a bench's clock loop: ``words`` offered on ``valid``/``payload`` with probability
    ``p_valid`` a cycle (one draw of ``rng`` a cycle while a word waits to be offered), a word once offered held until
    ``ready`` takes it (the stream rule). Call :meth:`drive` after the falling edge and :meth:`taken` in the
    read-only phase that follows."""

    def __init__(self, words, rng: random.Random, p_valid: float, valid, payload, ready):
        self.words, self.rng, self.p_valid = list(words), rng, p_valid
        self.valid, self.payload, self.ready = valid, payload, ready
        self.k, self.offered = 0, False

    def drive(self) -> None:
        if self.k < len(self.words) and not self.offered:
            self.offered = self.rng.random() < self.p_valid
            if self.offered:
                self.payload.value = self.words[self.k]
        self.valid.value = int(self.offered)

    def taken(self) -> bool:
        """Whether the word offered this cycle was taken (then the next one waits)."""
        if self.offered and int(self.ready.value):
            self.k, self.offered = self.k + 1, False
            return True
        return False

    @property
    def done(self) -> bool:
        """Every word taken."""
        return self.k == len(self.words) and not self.offered

    @classmethod
    def on(cls, dut, words, rng: random.Random, p_valid: float, port: str = "i") -> Source:
        """The source on the design's input stream ``port`` (``<port>__valid``, ``__payload``, ``__ready``)."""
        return cls(words, rng, p_valid, *(getattr(dut, f"{port}__{s}") for s in ("valid", "payload", "ready")))


async def read_manager_walk(dut, meta: dict, latency: int | None = None, *, memory=None) -> None:
    """Drive a stream-in/stream-out AXI4 read manager (a texel cache, the texture fetch) from ``job.json``: requests
    offered with probability ``p_valid``, the sink ready with ``p_ready``, an ``AxiRam`` with wait states behind
    ``mem``; record every ``AR`` (address, length), the ``R`` beats, the outputs and the cycles into the result
    file (``outputs`` in the job: how many outputs to wait for, default one per request; the engine's are its
    fragments). ``latency``: the value of the bench's ``lat`` input (the fetch bench's delay queue), if it has
    one. ``memory``: instead of the ``AxiRam``, a coroutine function awaited (with ``dut``) while the design is
    held in reset, which puts the image in the bench's own memory; ``mem`` is then the bench's copy of the
    manager's port, watched only, and the bench's ``mem_error`` at the end is recorded too."""
    reqs = [int(r, 16) for r in meta["requests"]]
    rng = random.Random(meta["seed"])
    start(dut)
    if latency is not None:
        dut.lat.value = latency
    if memory is None:
        _ram = axi_ram(dut, meta["base"], bytes.fromhex(meta["image"]), meta["seed"], meta["p_pause"],
                       write=False)                        # the memory model lives as long as the test
    else:
        await memory(dut)
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0
    src = Source.on(dut, reqs, rng, meta["p_valid"])
    cycles, beats, ar, outputs = 0, 0, [], []
    wanted = meta.get("outputs", len(reqs))                 # the engine: fragments out of triangle records in
    while len(outputs) < wanted:
        await FallingEdge(dut.clk)
        cycles += 1
        assert cycles < meta["max_cycles"], f"no progress after {cycles} cycles ({len(outputs)} of {wanted})"
        src.drive()
        dut.o__ready.value = int(rng.random() < meta["p_ready"])
        await ReadOnly()
        src.taken()
        if int(dut.o__valid.value) and int(dut.o__ready.value):
            outputs.append(format(int(dut.o__payload.value), "x"))
        if int(dut.mem__arvalid.value) and int(dut.mem__arready.value):
            ar.append([int(dut.mem__araddr.value), int(dut.mem__arlen.value)])
        beats += int(dut.mem__rvalid.value) & int(dut.mem__rready.value)
    result = {"outputs": outputs, "ar": ar, "beats": beats, "cycles": cycles}
    if memory is not None:                                  # the bench's memory: its error flag
        result["mem_error"] = int(dut.mem_error.value)
    Path(meta["out"]).write_text(json.dumps(result))
