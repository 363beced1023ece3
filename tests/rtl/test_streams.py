"""Stream interfaces (``rtl/streams.py``) in Amaranth's simulator: payload layouts from the parameter object,
bit-exact results in order under input gaps and output backpressure, the documented latency and one result per
clock without stalls, the sideband, how much the output FIFO holds, and the block-RAM units through stalls.

The HDL-simulator stress test of every unit and preset is ``cosim/test_streams.py``; this file checks the
component itself on small presets, cycle by cycle, where Python sees every handshake.
"""

from __future__ import annotations

import numpy as np
import pytest
from amaranth.hdl import Fragment
from amaranth.lib import data
from amaranth.sim import Simulator

from fxmodel.core.unit import preset
from rtl.fixed import shape
from rtl.streams import StreamUnit, buffer_depth, input_layout, output_layout

SIDE = data.StructLayout({"x": 9, "y": 9})


def pattern(name: str, rng: np.random.Generator, cycles: int) -> np.ndarray:
    """0/1 per cycle: ``none`` (always 1), ``half`` (random 50 %), ``bursts`` (runs of 1 to 16), ``long`` (low
    for 100 to 300 cycles now and then)."""
    if name == "none":
        return np.ones(cycles, dtype=bool)
    if name == "half":
        return rng.random(cycles) < 0.5
    out, level = [], True
    while len(out) < cycles:
        n = rng.integers(1, 17) if name == "bursts" else (rng.integers(100, 301) if not level else
                                                          rng.integers(1, 60))
        out += [level] * int(n)
        level = not level
    return np.array(out[:cycles], dtype=bool)


def stream_through(params, vectors, valid, ready, side=None, max_cycles=None, in_stages=0):
    """Drive ``vectors`` into a :class:`StreamUnit` (``in_stages`` input registers; offering one when
    ``valid[cycle]``, held until taken), take outputs when ``ready[cycle]``; return outputs (codes), their
    sidebands, the cycles each input was accepted and each output taken, and the handshake-rule violations seen
    on ``o``."""
    dut = StreamUnit(params, side=SIDE if side is not None else None, in_stages=in_stages)
    n = len(vectors)
    got, sides, t_in, t_out, violations = [], [], [], [], []
    cycles = max_cycles or len(valid)

    async def bench(ctx):
        k, held = 0, None
        for cycle in range(cycles):
            if k < n and (valid[cycle] or held is not None):
                fields = {p.name: int(vectors[k][j]) for j, p in enumerate(params.inputs)}
                if side is not None:
                    fields["side"] = {"x": int(side[k][0]), "y": int(side[k][1])}
                ctx.set(dut.i.payload, fields)
                ctx.set(dut.i.valid, 1)
                offering = True
            else:
                ctx.set(dut.i.valid, 0)
                offering = False
            ctx.set(dut.o.ready, int(ready[cycle]))
            o_valid, payload = ctx.get(dut.o.valid), ctx.get(dut.o.payload)
            if held is not None and (not o_valid or payload.as_value().value != held):
                violations.append(cycle)                   # o changed while valid and not taken
            held = None
            if o_valid and ready[cycle]:
                got.append([getattr(payload, p.name) for p in params.outputs])
                if side is not None:
                    sides.append([payload.side.x, payload.side.y])
                t_out.append(cycle)
            elif o_valid:
                held = payload.as_value().value
            if offering and ctx.get(dut.i.ready):
                t_in.append(cycle)
                k += 1
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return np.array(got, dtype=np.int64).reshape(-1, len(params.outputs)), sides, t_in, t_out, violations


def test_payload_layouts_follow_the_parameter_object():
    params = preset("divide", "default")
    lay_in, lay_out = input_layout(params), output_layout(params, side=SIDE)
    assert list(dict(lay_in.members)) == [p.name for p in params.inputs]
    for p in params.inputs:
        assert lay_in.members[p.name] == shape(p.fmt)
    assert list(dict(lay_out.members)) == [p.name for p in params.outputs] + ["side"]
    assert lay_out.size == sum(p.fmt.width for p in params.outputs) + SIDE.size
    from amaranth.lib import stream
    from amaranth.lib.wiring import In, Out
    sig = StreamUnit(params, side=SIDE).signature.members
    assert sig["i"] == In(stream.Signature(input_layout(params, SIDE))) and sig["o"] == Out(stream.Signature(lay_out))


