"""``rtl/dsp.py``: products in ECP5 multiplier blocks with the blocks' own registers.

- The behavioural ``MULT18X18D`` (:data:`rtl.dsp.MODEL`) against exact integer products, every signedness.
- Units written both ways (``platform=None``, and :data:`rtl.dsp.ECP5`, the block standing in as the model) run
  side by side in Icarus on the same random inputs, resets included: every output equal on every clock. The
  comparison is shown to catch a difference (an operand register taken from the wrong clock).
- What :func:`rtl.dsp.registered_product` takes and leaves, and that a register with an enable is never
  taken for a delay.
"""

from __future__ import annotations

import random
import re

import pytest
from amaranth.hdl import Fragment, Module, Signal, signed

from cosim.miter import miter, needs_icarus, run_icarus
from fxmodel.core.unit import preset
from rtl import dsp
from rtl.unit import Pipe
from rtl.verilog import verilog_text

#: Clocks each unit runs both ways.
CYCLES = 400

def _both_ways(params, cycles=CYCLES):
    ref = verilog_text(params, "fab", flat=True)
    alt = verilog_text(params, "blk", flat=True, platform=dsp.ECP5)
    return ref, alt, miter(ref, alt, cycles)


#: Units whose products go into blocks: operands that are registers of the same pipe (inputs absorbed; squares of
#: one register), a block's product as the next block's operand and the ROM's word (the perspective unit); unit
#: inputs (the output register only: shading, the reflect unit's first products, read through a proven
#: narrowing); the scan converter's span start (stream ports); partial products.
UNITS = [("persp", "default"), ("shade", "default"), ("raster", "small"), ("recip", "rcp24"), ("reflect", "default")]


@needs_icarus
@pytest.mark.parametrize("unit, name", UNITS)
def test_ecp5_form_equals_the_fabric_form_on_every_clock(tmp_path, unit, name):
    ref, alt, tb = _both_ways(preset(unit, name))
    assert "MULT18X18D" in alt and "MULT18X18D" not in ref
    out = run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "model.v": dsp.MODEL, "tb.v": tb})
    done = re.search(r"DONE 400 (\d+) UNKNOWN (\d+) OF (\d+)", out)
    assert done and int(done[1]) == 0, out
    assert int(done[2]) < int(done[3]) // 10, out        # unknown only while the pipeline first fills


def _board_unit(name):
    from board.frame import BOARD_PRESET, board_engine
    engine = board_engine("tin-plane", BOARD_PRESET, 128)[0]
    return engine.raster if name == "raster" else getattr(engine.pipeline, name)


@needs_icarus
@pytest.mark.parametrize("unit", ["persp", "raster"])
def test_narrow_products_in_logic_equal_the_fabric_form_on_every_clock(tmp_path, unit):
    """The board's perspective unit (17 + 2-bit pieces of its quotients) and scan converter (the span start's
    1- and 2-bit top pieces): those products are one adder each (:func:`rtl.dsp.logic_product`), not blocks."""
    params = _board_unit(unit)
    ref, alt, tb = _both_ways(params)
    narrow = [p for p in built_products(params) if min(w for w, _ in p) <= dsp.LOGIC_PRODUCT_BITS]
    assert narrow, "no narrow product: the test would not exercise the logic form"
    out = run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "model.v": dsp.MODEL, "tb.v": tb})
    done = re.search(r"DONE 400 (\d+) UNKNOWN (\d+) OF (\d+)", out)
    assert done and int(done[1]) == 0, out


def built_products(params):
    from tests.fxmodel.core.test_cost import built
    return list(built(params)[0])


