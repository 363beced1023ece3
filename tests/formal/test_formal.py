"""The fast subset of the formal proofs (``make formal`` runs them all, ``formal/``): one stream unit's rules
proven by k-induction, the ROP's AXI4 port and hazard rule proven, a broken variant failing with a
counterexample waveform; the record's table, and clear errors for a missing solver or a bad name."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from formal.report import markdown_table
from formal.runner import tools_missing
from formal.sets import property_sets, run_set, run_variant, variants
from fxmodel.core.paths import ROOT, build_dir  # noqa: E402

#: YoWASP maps /tmp to a private folder, so the jobs run under the repository's build folder
OUT = build_dir("formal", "test")

needs_tools = pytest.mark.skipif(tools_missing() is not None, reason=str(tools_missing()))


def _set(name):
    (ps,) = [s for s in property_sets() if s.name == name]
    return ps


@needs_tools
def test_stream_unit_rules_are_proven_by_induction():
    entry = run_set(_set("stream_recip"), OUT, covers=False)
    assert entry["status"] == "PASS", entry
    assert entry["runs"][0]["mode"] == "prove" and entry["verdict"].startswith("proven")


@needs_tools
def test_rop_axi_port_and_hazard_are_proven_and_reachable():
    entry = run_set(_set("rop_axi"), OUT)
    assert entry["status"] == "PASS", entry
    assert [r["kind"] for r in entry["runs"]] == ["proof", "cover"]


@needs_tools
def test_broken_variant_fails_with_a_waveform():
    (v,) = [v for v in variants() if v.name == "payload_while_stalled"]
    entry = run_variant(v, OUT)
    assert entry["status"] == "FAIL" and entry["caught"], entry
    assert "o_hold" in entry["failed"]
    vcd = Path(entry["trace"])
    text = (vcd if vcd.is_absolute() else ROOT / vcd).read_text()
    assert "$enddefinitions" in text and "o__payload" in text


def _run_cli(*args, env=None):
    return subprocess.run([sys.executable, "-m", "tools", "formal", *args], cwd=ROOT, capture_output=True, text=True,
                          env=env, timeout=120)


def test_missing_solver_is_a_clear_error(monkeypatch, capsys):
    """No tool in the interpreter's folder nor on PATH: one line naming the tool and its package, exit 2."""
    from tools.main import main
    monkeypatch.setattr(sys, "executable", "/nonexistent/python")
    monkeypatch.setenv("PATH", "/nonexistent")
    assert main(["formal", "--only", "rop_axi"]) == 2
    err = capsys.readouterr().err
    assert "not found on PATH" in err and "yowasp" in err


