"""LiteDRAM's standalone core in an Amaranth design (``board/litedram.py`` generates it): the core as an ``Instance``
with its AXI4 user port, and the SDRAM's init sequence, which with no CPU in the core is ours to run through its
Wishbone control port (``docs/board.md``).

The sequence (:data:`INIT`) is LiteDRAM's for SDR (``litedram.init.get_sdr_phy_init_sequence``, CL 2, burst 1:
``tests/board/test_sdram_core.py`` checks it against LiteDRAM's own when installed): software control of the DFI
with CKE high, then precharge all, load mode register with DLL reset, precharge all, two auto refreshes, load mode
register; then the DFI back to the controller and ``init_done`` set (which opens the AXI port). Each step's wait is
LiteDRAM's delay in clocks (20 000 after CKE: 200 us at 100 MHz, the chip's power-up wait), and at least
:data:`MIN_GAP` clocks after each command (more than the auto refresh's tRFC, 7 clocks at 100 MHz).
"""

from __future__ import annotations

from amaranth import Array, Cat, Const, Instance, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from rtl.rop import axi_signature

from .litedram import ADDR_BITS, DATA_BITS, ID_BITS, TEXTURE_DATA_BITS, TEXTURE_PORT

__all__ = ["CSR", "DFII", "CMD", "INIT", "MIN_GAP", "writes", "SdramInit", "LiteDram"]

#: The control port's registers (byte addresses, the generated ``csr.csv``; the Wishbone address is a word's).
CSR = {"init_done": 0x000, "dfii_control": 0x800, "pi0_command": 0x804, "pi0_command_issue": 0x808,
       "pi0_address": 0x80C, "pi0_baddress": 0x810}
#: DFII control bits and command bits (LiteDRAM's ``sdram_phy.h``).
DFII = {"SEL": 1, "CKE": 2, "ODT": 4, "RESET_N": 8}
CMD = {"CS": 1, "WE": 2, "CAS": 4, "RAS": 8}
#: CAS latency and burst length of the generated core (GENSDRPHY at 100 MHz: ``SDRAM_PHY_CL 2``, one phase).
CL, BL = 2, 1
_MR = (BL.bit_length() - 1) + (CL << 4)
_PRECHARGE_ALL = CMD["RAS"] | CMD["WE"] | CMD["CS"]
_MODE_REGISTER = CMD["RAS"] | CMD["CAS"] | CMD["WE"] | CMD["CS"]
_AUTO_REFRESH = CMD["RAS"] | CMD["CAS"] | CMD["CS"]
#: ``(name, address, bank, command, delay)`` as LiteDRAM lists them; command ``None``: the CKE step (a control
#: write, no command).
INIT = (("Bring CKE high", 0x0000, 0, None, 20000),
        ("Precharge All", 0x0400, 0, _PRECHARGE_ALL, 0),
        (f"Load Mode Register / Reset DLL, CL={CL}, BL={BL}", _MR + (1 << 8), 0, _MODE_REGISTER, 200),
        ("Precharge All", 0x0400, 0, _PRECHARGE_ALL, 0),
        ("Auto Refresh", 0x0, 0, _AUTO_REFRESH, 4),
        ("Auto Refresh", 0x0, 0, _AUTO_REFRESH, 4),
        (f"Load Mode Register / CL={CL}, BL={BL}", _MR, 0, _MODE_REGISTER, 200))
#: Clocks at least between a command and the next write.
MIN_GAP = 16


def writes(init=INIT, cke_delay: int | None = None) -> list[tuple[int, int, int]]:
    """The Wishbone writes of the sequence: ``(byte address, data, clocks to wait after it)``; ``cke_delay``
    replaces the power-up wait (a shorter one for a simulation whose DRAM model does not check it)."""
    out = []
    for _, addr, bank, cmd, delay in init:
        out += [(CSR["pi0_address"], addr, 0), (CSR["pi0_baddress"], bank, 0)]
        if cmd is None:
            wait = delay if cke_delay is None else cke_delay
            out.append((CSR["dfii_control"], DFII["CKE"] | DFII["ODT"] | DFII["RESET_N"], wait))
        else:
            out += [(CSR["pi0_command"], cmd, 0), (CSR["pi0_command_issue"], 1, max(delay, MIN_GAP))]
    return out + [(CSR["dfii_control"], DFII["SEL"], 0), (CSR["init_done"], 1, 0)]


