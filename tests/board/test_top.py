"""The ULX3S board top (``board/top.py``) prepares for the open flow (RTLIL, constraints, build script: the PLL, the
HDMI pairs' double-data-rate buffers, the UART pins), and the report reads nextpnr's figures. The bitstream itself
is ``make bitstream BOARD=ulx3s`` (about a minute)."""

from __future__ import annotations

import json
import re
from fractions import Fraction

import pytest

pytest.importorskip("amaranth_boards")

import board.top as top  # noqa: E402
from board.top import Top, _platform, critical_paths, report  # noqa: E402
from tests.board.test_ulx3s import plan_text  # noqa: E402

TIM = """Info: Max frequency for clock '$glbnet$tmds': 150.00 MHz (PASS at 125.00 MHz)
Info: Max frequency for clock               '$glbnet$clk': 20.00 MHz (FAIL at 25.00 MHz)
Info: Device utilisation:
Info: \t          TRELLIS_IO:    10/   365     2%
Info: \t             EHXPLLL:     1/     4    25%
Info: Max frequency for clock '$glbnet$tmds': 160.00 MHz (PASS at 125.00 MHz)
Info: Max frequency for clock               '$glbnet$clk': 30.00 MHz (PASS at 25.00 MHz)
"""


def test_report_takes_the_last_figures_of_every_clock():
    rec = report(TIM)
    assert rec["clocks"] == {"$glbnet$tmds": {"fmax_mhz": 160.0, "target_mhz": 125.0, "met": True},
                             "$glbnet$clk": {"fmax_mhz": 30.0, "target_mhz": 25.0, "met": True}}
    assert rec["resources"] == {"TRELLIS_IO": [10, 365], "EHXPLLL": [1, 4]} and rec["all_met"]
    assert not report(TIM.rsplit("Info: Max", 1)[0])["all_met"]        # the clk FAIL is the last one seen then


PATHS = """Info: Critical path report for clock '$glbnet$engine_clk' (posedge -> posedge):
Info:   clk-to-q  5.83  5.83 Source a.DOB0
Info:    routing  1.51  7.34 Net n1 (46,46) -> (54,40)
Info:                          Sink b.B
Info:      logic  0.24  7.58 Source b.F
Info:                          Sink c.DI
Info: 6.07 ns logic, 1.51 ns routing

Info: Critical path report for cross-domain path 'posedge $glbnet$engine_clk' -> 'posedge $glbnet$clk':
Info:   clk-to-q  0.52  0.52 Source d.Q
Info:                          Sink e.M
Info: 0.52 ns logic, 0.81 ns routing
"""


def test_critical_paths_name_each_clocks_first_source_and_last_sink():
    assert critical_paths(PATHS) == {"$glbnet$engine_clk": {"from": "a.DOB0", "to": "c.DI", "logic_ns": 6.07,
                                                            "routing_ns": 1.51, "total_ns": 7.58}}
    assert report(TIM + PATHS)["critical_paths"] == critical_paths(PATHS)


def test_top_prepares_with_pll_and_ddr_outputs():
    plan = _platform().prepare(Top(), name="top")
    rtlil = plan_text(plan, "top.il")
    assert "EHXPLLL" in rtlil and "ODDRX1F" in rtlil
    lpf = plan_text(plan, "top.lpf")
    assert all(pin in lpf for pin in ("A16", "A14", "A12", "A17", "M1", "L4", "G2"))   # HDMI data, clock, UART, clk25


@pytest.mark.slow
def test_the_top_with_the_engine_prepares_with_the_pll_third_output():
    from board.frame import board_engine
    plan = _platform().prepare(Top(board_engine(size=32)[0]), name="top")
    rtlil = plan.files["top.il"]
    assert "EHXPLLL" in rtlil and "CLKOS2" in rtlil and "ODDRX1F" in rtlil
    assert "MULT18X18D" in rtlil and "REG_OUTPUT_CLK" in rtlil      # products in their blocks' registers (rtl.dsp)


