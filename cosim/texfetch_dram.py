"""Co-simulation of the texture fetch (``rtl/texfetch.py``: the bump map's and the color texture's lookups of
paper, sections 3.2 and 4, through one decoupled texel cache each) with its maps in the SDRAM behind LiteDRAM, as
the board reads them (``docs/board.md``, "Textures in SDRAM"): the fetch in the engine's clock, its read channels
across :class:`~board.texture_port.TextureReadCrossing` into the texture port of LiteDRAM's simulation core (its
controller and SDRAM model inside, ``bumpmap litedram``) in the SDRAM's clock. The testbench writes the maps'
texel words at their layout addresses through the core's first port (the frame's) and reads them back, then runs
the fragments as :func:`cosim.texfetch.run_fetch` does (``dram_ns``) and compares texels and bursts with the
model in the same way.
"""

from __future__ import annotations

from amaranth import ClockDomain, ClockSignal, Module, ResetSignal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from board.litedram import ADDR_BITS, DATA_BITS, ID_BITS
from rtl.rop import axi_signature

__all__ = ["FetchDramBench", "WATCHED"]

#: The fetch's port signals the bench copies out (port ``mem``) for the testbench to count bursts and beats.
WATCHED = ("arvalid", "arready", "araddr", "arlen", "rvalid", "rready")


class FetchDramBench(wiring.Component):
    """Simulation top: ``inner`` (a :class:`~rtl.texfetch.TexFetch` built with
    ``addr_bits=board.texture_port.TEXTURE_ADDR_BITS``) in domain ``sync`` (``clk``, ``rst``), its ``mem`` port
    through the board's :class:`~board.texture_port.TexturePort` (its read crossing: the maps at ``TEXTURE_BASE``;
    no upload's word offered) into
    :class:`~board.sdram_core.LiteDram`'s texture port (simulation core, domain ``dram``: ``dram_clk``,
    ``dram_rst``; the init sequence with a ``cke_delay``-clock power-up wait). Ports: the fetch's ``i``, ``o``,
    ``busy``; ``mem`` (a copy of the fetch's port's :data:`WATCHED` signals); ``load`` (the core's first AXI4 port,
    for the testbench's writes and reads); ``ready`` (the core's port open); ``mem_error`` (the crossing's
    ``error``)."""

    def __init__(self, inner, cke_delay: int = 200):
        from board.sdram_core import LiteDram
        from board.texture_port import TexturePort
        self.inner = inner
        self._cross = TexturePort(len(inner.mem.arid), i_domain="sync", o_domain="dram")
        self._dram = LiteDram(None, cke_delay, textures=True)
        sig = inner.signature.members
        watch = wiring.Signature({n: Out(len(getattr(inner.mem, n))) for n in WATCHED})
        super().__init__({"i": sig["i"], "o": sig["o"], "busy": Out(1), "mem": Out(watch),
                          "load": In(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "dram_clk": In(1),
                          "dram_rst": In(1), "ready": Out(1), "mem_error": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.domains.dram = ClockDomain("dram")
        m.d.comb += [ClockSignal("dram").eq(self.dram_clk), ResetSignal("dram").eq(self.dram_rst)]
        m.submodules.fetch = f = self.inner
        m.submodules.cross = x = self._cross
        m.submodules.dram = d = self._dram
        wiring.connect(m, wiring.flipped(self.i), f.i)
        wiring.connect(m, f.o, wiring.flipped(self.o))
        wiring.connect(m, f.mem, x.up)
        wiring.connect(m, x.down, d.tex)
        wiring.connect(m, wiring.flipped(self.load), d.axi)
        m.d.comb += [self.busy.eq(f.busy), self.ready.eq(d.ready), self.mem_error.eq(x.error | x.read_error)]
        m.d.comb += [getattr(self.mem, n).eq(getattr(f.mem, n)) for n in WATCHED]
        return m
