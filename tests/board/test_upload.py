"""The board's uploads (``board/upload.py``) in Amaranth's simulator: the host's TEXTURE and CUBE frames
(``host.protocol.upload_frames``, several frames a map) through the command parser (``board/command.py``) become one
write a word on the texel memories' bus, each at its map and index with its word; a memory id naming no map and a
word beyond its map's words are not written and set ``bad``; a TEXTURE frame of the other form than its map's
(in SDRAM or on chip) is not written either."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from amaranth import Module
from amaranth.sim import Simulator

from board.command import CommandParser
from board.upload import UploadWriter
from fxmodel.core.unit import preset
from fxmodel.pipeline.pixel import TEXEL_MAPS
from host.protocol import MEMORIES, SDRAM_FORM, Cmd, frame, upload_frames
from rtl.sampler import TexelWrites

#: Four maps of different word widths (2, 3 and 5 bytes) and memory layouts.
MAPS = SimpleNamespace(bump_map=preset("sampler", "default"), texture=preset("sampler", "nearest"),
                       diffuse=preset("sampler", "cube"), specular=preset("sampler", "border"))


def _writes(data: bytes, sdram=None):
    """Feed ``data`` (a byte every third clock) through the parser into the writer; the bus's writes
    ``(sel, addr, data)`` (and with ``sdram``, the maps in SDRAM, the SDRAM's words ``("sdram", addr, data)``
    at each change of ``sd_req``) and the final ``bad``."""
    writes = TexelWrites(MAPS)
    m = Module()
    m.submodules.parser = p = CommandParser(record_len=290)
    m.submodules.up = up = UploadWriter(writes, domain="sync", sdram=sdram)
    m.d.comb += [up.cmd.eq(p.cmd), up.index.eq(p.index), up.data.eq(p.data), up.data_valid.eq(p.data_valid)]
    got = []

    async def bench(ctx):
        last = 0

        def look():
            nonlocal last
            if ctx.get(writes.en):
                got.append((ctx.get(writes.sel), ctx.get(writes.addr), ctx.get(writes.data)))
            if sdram and ctx.get(up.sd_req) != last:
                last ^= 1
                got.append(("sdram", ctx.get(up.sd_addr), ctx.get(up.sd_data)))

        for b in data:
            ctx.set(p.byte, b)
            ctx.set(p.valid, 1)
            for _ in range(3):
                await ctx.tick()
                ctx.set(p.valid, 0)
                look()
        for _ in range(8):
            await ctx.tick()
            look()
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


def test_the_maps_in_sdram_go_to_their_spans_the_cubes_on_the_bus():
    """With the bump map and the texture in SDRAM, TEXTURE words (four bytes each) leave for the SDRAM at their
    map's span start + 4 k, never on the bus; CUBE words still go on the bus; a word beyond a map's span is
    refused."""
    from board.texture_port import TEXTURE_BASE
    spans = {"bump_map": (TEXTURE_BASE + 256, 4 * 40), "texture": (TEXTURE_BASE + 256 + 4 * 40, 4 * 24)}
    data, want = b"", []
    for mem, name in enumerate(MEMORIES[Cmd.TEXTURE]):
        words = [(k * 0x01010101 + 7 * mem) & 0xFFFFFFFF for k in range(spans[name][1] // 4)]
        data += b"".join(upload_frames(Cmd.TEXTURE, mem, words, 32, chunk=64, maps="sdram"))
        want += [("sdram", spans[name][0] + 4 * k, w) for k, w in enumerate(words)]
    for mem, name in enumerate(MEMORIES[Cmd.CUBE]):
        s = getattr(MAPS, name)
        data += b"".join(upload_frames(Cmd.CUBE, mem, s.upload_words, s.word_bits, chunk=64))
        want += [(TEXEL_MAPS.index(name), a, w) for a, w in enumerate(s.upload_words)]
    got, bad = _writes(data, spans)
    assert got == want and not bad
    beyond = frame(Cmd.TEXTURE, bytes([SDRAM_FORM | 1]) + (24).to_bytes(4, "little") + (5).to_bytes(4, "little"))
    got, bad = _writes(beyond, spans)
    assert got == [] and bad


def test_a_texture_frame_of_the_other_form_writes_nothing():
    """A TEXTURE frame whose memory byte names the other form than its map's (``SDRAM_FORM`` to a map on chip, or
    not to a map in SDRAM) writes no word anywhere, and is not ``bad``: the parser refuses it (``Err.MAPS``,
    ``tests/host/test_protocol.py``, ``cosim/test_board_uart.py``), which the host names and can undo."""
    from board.texture_port import TEXTURE_BASE
    spans = {"bump_map": (TEXTURE_BASE, 64), "texture": (TEXTURE_BASE + 64, 64)}
    chip = frame(Cmd.TEXTURE, bytes([1]) + bytes(4) + (5).to_bytes(3, "little"))
    in_sdram = frame(Cmd.TEXTURE, bytes([SDRAM_FORM | 1]) + bytes(4) + (5).to_bytes(4, "little"))
    assert _writes(chip, spans) == ([], 0)
    assert _writes(in_sdram) == ([], 0)
    assert _writes(chip)[0] and _writes(in_sdram, spans)[0]           # each form to its own maps is written


def test_a_span_outside_the_sdram_is_refused():
    from board.litedram import SDRAM_BYTES
    for bad in ({"bump_map": (SDRAM_BYTES - 4, 8)}, {"texture": (2, 8)}, {"diffusee": (0, 4)}):
        with pytest.raises(ValueError, match="span"):
            UploadWriter(TexelWrites(MAPS), sdram=bad)
