"""The board's uploads into the engine's texel memories (``docs/protocol.md``: TEXTURE and CUBE frames; paper,
section 4: the bump map, the texture and the reflectance cubes are tables the renderer loads).

A TEXTURE or CUBE payload is ``memory, first word (4 bytes LE), words (ceil(word_bits / 8) bytes LE each)``; the
map is ``host.protocol.MEMORIES[cmd][memory]`` and its words are
:attr:`~fxmodel.units.sampler.SamplerParams.upload_words` (the map's memories one after the other, so the sampler
finds a word's memory by comparing its index with their bounds: ``rtl.sampler.Sampler._writes``).

:class:`UploadWriter` takes the command parser's payload bytes (``sync``, the pixel clock), assembles each word,
and hands it to the engine's clock through a holding register and a toggle (two-register synchroniser), where it
is one clock of ``en`` on the texel memories' write bus (:class:`rtl.sampler.TexelWrites`). The holding register
changes at most once a UART byte (ten bit times, 250 pixel clocks at 1 MBd), long after the engine has written
the word it held (three engine clocks), so no handshake back is needed. Words are written as they arrive, before
the frame's CRC is checked (``board/command.py``). A memory byte naming no map, or a word beyond its map's words,
is not written and sets ``bad`` (sticky, a LED): an index is never narrowed into another word's address.
"""

from __future__ import annotations

from amaranth import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from fxmodel.pipeline.pixel import TEXEL_MAPS
from host.protocol import MEMORIES

from .cdc import toggle_sync

__all__ = ["UploadWriter"]

#: Payload bytes before the first word: the memory id and the first word's index.
HEADER = 5
#: The two upload commands (TEXTURE, CUBE).
MEMORY_CMDS = tuple(MEMORIES)


class UploadWriter(wiring.Component):
    """Payload bytes of TEXTURE and CUBE frames (``cmd``, ``index``, ``data``, ``data_valid``: the command parser's
    outputs, ``sync``) -> the write bus ``writes`` (an :class:`rtl.sampler.TexelWrites` of the engine's pipeline,
    whose maps it serves, driven in ``domain``); ``bad`` (sticky, ``sync``): a word not written (module docstring)."""

    def __init__(self, writes, domain: str = "engine"):
        self.maps = writes.maps
        self.writes, self.domain = writes, domain
        super().__init__({"cmd": In(8), "index": In(16), "data": In(8), "data_valid": In(1), "bad": Out(1)})

    def elaborate(self, platform):
        m = Module()
        w = self.writes
        nbytes = [(s.word_bits + 7) // 8 for s in self.maps]
        sel, ok, emit = Signal.like(w.sel), Signal(), Signal()
        addr = Signal(32)                                   # the word's index as sent, never narrowed
        word = Signal(8 * max(nbytes))
        k = Signal(range(max(nbytes)))                     # the byte of the word
        last = Signal()                                    # this byte ends the word (its map's byte count)
        m.d.comb += last.eq(sum((sel == s) & (k == n - 1) for s, n in enumerate(nbytes)) != 0)
        in_range = Signal()
        m.d.comb += in_range.eq(sum((sel == s) & (addr < len(mp.upload_words)) for s, mp in enumerate(self.maps))
                                != 0)
        hold_sel, hold_addr, hold_data, req = Signal.like(w.sel), Signal.like(w.addr), Signal.like(w.data), Signal()
        upload = (self.cmd == MEMORY_CMDS[0]) | (self.cmd == MEMORY_CMDS[1])
        m.d.sync += emit.eq(0)
        with m.If(self.data_valid & upload):
            with m.If(self.index == 0):                    # the memory id: the map, or none
                m.d.sync += [ok.eq(0), k.eq(0)]
                hits = [((self.cmd == cmd) & (self.data == mem), TEXEL_MAPS.index(name))
                        for cmd, names in MEMORIES.items() for mem, name in enumerate(names)]
                for hit, s in hits:
                    with m.If(hit):
                        m.d.sync += [sel.eq(s), ok.eq(1)]
                with m.If(~Cat(*(hit for hit, _ in hits)).any()):
                    m.d.sync += self.bad.eq(1)
            with m.Elif(self.index < HEADER):              # the first word's index, little-endian
                with m.Switch(self.index):
                    for b in range(1, HEADER):
                        with m.Case(b):
                            m.d.sync += addr[8 * (b - 1):8 * b].eq(self.data)
            with m.Else():
                with m.Switch(k):
                    for b in range(max(nbytes)):
                        with m.Case(b):
                            m.d.sync += word[8 * b:8 * b + 8].eq(self.data)
                m.d.sync += k.eq(k + 1)
                with m.If(last):
                    m.d.sync += [k.eq(0), emit.eq(1)]
        with m.If(emit):                                   # the word complete: hand it over, or refuse it
            with m.If(ok & in_range):                  # in range: the index fits the bus's address exactly
                m.d.sync += [hold_sel.eq(sel), hold_addr.eq(addr[:len(hold_addr)]),
                             hold_data.eq(word[:len(hold_data)]), req.eq(~req)]
            with m.Else():
                m.d.sync += self.bad.eq(1)
            m.d.sync += addr.eq(addr + 1)
        seen = toggle_sync(m, "upload", req, self.domain)
        m.d.comb += [w.en.eq(seen), w.sel.eq(hold_sel), w.addr.eq(hold_addr), w.data.eq(hold_data)]
        return m