def test_the_top_with_the_frame_in_sdram_prepares_with_litedrams_core_on_its_own_clock():
    # not slow (about ten seconds, the core generated once): the only check that the SDRAM top elaborates; it did
    # not, once the engine's clock lost its reset, as the core took that clock's reset
    from board.frame import board_engine
    from board.litedram import core_dir
    div = 6
    plan = _platform().prepare(Top(board_engine(size=16)[0], frame="sdram", engine_div=div), name="top")
    rtlil = plan_text(plan, "top.il")
    lpf = plan_text(plan, "top.lpf")
    assert "litedram_core" in rtlil and "inout  wire   [15:0] sdram_dq" in plan.files["litedram_core.v"]
    assert all(pin in lpf for pin in ("F19", "J16", "M20", "U19"))          # SDRAM clock, dq, a, dqm
    assert "rst_dram" in rtlil                                               # the core's reset until the PLL locks
    # the core on a clock of its own (the PLL's fourth output), generated for it: its refresh timer counts the
    # chip's 7.8 us in that clock's cycles
    hz = top.DRAM_HZ
    assert "CLKOS3" in rtlil and hz == top._VCO_HZ // top.PLL["CLKOS3_DIV"]
    assert f'"sys_clk_freq":  {hz},' in (core_dir(False, hz) / "sdram.yml").read_text()
    counts = {int(n) for n in re.findall(r"litedramcore_timer_count1 <= \d+'d(\d+);", plan.files["litedram_core.v"])}
    trefi = Fraction(64, 1000 * 8192)                                      # 64 ms for the chip's 8192 rows
    assert len(counts) == 1 and Fraction(0.95) * trefi < Fraction(counts.pop(), hz) <= trefi


def _stub_flow(monkeypatch, tmp_path, tim: str) -> dict:
    """``board.top.build`` without the tools: the platform's build writes ``tim`` as nextpnr's log and keeps its
    keyword arguments in the returned dict; ``Top`` builds nothing."""
    seen = {}

    class Platform:
        def __init__(self, floorplan=None):
            seen["floorplan"] = floorplan

        def build(self, design, **kwargs):
            seen.update(kwargs)
            (tmp_path / "top.tim").write_text(tim)

    monkeypatch.setattr(top, "_platform", Platform)
    monkeypatch.setattr(top, "Top", lambda engine, frame, engine_div: None)       # nothing to elaborate
    return seen


@pytest.mark.parametrize("seed, flag", [(None, None), (7, "--seed 7")])
def test_build_hands_router_and_seed_to_nextpnr(tmp_path, monkeypatch, seed, flag):
    seen = _stub_flow(monkeypatch, tmp_path, TIM)
    rec = top.build(tmp_path, router="router1", seed=seed)
    opts = seen["nextpnr_opts"]
    assert "--router router1" in opts and "--timing-allow-fail" in opts
    assert ("--seed" in opts) == (flag is not None) and (flag is None or flag in opts)
    assert rec.get("seed") == seed and rec["router"] == "router1"


@pytest.mark.parametrize("fmax, met", [(100.5, True), (99.71, False)])
def test_the_engine_margin_aims_nextpnr_higher_and_the_report_judges_against_the_pll(tmp_path, monkeypatch, fmax,
                                                                                      met):
    """``engine_margin``: an LPF constraint on ``engine_clk`` above the PLL's frequency (nextpnr's target); the
    record's ``target_mhz`` and ``met`` are the PLL's, nextpnr's target kept as ``constraint_mhz``."""
    engine_tim = TIM + f"Info: Max frequency for clock '$glbnet$engine_clk': {fmax} MHz (FAIL at 101.00 MHz)\n"
    seen = _stub_flow(monkeypatch, tmp_path, engine_tim)
    rec = top.build(tmp_path, engine=object(), engine_div=5, engine_margin=0.01)
    assert seen["add_preferences"] == 'FREQUENCY NET "engine_clk" 101000000 HZ;'
    clock = rec["clocks"]["$glbnet$engine_clk"]
    assert clock == {"fmax_mhz": fmax, "target_mhz": 100.0, "constraint_mhz": 101.0, "met": met}
    assert rec["all_met"] == met and rec["engine_margin"] == 0.01
    seen.clear()
    top.build(tmp_path, engine=object(), engine_div=5, engine_margin=0)       # no margin: nextpnr's own target
    assert "add_preferences" not in seen and "nextpnr_opts" in seen


def _net(driver: str, arrivals: dict) -> dict:
    """A net of nextpnr's per-net timing report: its endpoints' ``{"cell.pin": arrival ns}`` in the engine clock."""
    ev = "posedge $glbnet$engine_clk"
    return {"driver": driver, "event": ev, "net": driver + "_n", "port": "Q",
            "endpoints": [{"cell": c.rsplit(".", 1)[0], "port": c.rsplit(".", 1)[1], "delay": [t - 1, t], "event": ev}
                          for c, t in arrivals.items()]}


