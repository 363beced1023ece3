"""RTL construction from parameter objects: ports and latency come from the model's parameters."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset, preset_names, units
from rtl import build, write_verilog
from rtl.unit import Pipe, UnitComponent
from tools.main import main as bumpmap


@pytest.mark.parametrize("unit, name", [("recip", "default"), ("recip", "small"), ("divide", "default")])
def test_ports_follow_the_parameter_object(unit, name):
    params = preset(unit, name)
    comp = build(params)
    members = comp.signature.members
    for port in params.inputs + params.outputs:
        shape = members[port.name].shape
        assert (shape.width, shape.signed) == (port.fmt.width, port.fmt.signed), port.name
    assert {"i_valid", "o_valid"} <= set(members.keys())


@pytest.mark.parametrize("unit, name", [(u, n) for u in units() for n in preset_names(u)])
def test_every_preset_elaborates_with_the_documented_latency(unit, name):
    from amaranth.hdl import Fragment

    Fragment.get(build(preset(unit, name)), None)        # finish() raises if the depth is not params.latency


def test_verilog_is_written_with_the_module_name(tmp_path):
    path = write_verilog(preset("recip", "small"), tmp_path / "recip_small.v")
    text = path.read_text()
    assert "module recip_small(" in text and "mant" in text


def test_cli_writes_the_pipeline_of_a_fitted_preset_with_the_scene_tables(tmp_path, capsys):
    import re

    from host.render import pipeline_params

    assert bumpmap(["verilog", "--scene", "tin-plane", "--preset", "tin-plane-fit", "--out", str(tmp_path)]) == 0
    path = tmp_path / "pipeline_tin-plane-fit_tin-plane.v"
    assert f"wrote {path}" in capsys.readouterr().out
    text = path.read_text()
    assert "module pipeline_tin_plane_fit_tin_plane(" in text     # a plain identifier, no escaped name
    assert "i__ready" in text and "o__payload" in text            # the stream version (rtl/streams.py)
    # the bump map's four banks (each a rtl.bram.RegisteredMemory) hold the scene's (du, dv) words, as the model
    # packs and banks them
    params = pipeline_params("tin-plane", "tin-plane-fit").bump_map
    assert params.banked and params.texels.shape == (1, 40, 40, 2)
    for k, words in enumerate(params.bank_words):
        head = re.search(rf"module \\pipeline_tin_plane_fit_tin_plane\.[\w.]*\bbump_map\.texels{k} ", text)
        bank = text[head.start():]
        bank = bank[:bank.index("endmodule")]
        init = {int(i): int(v, 16) for i, v in re.findall(r"mem\[(\d+)\] = \d+'h([0-9a-f]+);", bank)}
        assert len(init) == len(words) == 400 and [init[i] for i in range(len(words))] == words, k
        py, px = divmod(k, 2)                       # bank (i mod 2, j mod 2) holds texel (i, j) at (j // 2, i // 2)
        assert words == [params.words[(2 * j + py) * 40 + 2 * i + px] for j in range(20) for i in range(20)]
        assert any(words)


@pytest.mark.parametrize("args, message", [
    (["--scene", "scenes/no-such.toml"], "scenes/no-such.toml: cannot read the scene file"),
    (["--scene", "tin-plane", "--preset", "no-such"], "unknown pipeline preset 'no-such'"),
    (["--preset", "tin-plane-fit"], "tin-plane-fit: a pipeline preset, whose memories come from a scene"),
])
def test_cli_scene_errors_are_named(tmp_path, capsys, args, message):

    assert bumpmap(["verilog", *args, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err and not list(tmp_path.iterdir())


def test_latency_mismatch_is_caught():
    params = preset("recip", "small")

    class Wrong(UnitComponent):
        def elaborate(self, platform):
            from amaranth.hdl import Module
            m = Module()
            pipe = Pipe(m)
            pipe.stage(x=self.w)
            self.finish(m, pipe, {"mant": 0, "exp": 0, "dbz": 0})
            return m

    from amaranth.back import rtlil
    with pytest.raises(AssertionError, match="pipeline has 2 stages but RecipParams.latency says"):
        rtlil.convert(Wrong(params))


def test_unknown_params_have_no_rtl():
    with pytest.raises(ValueError, match="no RTL for Fmt"):
        build(Fmt(True, 2, 2))


@given(st.lists(st.integers(1, 1000), max_size=40), st.integers(1, 1200))
def test_control_copies_split_registers_into_groups_of_at_most_the_fanout(sizes, limit):
    """``rtl.raster._groups``: every block in order, no group over ``limit`` bits unless it is one block, and
    each group full (the next block would not have fitted), so no more control copies than needed."""
    from rtl.raster import _groups

    blocks = [(bits, k) for k, bits in enumerate(sizes)]
    groups = _groups(blocks, limit)
    assert [b for g in groups for b in g] == blocks
    for g, nxt in zip(groups, groups[1:] + [None]):
        total = sum(bits for bits, _ in g)
        assert g and (total <= limit or len(g) == 1)
        if nxt is not None:
            assert total + nxt[0][0] > limit


def test_scan_converter_keeps_one_control_copy_per_register_group():
    """The engine's scan converter (``rtl/raster.py``, "Fan-out"): its row generator and Pixel Calculator each
    hold their control state in several copies, every copy driving at most ``ENABLE_FANOUT`` register bits."""
    import re

    from amaranth.back import rtlil

    from host.render import engine_params
    from rtl.raster import Raster

    params = engine_params("tin-plane", "tin-plane-fit").raster
    text = rtlil.convert(Raster(params))
    gen = set(re.findall(r"wire .*\\gen_valid_(\d+)\n", text))
    pc = set(re.findall(r"wire .*\\advance_(\d+)\n", text))
    acc_bits = sum(params.acc_fmt(n).width for n in params.names)
    assert len(gen) >= -(-3 * acc_bits // params.ENABLE_FANOUT) >= 2
    assert len(pc) >= -(-2 * acc_bits // params.ENABLE_FANOUT) >= 2


def _xor_cells(share: bool) -> int:
    """``$xor`` cells in the RTLIL of a register fed bit by bit from one ``a ^ b`` (through :func:`named` or not)."""
    from amaranth.back import rtlil
    from amaranth.hdl import Cat, Module, Signal

    from rtl.unit import named

    m = Module()
    a, b, o = Signal(16), Signal(16), Signal(16)
    x = named(m, a ^ b, "x") if share else a ^ b
    m.d.sync += o.eq(Cat(*(x[i] for i in reversed(range(16)))))
    return rtlil.convert(m, ports=[a, b, o]).count("cell $xor")


def test_a_subexpression_read_many_times_is_emitted_once_through_named():
    """Amaranth lowers a statement by copying its expression per read, so ``a ^ b`` read a bit at a time is
    emitted once per bit; through :func:`rtl.unit.named` once (why the carry-save span products and the level of
    detail's leading-zero counts name their subexpressions)."""
    assert _xor_cells(True) == 1 and _xor_cells(False) >= 8


def test_span_products_in_logic_stay_small():
    """The scan converter with its span products in logic (``span_dsp`` off): each carry-save level named, its
    RTLIL stays near its size with the products in multiplier blocks (nested, the levels restated one another:
    tens of megabytes and minutes of elaboration)."""
    import dataclasses

    from amaranth.back import rtlil

    from fxmodel.units.raster import RasterParams
    sizes = [len(rtlil.convert(build(dataclasses.replace(RasterParams.PRESETS["default"], span_dsp=dsp)),
                               name="raster", emit_src=False)) for dsp in (True, False)]
    assert sizes[1] < 2 * sizes[0], sizes


def test_with_next_is_the_value_after_the_clock():
    """``with_next``: a register assigned through its next value (a counter that loads, steps or holds, with a
    non-zero reset) equals, after each clock, what its ``_next`` showed before it; a plain register written the same
    way in ``m.d.sync`` is the reference, and the inputs are random."""
    import random

    from amaranth.hdl import Module, Signal
    from amaranth.sim import Simulator

    from rtl.unit import with_next

    m = Module()
    load, step, value = Signal(), Signal(), Signal(4)
    reg, ref = Signal(4, init=9, name="reg"), Signal(4, init=9)
    nxt = with_next(m, reg)
    with m.If(load):
        m.d.comb += nxt.eq(value)
        m.d.sync += ref.eq(value)
    with m.Elif(step):
        m.d.comb += nxt.eq(reg + 1)
        m.d.sync += ref.eq(ref + 1)
    rng, seen = random.Random(3), []

    async def bench(ctx):
        assert ctx.get(reg) == 9
        for _ in range(200):
            ctx.set(load, rng.random() < 0.2)
            ctx.set(step, rng.random() < 0.5)
            ctx.set(value, rng.randrange(16))
            shown = ctx.get(nxt)
            await ctx.tick()
            seen.append((shown, ctx.get(reg), ctx.get(ref)))

    sim = Simulator(m)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert nxt.name == "reg_next"
    assert all(shown == got == want for shown, got, want in seen), seen
    assert len({got for _, got, _ in seen}) > 4                  # it moved