@needs_icarus
def test_the_comparison_catches_an_operand_from_the_wrong_clock(tmp_path):
    ref, alt, tb = _both_ways(preset("persp"))
    late = dsp.MODEL.replace('(REG_INPUTA_CLK == "CLK0") ? ar : a', '(REG_INPUTA_CLK == "CLK0") ? a : a')
    assert late != dsp.MODEL
    out = run_icarus(tmp_path, {"ref.v": ref, "alt.v": alt, "model.v": late, "tb.v": tb})
    done = re.search(r"DONE 400 (\d+) UNKNOWN", out)
    assert done and int(done[1]) > 0, out


def _model_tb(cases) -> str:
    lines = ["module tb;", "  reg clk = 0; reg [17:0] a, b; reg sa, sb; wire [35:0] p;",
             "  MULT18X18D #(.REG_OUTPUT_CLK(\"CLK0\"), .GSR(\"DISABLED\")) m (" +
             ", ".join([f".A{i}(a[{i}])" for i in range(18)] + [f".B{i}(b[{i}])" for i in range(18)] +
                       [f".P{i}(p[{i}])" for i in range(36)]) +
             ", .SIGNEDA(sa), .SIGNEDB(sb), .SOURCEA(1'b0), .SOURCEB(1'b0), .CLK0(clk), .CE0(1'b1), .RST0(1'b0));",
             "  initial begin"]
    for a, b, sa, sb in cases:
        lines.append(f"    a = 18'd{a % (1 << 18)}; b = 18'd{b % (1 << 18)}; sa = {sa}; sb = {sb};"
                     " #1 clk = 1; #1 clk = 0; $display(\"P %0d\", p);")
    lines += ["    $finish;", "  end", "endmodule"]
    return "\n".join(lines)


@needs_icarus
def test_block_model_is_the_exact_product(tmp_path):
    rng = random.Random(7)
    cases = []
    for sa in (0, 1):
        for sb in (0, 1):
            ends = [(-(1 << 17) if s else 0, (1 << 17) - 1 if s else (1 << 18) - 1) for s in (sa, sb)]
            cases += [(ends[0][i], ends[1][j], sa, sb) for i in (0, 1) for j in (0, 1)]
            cases += [(rng.randint(*ends[0]), rng.randint(*ends[1]), sa, sb) for _ in range(40)]
    out = run_icarus(tmp_path, {"model.v": dsp.MODEL, "tb.v": _model_tb(cases)})
    got = [int(x) for x in re.findall(r"^P (\d+)$", out, re.M)]
    assert got == [(a * b) % (1 << 36) for a, b, _, _ in cases]


def test_registered_product_takes_products_of_at_most_18_bits():
    a, b, wide = Signal(signed(18)), Signal(18), Signal(19)
    p = dsp.registered_product(a * b)
    assert p is not None and (p.lo, p.hi) == (0, len(a * b))
    assert dsp.registered_product((a * b)[3:20]).lo == 3
    assert dsp.registered_product(a * wide) is None
    assert dsp.registered_product(a * 5) is None
    assert dsp.registered_product(a + b) is None
    assert dsp.registered_product((a * b)[:30].as_signed()).hi == 30          # a proven narrowing's reading
    shifted = dsp.registered_product((a * b) >> 5)                            # a truncating narrowing's
    assert (shifted.lo, shifted.hi) == (5, 5 + len(a * b))
    assert (dsp.registered_product(((a * b) >> 5)[2:33]).lo, dsp.registered_product(((a * b) >> 5)[2:33]).hi) \
        == (7, 38)                                                            # above the product: its extension


def test_only_ecp5_platforms_use_blocks_and_enabled_registers_are_not_delays():
    assert dsp.uses_blocks(dsp.ECP5) and not dsp.uses_blocks(None)
    m = Module()
    pipe = Pipe(m, platform=dsp.ECP5)
    x, en = Signal(8), Signal()
    free = pipe.delay(x, 1)
    with m.If(en):
        held = pipe.delay(x, 1, "held")
    assert pipe.sources.source(free) is x
    assert pipe.sources.source(held) is None
    assert not Pipe(m).blocks
    Fragment.get(m, None)