def test_an_engine_divider_is_the_pll_output_and_the_misses_are_counted_per_unit_and_kind(tmp_path, monkeypatch):
    seen = {}
    timing = {"detailed_net_timings": [
        _net("x", {"system.engine.raster.span_L_kept_copy_TRELLIS_FF_Q.DI": 12.5,      # misses 12 ns (div 6)
                   "system.engine.raster.span_s3_pp_U_0_mult.B3": 12.1,                # a multiplier block's operand
                   "system.engine.pipeline.core.unit.diffuse.s5_b1_TRELLIS_FF_Q_4.DI": 11.9}),   # meets
        _net("y", {"system.engine.raster.rows.storage.0.105$DPRAM_COMB3.WRE": 13.0,
                   "system.engine.raster.take_0_TRELLIS_FF_Q.CE": 12.01})]}

    class Platform:
        def __init__(self, floorplan=None):
            pass

        def build(self, design, **kwargs):
            seen.update(kwargs, design=design)
            (tmp_path / "top.tim").write_text(TIM)
            opts = kwargs["nextpnr_opts"].split()
            assert "--detailed-timing-report" in opts
            assert opts[opts.index("--report") + 1] == "timing.json"    # from the build folder: YoWASP's own /tmp
            (tmp_path / "timing.json").write_text(__import__("json").dumps(timing))

    monkeypatch.setattr(top, "_platform", Platform)
    rec = top.build(tmp_path, engine_div=6, misses=True)
    assert seen["design"].engine_div == 6 and rec["engine_div"] == 6
    m = rec["misses"]
    assert m["period_ns"] == 12.0 and m["endpoints"] == 4
    assert m["by_unit"] == {"raster": 3, "raster.rows": 1}
    assert m["by_kind"] == {"clock enable": 1, "LUT RAM": 1, "multiplier block": 1, "register": 1}
    assert [w["ns"] for w in m["worst"]] == [13.0, 12.5, 12.1, 12.01]
    assert m["worst"][1] == {"ns": 12.5, "unit": "raster", "register": "span_L_kept_copy", "pin": "DI"}
    with pytest.raises(ValueError, match="engine_div=3"):
        Top(engine_div=3)
    rtlil = plan_text(_platform().prepare(Top(engine_div=6), name="top"), "top.il")
    assert "parameter \\CLKOS2_DIV 6\n" in rtlil and 'FREQUENCY_PIN_CLKOS2 "83.3333"' in rtlil   # 500 / 6 MHz


def test_each_frame_builds_with_its_own_engine_clock(tmp_path, monkeypatch):
    """Without ``engine_div`` the top takes its frame's: ``PLL["CLKOS2_DIV"]`` (the 100 MHz target) on chip,
    ``SDRAM_ENGINE_DIV`` in SDRAM; ``build`` records the divider it used."""
    assert Top(frame="chip").engine_div == top.PLL["CLKOS2_DIV"] == 5
    assert top.engine_hz("chip") == 100_000_000
    assert top.engine_div_of("sdram") == top.SDRAM_ENGINE_DIV
    assert top.engine_hz("sdram") == 500_000_000 // top.SDRAM_ENGINE_DIV
    rtlil = plan_text(_platform().prepare(Top(), name="top"), "top.il")
    assert "parameter \\CLKOS2_DIV 5\n" in rtlil and 'FREQUENCY_PIN_CLKOS2 "100.0000"' in rtlil
    _stub_flow(monkeypatch, tmp_path, TIM)
    assert top.build(tmp_path, frame="sdram")["engine_div"] == top.SDRAM_ENGINE_DIV
    assert top.build(tmp_path, frame="chip")["engine_div"] == 5


def test_the_maps_in_sdram_build_with_their_own_clock_and_router(tmp_path, monkeypatch):
    """``--textures`` without ``--engine-div``, ``--router`` or ``--tmg-ripup``: the engine at
    ``TEXTURES_ENGINE_DIV``, routed by ``TEXTURES_ROUTER`` without router2's rip-up, placed by its own floorplan
    (``TEXTURES_FLOORPLAN``: the committed ``FLOORPLAN`` is the engine's with its maps on chip); the options given
    still win, and the board's other builds keep router2 with rip-up and their floorplan."""
    import argparse
    ap = argparse.ArgumentParser()
    top.add_arguments(ap)
    seen = []
    monkeypatch.setattr(top, "build", lambda out, engine, router, frame, seed, div, misses, tmg, *rest:
                        seen.append((router, div, tmg, rest[2])) or {"all_met": True})
    monkeypatch.setattr(top, "write_text_atomic", lambda *a: None)
    for argv in (["--textures"], ["--textures", "--router", "router2", "--tmg-ripup", "--engine-div", "6"], []):
        assert top.run(ap.parse_args(["--out", str(tmp_path), "--size", "16", *argv])) == 0
    assert seen[0][:3] == (top.TEXTURES_ROUTER, None, False) == ("router1", None, False)
    assert seen[1][:3] == ("router2", 6, True) and seen[2][:3] == ("router2", None, True)
    assert seen[0][3].name == top.TEXTURES_FLOORPLAN.name and seen[2][3].name == top.FLOORPLAN.name
    assert top.engine_div_of("sdram", textures=True) == top.TEXTURES_ENGINE_DIV
    assert top.engine_hz("sdram", True) == 500_000_000 // top.TEXTURES_ENGINE_DIV