@pytest.mark.parametrize("in_stages", [0, 1, 2])
def test_no_stall_keeps_the_latency_and_one_result_per_clock(in_stages):
    params = preset("recip", "small")
    vectors = np.concatenate([params.hard_cases()[:40], params.random_inputs(np.random.default_rng(1), 60)])
    n = len(vectors)
    cycles = n + params.latency + in_stages + 4
    ones = np.ones(cycles, dtype=bool)
    got, _, t_in, t_out, bad = stream_through(params, vectors, ones, ones, in_stages=in_stages)
    assert np.array_equal(got, params.compute(vectors))
    assert t_in == list(range(n))                               # accepted on every cycle
    lat = StreamUnit(params, in_stages=in_stages).latency
    assert lat == params.latency + in_stages
    assert t_out == [t + lat for t in t_in]                     # the documented latency, one per clock
    assert not bad


@pytest.mark.parametrize("valid_pat, ready_pat, in_stages", [
    ("half", "half", 0), ("bursts", "bursts", 0), ("none", "long", 0), ("half", "long", 0), ("none", "half", 0),
    ("half", "long", 1), ("none", "half", 1)])
def test_gaps_and_backpressure_lose_nothing(valid_pat, ready_pat, in_stages):
    """Every result exactly once, in order, bit-exact; the sideband travels with its fragment; ``o`` holds still
    while it waits."""
    params = preset("recip", "small")
    rng = np.random.default_rng(list((valid_pat + ready_pat).encode()))
    hard = params.hard_cases()
    vectors = np.concatenate([hard[rng.choice(len(hard), 100)], params.random_inputs(rng, 150)])
    side = rng.integers(0, 512, size=(len(vectors), 2))
    cycles = 3000
    valid, ready = pattern(valid_pat, rng, cycles), pattern(ready_pat, rng, cycles)
    ready[-200:] = True                                          # let it drain
    got, sides, t_in, t_out, bad = stream_through(params, vectors, valid, ready, side=side, in_stages=in_stages)
    assert len(t_in) == len(vectors), "not every input was accepted"
    assert np.array_equal(got, params.compute(vectors))         # none lost, none extra, in order
    assert sides == side.tolist()
    assert not bad, f"o changed while waiting at cycles {bad[:5]}"
    if ready_pat != "none":
        assert not all(ready[:t_out[-1]]), "the pattern must stall the output, or this test proves nothing"


@pytest.mark.parametrize("in_stages", [0, 1])
def test_a_stalled_consumer_fills_the_buffer_then_stops_the_input(in_stages):
    """With ``o.ready`` low the unit accepts only what its output FIFO can hold (one result per stage, input
    registers included, and one more), then drops ``i.ready``; nothing is lost when ``ready`` returns."""
    params = preset("recip", "small")
    vectors = params.random_inputs(np.random.default_rng(3), 100)
    cycles = 400
    valid = np.ones(cycles, dtype=bool)
    ready = np.zeros(cycles, dtype=bool)
    ready[300:] = True
    got, _, t_in, t_out, bad = stream_through(params, vectors, valid, ready, in_stages=in_stages)
    before = [t for t in t_in if t < 300]
    assert len(before) == buffer_depth(params, in_stages) == params.latency + in_stages + 1   # the FIFO's slots
    assert np.array_equal(got, params.compute(vectors)) and not bad


@pytest.mark.parametrize("name", ["default", "cube"])
def test_sampler_block_ram_through_stalls(name):
    """The samplers' texel memories are read in the pipeline (synchronous read ports), which runs free while the
    output waits: bit-exact, in order, under long stalls."""
    params = preset("sampler", name)
    frag = Fragment.get(StreamUnit(params), None)
    ports = []

    def walk(f):
        for sub, _, _ in f.subfragments:
            ports.extend(getattr(sub, "_read_ports", []))
            walk(sub)
    walk(frag)
    assert ports, "the sampler has no memory read port?"
    rng = np.random.default_rng(7)
    hard = params.hard_cases()
    vectors = np.concatenate([hard[rng.choice(len(hard), min(len(hard), 80), replace=False)],
                              params.random_inputs(rng, 80)])
    cycles = 2500
    ready = pattern("long", rng, cycles)
    ready[-100:] = True
    got, _, t_in, _, bad = stream_through(params, vectors, pattern("half", rng, cycles), ready)
    assert len(t_in) == len(vectors)
    assert np.array_equal(got, params.compute(vectors)) and not bad


