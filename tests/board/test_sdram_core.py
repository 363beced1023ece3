"""LiteDRAM's core in the design (``board/sdram_core.py``): the init sequence is LiteDRAM's own for the generated
SDR core (compared with ``litedram.init`` when installed, and with the generated ``csr.csv`` when generated), and
the Wishbone manager makes exactly its writes in order, each held until acknowledged and followed by its wait
(Amaranth's simulator, a responder acknowledging after random delays)."""

from __future__ import annotations

import random

import pytest
from amaranth.sim import Simulator

from board.sdram_core import CL, CMD, CSR, DFII, INIT, MIN_GAP, SdramInit, writes
from fxmodel.core.paths import build_dir


def test_the_sequence_is_litedrams_for_sdr():
    init = pytest.importorskip("litedram.init")

    class Phy:
        cl, nphases = CL, 1
    seq, _ = init.get_sdr_phy_init_sequence(Phy, None)
    names = {"DFII_COMMAND_" + k: v for k, v in CMD.items()} | {"DFII_CONTROL_" + k: v for k, v in DFII.items()}
    assert len(seq) == len(INIT)
    for (name, a, ba, cmd, delay), ours in zip(seq, INIT):
        bits = sum(names[c] for c in cmd.split("|"))
        assert (name, a, ba, delay) == (ours[0], ours[1], ours[2], ours[4])
        assert (ours[3] is None and name == "Bring CKE high"
                and bits == DFII["CKE"] | DFII["ODT"] | DFII["RESET_N"]) or bits == ours[3]


def test_the_registers_are_the_generated_cores():
    csv = build_dir("litedram") / "csr.csv"
    if not csv.exists():
        pytest.skip("no generated core (bumpmap litedram)")
    regs = {row.split(",")[1]: int(row.split(",")[2], 16) for row in csv.read_text().splitlines()
            if row.startswith("csr_register")}
    for name, addr in CSR.items():
        full = ("ddrctrl_" if name == "init_done" else "sdram_dfii_") + name.removeprefix("dfii_")
        assert regs[full] == addr, name


def test_the_manager_makes_the_writes_in_order_with_their_waits():
    dut = SdramInit(cke_delay=30)
    want = writes(cke_delay=30)
    assert want[-1] == (CSR["init_done"], 1, 0) and want[-2] == (CSR["dfii_control"], DFII["SEL"], 0)
    assert all(w >= MIN_GAP for a, _, w in want if a == CSR["pi0_command_issue"])
    got, rng = [], random.Random(3)

    async def bench(ctx):
        last_ack = None
        for clock in range(20000):
            await ctx.tick()
            if ctx.get(dut.done):
                break
            if ctx.get(dut.cyc) and ctx.get(dut.stb):
                if rng.random() < 0.4:
                    ctx.set(dut.ack, 1)
                    await ctx.tick()
                    ctx.set(dut.ack, 0)
                    got.append((ctx.get(dut.adr) << 2, ctx.get(dut.dat_w), clock))
                    last_ack = clock
        assert ctx.get(dut.done) and last_ack is not None

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert [(a, d) for a, d, _ in got] == [(a, d) for a, d, _ in want]
    for (_, _, t0), (_, _, t1), (_, _, wait) in zip(got, got[1:], want):
        assert t1 - t0 >= wait + 1


def test_the_cores_data_pins_become_inout_or_the_build_stops():
    from board.sdram_system import DQ_INOUT, DQ_INPUT, core_verilog
    text = f"module litedram_core (\n    {DQ_INPUT}\n    input wire clk\n);"
    assert DQ_INOUT in core_verilog(text) and DQ_INPUT not in core_verilog(text)
    with pytest.raises(ValueError, match="sdram_dq"):
        core_verilog(text.replace(DQ_INPUT, "inout wire [15:0] sdram_dq,"))