def test_misses_need_the_per_net_report():
    from board.timing import timing_misses
    with pytest.raises(ValueError, match="detailed-timing-report"):
        timing_misses({"critical_paths": []}, "engine_clk", 10.0)
    with pytest.raises(ValueError, match="no endpoint of clock 'engine_clk'"):
        timing_misses({"detailed_net_timings": [{"event": "posedge clk", "endpoints": []}]}, "engine_clk", 10.0)


def test_a_floorplan_is_handed_to_the_platform_and_a_routed_build_saves_one(tmp_path, monkeypatch):
    """``floorplan``: the platform's build constrains the netlist with it (``board.floorplan``) and the record
    names it; ``save_floorplan``: nextpnr writes the routed netlist and the engine's block sites in it are kept."""
    from board.floorplan import read_floorplan, write_floorplan
    mult = "system.engine.pipeline.core.unit.persp.s2_pp_0_mult"
    plan = tmp_path / "plan.json"
    write_floorplan(plan, {mult: "X96/Y10/MULT18_0"}, {"seed": 3})
    seen = _stub_flow(monkeypatch, tmp_path, TIM)
    rec = top.build(tmp_path, floorplan=plan)
    assert seen["floorplan"] == plan and rec["floorplan"] == plan.as_posix()
    assert "--write" not in seen["nextpnr_opts"]
    routed = {"modules": {"top": {"cells": {mult: {"type": "MULT18X18D",
                                                   "attributes": {"NEXTPNR_BEL": "X96/Y34/MULT18_0"}}}}}}
    (tmp_path / "top_routed.json").write_text(__import__("json").dumps(routed))
    rec = top.build(tmp_path, seed=3, save_floorplan=tmp_path / "saved.json")
    assert seen["floorplan"] is None and "--write top_routed.json" in seen["nextpnr_opts"]
    assert read_floorplan(tmp_path / "saved.json") == {mult: "X96/Y34/MULT18_0"}
    assert rec["floorplan_saved"] == (tmp_path / "saved.json").as_posix()
    _stub_flow(monkeypatch, tmp_path, TIM + "Warning: Max frequency for clock '$glbnet$engine_clk': 99.1 MHz "
                                             "(FAIL at 100.00 MHz)\n")
    rec = top.build(tmp_path, engine=object(), engine_div=5, save_floorplan=tmp_path / "missed.json")
    assert not rec["all_met"] and "floorplan_not_saved" in rec and not (tmp_path / "missed.json").exists()


def test_the_command_refuses_a_bad_floorplan_before_building(tmp_path, monkeypatch, capsys):
    import argparse
    ap = argparse.ArgumentParser()
    top.add_arguments(ap)
    from board.floorplan import CELL_TYPES, ENGINE_PREFIX
    (tmp_path / "bad.json").write_text(json.dumps({"types": list(CELL_TYPES), "prefix": ENGINE_PREFIX,
                                                   "cells": {"system.engine.x_mult": "nowhere"}}))
    monkeypatch.setattr(top, "Top", lambda *a, **k: pytest.fail("elaborated with a bad floorplan"))
    monkeypatch.setattr(top, "_platform", lambda *a, **k: pytest.fail("built with a bad floorplan"))
    args = ap.parse_args(["--out", str(tmp_path / "out"), "--floorplan", str(tmp_path / "bad.json"), "--size", "16"])
    assert top.run(args) == 2
    err = capsys.readouterr().err
    assert "--floorplan" in err and "bad.json" in err and "'nowhere'" in err
    with pytest.raises(SystemExit) as e:            # a floorplan named and refused in one command
        ap.parse_args(["--floorplan", str(tmp_path / "bad.json"), "--no-floorplan"])
    assert e.value.code == 2 and "not allowed with" in capsys.readouterr().err


def test_a_flow_that_stops_is_an_error_naming_its_folder(tmp_path, monkeypatch, capsys):
    """A tool of the flow (or the floorplan step, refusing a stale floorplan) that exits with an error stops the
    command with exit status 2 and a message naming the build folder and the logs, not a traceback."""
    import argparse
    import subprocess
    ap = argparse.ArgumentParser()
    top.add_arguments(ap)

    def stops(*a, **k):
        raise subprocess.CalledProcessError(2, ["sh", "build_top.sh"])
    monkeypatch.setattr(top, "build", stops)
    args = ap.parse_args(["--out", str(tmp_path / "out"), "--no-engine"])
    assert top.run(args) == 2
    err = capsys.readouterr().err
    assert str(tmp_path / "out") in err and "exited 2" in err and "top.tim" in err
