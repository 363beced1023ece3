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

With the maps in SDRAM (``sdram``: the engine's bump map and color texture behind its texel caches,
``board/texture_port.py``) a TEXTURE frame's words are four bytes each, word ``k`` of a map going to byte
``address + 4 k`` of the SDRAM, where ``address`` is the start of the map's span of the texture layout
(:meth:`fxmodel.units.texcache.Layout.span`, at ``board.texture_port.TEXTURE_BASE``): such a word leaves through
holding registers of its own (``sd_addr``, ``sd_data``) and a toggle (``sd_req``) for the SDRAM's writes
(:class:`board.texture_port.TextureWrites`), not on the texel memories' bus; the board invalidates the caches with
the same toggle. The reflectance cubes stay on chip (CUBE frames as before).

A TEXTURE frame's memory byte carries the form of its words (``host.protocol.SDRAM_FORM`` for the 4-byte words of
a map in SDRAM): a frame of the other form than its map's writes nothing, and is not ``bad`` either: the command
parser refuses it with ``Err.MAPS`` once its CRC matched (``board/command.py``), which the host names.
"""

from __future__ import annotations

from amaranth import C, Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from fxmodel.pipeline.pixel import TEXEL_MAPS
from host.protocol import MEMORIES, SDRAM_FORM, Cmd

from .cdc import toggle_sync

__all__ = ["UploadWriter"]

#: Payload bytes before the first word: the memory id and the first word's index.
HEADER = 5
#: The two upload commands (TEXTURE, CUBE).
MEMORY_CMDS = tuple(MEMORIES)


class UploadWriter(wiring.Component):
    """Payload bytes of TEXTURE and CUBE frames (``cmd``, ``index``, ``data``, ``data_valid``: the command parser's
    outputs, ``sync``) -> the write bus ``writes`` (an :class:`rtl.sampler.TexelWrites` of the engine's pipeline,
    whose maps it serves, driven in ``domain``); ``bad`` (sticky, ``sync``): a word not written (module docstring).
    ``sdram`` (optional): per map in SDRAM its span ``(byte address, bytes)`` in the SDRAM; its words leave on
    ``sd_req``, ``sd_addr``, ``sd_data`` (``sync`` registers)."""

    def __init__(self, writes, domain: str = "engine", sdram: dict | None = None):
        from .litedram import ADDR_BITS, SDRAM_BYTES, TEXTURE_DATA_BITS
        self.maps = writes.maps
        self.writes, self.domain, self.sdram = writes, domain, dict(sdram or {})
        for name, (addr, size) in self.sdram.items():
            if name not in TEXEL_MAPS or addr % 4 or size % 4 or not 0 <= addr <= SDRAM_BYTES - size:
                raise ValueError(f"sdram[{name!r}] = {(addr, size)}: a texel map's span of 4-byte words in the "
                                 f"{SDRAM_BYTES}-byte SDRAM")
        members = {"cmd": In(8), "index": In(16), "data": In(8), "data_valid": In(1), "bad": Out(1)}
        if self.sdram:
            members |= {"sd_req": Out(1), "sd_addr": Out(ADDR_BITS), "sd_data": Out(TEXTURE_DATA_BITS)}
        super().__init__(members)

    def elaborate(self, platform):
        m = Module()
        w = self.writes
        ext = [name in self.sdram for name in TEXEL_MAPS]     # the maps in SDRAM, by ``sel``
        nbytes = [4 if e else (s.word_bits + 7) // 8 for s, e in zip(self.maps, ext)]
        count = [self.sdram[n][1] // 4 if e else len(mp.upload_words) for n, mp, e in zip(TEXEL_MAPS, self.maps, ext)]
        sel, ok, emit = Signal.like(w.sel), Signal(), Signal()
        other_form = Signal()                               # a TEXTURE frame of the other form: nothing, not bad
        addr = Signal(32)                                   # the word's index as sent, never narrowed
        word = Signal(8 * max(nbytes))
        k = Signal(range(max(nbytes)))                     # the byte of the word
        last = Signal()                                    # this byte ends the word (its map's byte count)
        m.d.comb += last.eq(sum((sel == s) & (k == n - 1) for s, n in enumerate(nbytes)) != 0)
        in_range = Signal()
        m.d.comb += in_range.eq(sum((sel == s) & (addr < n) for s, n in enumerate(count)) != 0)
        external = Signal()                                 # the word's map is in SDRAM
        m.d.comb += external.eq((sum((sel == s) for s, e in enumerate(ext) if e) != 0) if any(ext) else 0)
        hold_sel, hold_addr, hold_data, req = Signal.like(w.sel), Signal.like(w.addr), Signal.like(w.data), Signal()
        upload = (self.cmd == MEMORY_CMDS[0]) | (self.cmd == MEMORY_CMDS[1])
        # the memory byte: the id with the form of its map's words (SDRAM_FORM for a map in SDRAM)
        forms = [(cmd, mem, name, SDRAM_FORM if name in self.sdram else 0)
                 for cmd, names in MEMORIES.items() for mem, name in enumerate(names)]
        hits = [((self.cmd == cmd) & (self.data == form | mem), TEXEL_MAPS.index(name))
                for cmd, mem, name, form in forms]
        # a TEXTURE frame of the other form: not written, refused by the parser (Err.MAPS), not ``bad``
        other = [(self.cmd == cmd) & (self.data == (form ^ SDRAM_FORM) | mem)
                 for cmd, mem, name, form in forms if cmd == Cmd.TEXTURE]
        m.d.sync += emit.eq(0)
        with m.If(self.data_valid & upload):
            with m.If(self.index == 0):                    # the memory id: the map, or none
                m.d.sync += [ok.eq(0), k.eq(0), other_form.eq(Cat(*other).any())]
                for hit, s in hits:
                    with m.If(hit):
                        m.d.sync += [sel.eq(s), ok.eq(1)]
                with m.If(~Cat(*(hit for hit, _ in hits), *other).any()):
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
            with m.If(ok & in_range & external):       # in range: base + 4 index lies in the map's span
                if self.sdram:
                    self._to_sdram(m, sel, addr, word)
            with m.Elif(ok & in_range):                # in range: the index fits the bus's address exactly
                m.d.sync += [hold_sel.eq(sel), hold_addr.eq(addr[:len(hold_addr)]),
                             hold_data.eq(word[:len(hold_data)]), req.eq(~req)]
            with m.Elif(~other_form):
                m.d.sync += self.bad.eq(1)
            m.d.sync += addr.eq(addr + 1)
        seen = toggle_sync(m, "upload", req, self.domain)
        m.d.comb += [w.en.eq(seen), w.sel.eq(hold_sel), w.addr.eq(hold_addr), w.data.eq(hold_data)]
        return m

    def _to_sdram(self, m, sel, index, word) -> None:
        """A word of a map in SDRAM into the holding registers, at its map's span start + 4 ``index``
        (``index`` below the map's words, so the sum is inside the span and the SDRAM: its narrowing to the
        address bits is exact), and the toggle."""
        start = Signal.like(self.sd_addr)
        for s, name in enumerate(TEXEL_MAPS):
            if name in self.sdram:
                with m.If(sel == s):
                    m.d.comb += start.eq(self.sdram[name][0])
        m.d.sync += [self.sd_addr.eq((start + Cat(C(0, 2), index))[:len(start)]),
                     self.sd_data.eq(word[:len(self.sd_data)]), self.sd_req.eq(~self.sd_req)]