def test_unknown_set_is_refused_by_name():
    run = _run_cli("--only", "no_such_set", env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 2 and "no_such_set" in run.stderr


def test_markdown_table_lists_every_set_and_variant():
    record = {"command": "bumpmap formal", "machine": {"nproc": 2, "loadavg": [1.0, 0.5, 0.2]}, "seconds": 12,
              "sets": [{"name": "a_set", "design": "D", "properties": "p | q", "verdict": "bounded (depth 9)",
                        "why": "latency 4", "status": "PASS", "seconds": 1.5,
                        "runs": [{"kind": "bounded", "mode": "bmc", "depth": 9, "status": "PASS", "seconds": 1.5}]}],
              "broken": [{"name": "bug", "bug": "B", "expect": "o_hold", "failed": ["o_hold"], "status": "FAIL",
                          "caught": True, "seconds": 0.5}]}
    table = markdown_table(record)
    rows = [line for line in table.splitlines() if line.startswith("| ")]
    assert len(rows) == 4                                   # two headers, one set, one variant
    assert "p \\| q" in table and "bounded (depth 9) (latency 4)" in table and "| yes |" in table
    assert "load average 1.0, 0.5, 0.2" in table


def test_committed_record_covers_every_set_and_catches_every_variant():
    record = json.loads((ROOT / "docs" / "formal" / "proofs.json").read_text())
    assert {s["name"] for s in record["sets"]} == {s.name for s in property_sets()}
    assert {b["name"] for b in record["broken"]} == {v.name for v in variants()}
    assert all(s["status"] == "PASS" for s in record["sets"])
    assert all(b["caught"] for b in record["broken"])
    assert record["machine"]["nproc"] >= 1 and record["command"].startswith("bumpmap formal")


READ_PORTS = [
    # (set, checks it must hold, broken variant, the check the variant must fail)
    ("texcache_axi", {"ar_hold", "ar_4k", "ar_len_declared", "ar_outstanding"}, "texcache_rlast_early",
     "fill_is_outstanding"),
    # the decoupled cache (several bursts outstanding, a lookup FIFO); one burst beyond its budget
    ("texcache_decoupled_axi", {"ar_outstanding", "owed_lines", "inside_is_stages", "o_capacity"},
     "decoupled_extra_burst", "ar_outstanding"),
]


@needs_tools
@pytest.mark.parametrize("name, checks, variant, failed", READ_PORTS, ids=[r[0] for r in READ_PORTS])
def test_cache_read_port_is_proven_and_its_broken_variant_caught(name, checks, variant, failed):
    """Each texel cache's AXI4 read port proven by k-induction; its broken variant fails ``failed`` with a
    waveform."""
    entry = run_set(_set(name), OUT, covers=False)
    assert entry["status"] == "PASS" and entry["verdict"].startswith("proven"), entry
    assert checks <= set(entry["checks"])
    (v,) = [v for v in variants() if v.name == variant]
    caught = run_variant(v, OUT)
    assert caught["caught"] and failed in caught["failed"], caught
    assert (ROOT / caught["trace"]).exists() or Path(caught["trace"]).exists()


def test_every_read_manager_entry_is_a_property_set():
    from formal.readers import READ_MANAGERS
    assert READ_MANAGERS and {e.name for e in READ_MANAGERS} <= {s.name for s in property_sets()}


def test_abstract_unit_keeps_the_ports_and_the_valid_delay_line():
    """The abstraction of formal/abstract.py has the unit's ports and latency, and its o_valid is i_valid delayed
    by the latency (the only thing StreamUnit reads of a unit), in registers named as every unit's."""
    from amaranth.sim import Simulator

    from formal import whitebox
    from formal.abstract import Abstract
    from fxmodel.core.unit import preset
    from rtl.unit import build
    real = preset("recip", "small")
    p = Abstract.of(real)
    assert (p.inputs, p.outputs, p.latency) == (tuple(real.inputs), tuple(real.outputs), real.latency)
    dut = build(p)
    frag = whitebox.elaborate(build(p))
    assert whitebox.has_signal(frag, f"valid{p.latency}") and not whitebox.has_signal(frag, f"valid{p.latency + 1}")
    pattern = [1, 0, 1, 1, 0, 0, 1, 0] + [0] * p.latency
    seen = []

    async def bench(ctx):
        for v in pattern:
            ctx.set(dut.i_valid, v)
            seen.append(ctx.get(dut.o_valid))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert seen == [0] * p.latency + pattern[:len(pattern) - p.latency]


@needs_tools
def test_rop_chip_forwarding_is_proven_and_a_missing_forward_fails():
    """The on-chip depth test's writes are a reference depth test's (proven by k-induction, covers reached: each
    forwarding distance taken); without the forwarding (``hazard=False``) the bounded check finds a wrong write."""
    entry = run_set(_set("rop_chip"), OUT)
    assert entry["status"] == "PASS", entry
    assert "write_decision" in entry["checks"] and "forward_5_reach" in entry["covers"]
    (v,) = [v for v in variants() if v.name == "rop_chip_no_forwarding"]
    broken = run_variant(v, OUT)
    assert broken["caught"] and "write_decision" in broken["failed"], broken


def test_rop_chip_frame_model_is_the_memory():
    """The proof's frame (``formal.rop_chip.ArrayFrameRop``: registers with the read port's behaviour) is the
    design's memory: both ROPs, driven alike at random (fragments with recurring pixels, read-outs, clears begun
    while idle), give the same ``fb.data``, ``busy`` and ``status`` on every clock."""
    import numpy as np
    from amaranth.hdl import Module
    from amaranth.sim import Simulator

    from formal.rop_chip import ArrayFrameRop, small_rop_chip
    from rtl.rop import Rop

    P = small_rop_chip()
    m = Module()
    m.submodules.real = real = Rop(P)
    m.submodules.model = model = ArrayFrameRop(P)
    rng = np.random.default_rng(7)
    width = len(real.i.payload.as_value())
    diffs, reads = [], {"n": 0}

    async def bench(ctx):
        clearing = False
        for cycle in range(3000):
            busy = ctx.get(real.busy)
            read = rng.random() < 0.15
            clear = read and (clearing or (not busy and rng.random() < 0.5))
            clearing = clear
            values = {"i.valid": int(rng.random() < 0.8), "payload": int(rng.integers(0, 1 << width)),
                      "read": int(read), "clear": int(clear), "addr": int(rng.integers(0, P.pixels))}
            for dut in (real, model):
                ctx.set(dut.i.valid, values["i.valid"])
                ctx.set(dut.i.payload.as_value(), values["payload"])
                ctx.set(dut.fb.read, values["read"])
                ctx.set(dut.fb.clear, values["clear"])
                ctx.set(dut.fb.addr, values["addr"])
            await ctx.tick()
            got = [tuple(ctx.get(s) for s in (d.fb.data, d.busy, d.status)) for d in (real, model)]
            reads["n"] += read
            if got[0] != got[1]:
                diffs.append((cycle, got))

    sim = Simulator(m)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert reads["n"] > 300 and not diffs, diffs[:3]