class SdramInit(wiring.Component):
    """A Wishbone (classic, 32-bit, word addresses) manager that makes :func:`writes` in turn, each held until
    ``ack``, then waits its clocks; ``done`` after the last."""

    def __init__(self, cke_delay: int | None = None):
        self.steps = writes(cke_delay=cke_delay)
        super().__init__({"cyc": Out(1), "stb": Out(1), "we": Out(1), "adr": Out(30), "dat_w": Out(32),
                          "sel": Out(4), "ack": In(1), "done": Out(1)})

    def elaborate(self, platform):
        m = Module()
        n = len(self.steps)
        adr = Array(Const(a >> 2, 30) for a, _, _ in self.steps)
        dat = Array(Const(d, 32) for _, d, _ in self.steps)
        wait = Array(Const(w, range(max(w for _, _, w in self.steps) + 1)) for _, _, w in self.steps)
        k = Signal(range(n + 1))
        count = Signal(range(max(w for _, _, w in self.steps) + 1))
        m.d.comb += [self.adr.eq(adr[k]), self.dat_w.eq(dat[k]), self.we.eq(1), self.sel.eq(0xF),
                     self.done.eq(k == n)]
        with m.FSM():
            with m.State("write"):
                m.d.comb += [self.cyc.eq(k != n), self.stb.eq(k != n)]
                with m.If((k != n) & self.ack):
                    m.d.sync += count.eq(wait[k])
                    m.next = "wait"
            with m.State("wait"):
                m.d.sync += count.eq(count - 1)
                with m.If(count == 0):
                    m.d.sync += k.eq(k + 1)
                    m.next = "write"
        return m


def _axi_ports(a, name: str) -> dict:
    """The ``Instance`` ports of the core's AXI4 user port ``name`` on the port ``a`` (:func:`rtl.rop.axi_signature`);
    the core's ``AxSIZE`` has 4 bits, AXI's 3 (the top bit tied to 0)."""
    ports = {f"i_user_port_{name}_{n}": getattr(a, n) for n in
             ("awid", "awaddr", "awlen", "awburst", "awvalid", "wdata", "wstrb", "wlast", "wvalid", "bready",
              "arid", "araddr", "arlen", "arburst", "arvalid", "rready")}
    ports |= {f"o_user_port_{name}_{n}": getattr(a, n) for n in
              ("awready", "wready", "bid", "bresp", "bvalid", "arready", "rid", "rdata", "rresp", "rlast", "rvalid")}
    return ports | {f"i_user_port_{name}_awsize": Cat(a.awsize, Const(0, 1)),
                    f"i_user_port_{name}_arsize": Cat(a.arsize, Const(0, 1))}


class LiteDram(wiring.Component):
    """LiteDRAM's core (module ``litedram_core``, ``board/litedram.py``) in domain ``dram`` (its ``clk``; its user
    clock is the same clock) with :class:`SdramInit` on its control port. ``axi``: the AXI4 user port (a
    subordinate: connect a manager to it); with ``textures`` also ``tex``, the core's second user port
    (:data:`~board.litedram.TEXTURE_PORT`, :data:`~board.litedram.TEXTURE_DATA_BITS` data bits: the texel caches'
    misses), arbitrated with the first by the core's crossbar; ``ready`` high once the init sequence is done and
    the core reports no init error. ``pins``: for the board's core, the platform's ``sdram`` resource requested
    with ``dir="-"`` (its clock pin is driven by the caller); ``None`` for the simulation core (its DRAM model
    inside)."""

    def __init__(self, pins=None, cke_delay: int | None = None, textures: bool = False):
        self.pins, self.textures = pins, textures
        self._init = SdramInit(cke_delay)
        members = {"axi": In(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "ready": Out(1), "init_error": Out(1)}
        if textures:
            members["tex"] = In(axi_signature(ADDR_BITS, TEXTURE_DATA_BITS, ID_BITS))
        super().__init__(members)

    def elaborate(self, platform):
        from amaranth import ClockSignal, DomainRenamer, ResetSignal
        m = Module()
        init = self._init
        m.submodules.init = DomainRenamer("dram")(init)
        done, error = Signal(), Signal()
        ports = _axi_ports(self.axi, "axi_0") | (_axi_ports(self.tex, TEXTURE_PORT) if self.textures else {})
        ports |= {"i_wb_ctrl_adr": init.adr, "i_wb_ctrl_dat_w": init.dat_w, "i_wb_ctrl_sel": init.sel,
                  "i_wb_ctrl_cyc": init.cyc, "i_wb_ctrl_stb": init.stb, "i_wb_ctrl_we": init.we,
                  "i_wb_ctrl_cti": Const(0, 3), "i_wb_ctrl_bte": Const(0, 2), "o_wb_ctrl_ack": init.ack,
                  "o_init_done": done, "o_init_error": error, "i_clk": ClockSignal("dram")}
        if self.pins is None:
            ports["i_sim_trace"] = Const(0)
        else:
            p = self.pins
            ports |= {"i_rst": ResetSignal("dram"), "o_sdram_a": p.a.io, "o_sdram_ba": p.ba.io,
                      "o_sdram_cs_n": p.cs.io, "o_sdram_we_n": p.we.io, "o_sdram_ras_n": p.ras.io,
                      "o_sdram_cas_n": p.cas.io, "o_sdram_cke": p.clk_en.io, "o_sdram_dm": p.dqm.io,
                      "io_sdram_dq": p.dq.io}
        m.submodules.core = Instance("litedram_core", **ports)
        m.d.comb += [self.ready.eq(done & ~error & init.done), self.init_error.eq(error)]
        return m