def test_sideband_name_clash_is_refused():
    from fxmodel.core.fixed import Fmt
    from fxmodel.core.unit import Port
    from rtl.streams import payload_layout
    with pytest.raises(ValueError, match="side"):
        payload_layout([Port("side", Fmt(True, 1, 3))], SIDE)


def _credit_fifo_run(depth, cycles, seed, cheat=False):
    """A writer holding credits (it writes only while words held + words it wrote but not yet seen read leave a
    place; ``cheat`` writes whenever it likes) and a reader with random ``r_en``: every word read, the level,
    ``r_rdy`` and ``overflow`` per cycle, and what a Python deque says they should be."""
    from collections import deque

    from rtl.streams import CreditFIFO
    dut = CreditFIFO(12, depth)
    rng = np.random.default_rng(seed)
    log = {"read": [], "want": [], "overflow": 0, "level_ok": True}

    async def bench(ctx):
        model, k = deque(), 0
        for _ in range(cycles):
            r_en = bool(rng.random() < 0.6)
            level = ctx.get(dut.level)
            w_en = bool(rng.random() < 0.7) and (cheat or level < depth)
            ctx.set(dut.w_en, w_en)
            ctx.set(dut.w_data, k)
            ctx.set(dut.r_en, r_en)
            await ctx.delay(1e-9)
            if cheat:                               # the model ends at the first write into a full FIFO
                await ctx.tick()
                continue
            log["level_ok"] &= level == len(model) and ctx.get(dut.r_rdy) == (len(model) > 0) \
                and ctx.get(dut.w_rdy) == (level != depth)
            if ctx.get(dut.r_rdy) and r_en:
                log["read"].append(ctx.get(dut.r_data))
                log["want"].append(model.popleft())
            if w_en:
                if len(model) < depth:
                    model.append(k)
                k += 1
            await ctx.tick()
        log["overflow"] = ctx.get(dut.overflow)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return log


@pytest.mark.parametrize("depth", [2, 4, 5])
def test_credit_fifo_returns_every_word_in_order_with_its_level(depth):
    log = _credit_fifo_run(depth, 600, seed=depth)
    assert len(log["read"]) > 200
    assert log["read"] == log["want"]
    assert log["level_ok"] and log["overflow"] == 0


def test_credit_fifo_flags_a_write_into_a_full_fifo():
    log = _credit_fifo_run(4, 300, seed=1, cheat=True)
    assert log["overflow"] == 1


@pytest.mark.parametrize("depth", [2, 3, 5])
def test_tail_fifo_is_sync_fifo_buffered_clock_for_clock_with_its_tail(depth):
    """``TailFIFOBuffered`` beside Amaranth's ``SyncFIFOBuffered`` of the same depth, fed the same random writes
    and reads: every port equal on every clock (so the texel cache's input FIFO keeps its timing), and ``r_tail``
    the tail of the word held (a 7-bit word's bits reversed and XORed with 5: not the word) whenever ``r_rdy``."""
    from amaranth.hdl import Cat, Module
    from amaranth.lib.fifo import SyncFIFOBuffered

    from rtl.streams import TailFIFOBuffered

    def tail(word):
        return Cat(*reversed(list(word))) ^ 5

    m = Module()
    m.submodules.ref = ref = SyncFIFOBuffered(width=7, depth=depth)
    m.submodules.dut = dut = TailFIFOBuffered(width=7, depth=depth, tail=tail)
    rng = np.random.default_rng(depth)
    log = {"same": True, "tail": True, "reads": 0}

    async def bench(ctx):
        for k in range(800):
            w_en, r_en = bool(rng.random() < 0.6), bool(rng.random() < 0.5)
            for f in (ref, dut):
                ctx.set(f.w_en, w_en)
                ctx.set(f.w_data, k % 128)
                ctx.set(f.r_en, r_en)
            await ctx.delay(1e-9)
            ports = [[ctx.get(getattr(f, p)) for p in ("w_rdy", "r_rdy", "level", "r_level", "w_level")]
                     for f in (ref, dut)]
            log["same"] &= ports[0] == ports[1]
            if ctx.get(dut.r_rdy):
                word = ctx.get(dut.r_data)
                log["same"] &= word == ctx.get(ref.r_data)
                log["tail"] &= ctx.get(dut.r_tail) == int(f"{word:07b}"[::-1], 2) ^ 5
                log["reads"] += r_en
            await ctx.tick()

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    assert log["reads"] > 200
    assert log["same"] and log["tail"]
    with pytest.raises(ValueError, match="depth 1"):
        TailFIFOBuffered(width=7, depth=1, tail=tail)
