"""The command parser's CRC logic (``board/command.py``) against :func:`host.protocol.crc16` in Amaranth's
simulator, and its tile argument (the parser as a whole: ``cosim/test_board_uart.py``)."""

from __future__ import annotations

import random

import pytest
from amaranth import Module, Signal
from amaranth.sim import Simulator

from board.command import crc16_byte
from host.protocol import crc16


def test_crc_byte_step_matches_the_protocol():
    crc, byte, out = Signal(16), Signal(8), Signal(16)
    m = Module()
    m.d.comb += out.eq(crc16_byte(crc, byte))
    rng = random.Random(5)
    cases = [(rng.randrange(1 << 16), rng.randrange(256)) for _ in range(500)] + [(0xFFFF, 0), (0, 0xFF)]
    got = []

    async def bench(ctx):
        for c, b in cases:
            ctx.set(crc, c)
            ctx.set(byte, b)
            got.append(ctx.get(out))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert got == [crc16(bytes([b]), c) for c, b in cases]


def test_the_tile_a_frame_start_must_name_is_checked():
    from board.command import check_tile
    assert check_tile((128, 64)) == (128, 64) and check_tile(None) is None
    for bad in ((0, 128), (128, 1 << 16), (128,), (128.0, 128), [128, 128]):
        with pytest.raises(ValueError, match="tile="):
            check_tile(bad)
