"""The board simulated with its frame in SDRAM (``bumpmap board-sim --frame sdram``, ``docs/board.md``): the
engine system of ``board/frame.py`` with ``frame="sdram"`` and LiteDRAM's simulation core (its DRAM model inside)
on the system's AXI4 port, in the SDRAM's own clock (paper, section 4 and Fig. 5: the frame buffer the display reads).
"""

from __future__ import annotations

from amaranth import ClockDomain, ClockSignal, Module, ResetSignal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from .frame import EngineSystem
from .sdram_core import LiteDram

__all__ = ["SdramBoardSim"]


class SdramBoardSim(wiring.Component):
    """``BoardSim`` (``board/frame.py``) with the frame in SDRAM: the engine system's AXI port on LiteDRAM's
    simulation core (:class:`~board.sdram_core.LiteDram`, its DRAM model inside) in the SDRAM's clock
    (``dram_clk``/``dram_rst``, a third clock as on the board), the core's
    init sequence with a ``cke_delay``-clock power-up wait. Extra ports: ``underrun``, ``mem_error``,
    ``dram_ready``, ``upload_bad``. With ``params.textures`` the maps are in the SDRAM too, on the core's texture port
    (``docs/board.md``, "Textures in SDRAM"), uploaded by TEXTURE frames."""

    def __init__(self, params, timing, divisor: int, cke_delay: int = 200):
        self._sys = EngineSystem(params, timing, divisor, frame="sdram")
        self._dram = LiteDram(None, cke_delay, textures=self._sys.textures)
        super().__init__({"engine_clk": In(1), "engine_rst": In(1), "dram_clk": In(1), "dram_rst": In(1),
                          "rx": In(1, init=1), "tx": Out(1, init=1),
                          "words": Out(30), "error": Out(1), "good": Out(1), "overrun": Out(1), "front": Out(1),
                          "status": Out(self._sys.status.shape()), "underrun": Out(1), "mem_error": Out(1),
                          "dram_ready": Out(1), "upload_bad": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.domains.engine = ClockDomain("engine")
        m.domains.dram = ClockDomain("dram")
        m.d.comb += [ClockSignal("engine").eq(self.engine_clk), ResetSignal("engine").eq(self.engine_rst),
                     ClockSignal("dram").eq(self.dram_clk), ResetSignal("dram").eq(self.dram_rst)]
        m.submodules.system = s = self._sys
        m.submodules.dram = d = self._dram
        wiring.connect(m, s.mem, d.axi)
        if self._sys.textures:
            wiring.connect(m, s.tex, d.tex)
        m.d.comb += [s.rx.eq(self.rx), self.tx.eq(s.tx), self.words.eq(s.words), self.error.eq(s.error),
                     self.good.eq(s.good), self.overrun.eq(s.overrun), self.front.eq(s.front),
                     self.status.eq(s.status), self.underrun.eq(s.underrun), self.mem_error.eq(s.mem_error),
                     self.upload_bad.eq(s.upload_bad),
                     self.dram_ready.eq(d.ready)]
        return m
