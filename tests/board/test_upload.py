"""The board's uploads (``board/upload.py``) in Amaranth's simulator: the host's TEXTURE and CUBE frames
(``host.protocol.upload_frames``, several frames a map) through the command parser (``board/command.py``) become one
write a word on the texel memories' bus, each at its map and index with its word; a memory id naming no map and a
word beyond its map's words are not written and set ``bad``."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from amaranth import Module
from amaranth.sim import Simulator

from board.command import CommandParser
from board.upload import UploadWriter
from fxmodel.core.unit import preset
from fxmodel.pipeline.pixel import TEXEL_MAPS
from host.protocol import MEMORIES, Cmd, frame, upload_frames
from rtl.sampler import TexelWrites

#: Four maps of different word widths (2, 3 and 5 bytes) and memory layouts.
MAPS = SimpleNamespace(bump_map=preset("sampler", "default"), texture=preset("sampler", "nearest"),
                       diffuse=preset("sampler", "cube"), specular=preset("sampler", "border"))


def _writes(data: bytes):
    """Feed ``data`` (a byte every third clock) through the parser into the writer; the bus's writes
    ``(sel, addr, data)`` and the final ``bad``."""
    writes = TexelWrites(MAPS)
    m = Module()
    m.submodules.parser = p = CommandParser(record_len=290)
    m.submodules.up = up = UploadWriter(writes, domain="sync")
    m.d.comb += [up.cmd.eq(p.cmd), up.index.eq(p.index), up.data.eq(p.data), up.data_valid.eq(p.data_valid)]
    got = []

    async def bench(ctx):
        for b in data:
            ctx.set(p.byte, b)
            ctx.set(p.valid, 1)
            for _ in range(3):
                await ctx.tick()
                ctx.set(p.valid, 0)
                if ctx.get(writes.en):
                    got.append((ctx.get(writes.sel), ctx.get(writes.addr), ctx.get(writes.data)))
        for _ in range(8):
            await ctx.tick()
            if ctx.get(writes.en):
                got.append((ctx.get(writes.sel), ctx.get(writes.addr), ctx.get(writes.data)))
        got.append(ctx.get(up.bad))

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return got[:-1], got[-1]


def test_every_word_of_every_map_is_written_once_at_its_index():
    data, want = b"", []
    for cmd, names in MEMORIES.items():
        for mem, name in enumerate(names):
            s = getattr(MAPS, name)
            data += b"".join(upload_frames(cmd, mem, s.upload_words, s.word_bits, chunk=64))
            want += [(TEXEL_MAPS.index(name), a, w) for a, w in enumerate(s.upload_words)]
    got, bad = _writes(data)
    assert got == want and not bad


@pytest.mark.parametrize("case", ["memory", "beyond"])
def test_a_word_outside_every_map_is_refused(case):
    s = MAPS.texture
    wb = (s.word_bits + 7) // 8
    if case == "memory":                                     # memory id 2 of TEXTURE: no such map
        payload = bytes([2]) + (0).to_bytes(4, "little") + (5).to_bytes(wb, "little")
    else:                                                    # the map has 35 words; word 35 and 2**16 + 1
        payload = bytes([1]) + len(s.upload_words).to_bytes(4, "little") + (5).to_bytes(wb, "little")
    got, bad = _writes(frame(Cmd.TEXTURE, payload))
    assert got == [] and bad
    far = bytes([1]) + (1 << 16 | 1).to_bytes(4, "little") + (5).to_bytes(wb, "little")
    got, bad = _writes(frame(Cmd.TEXTURE, far))
    assert got == [] and bad                                 # not narrowed to word 1
