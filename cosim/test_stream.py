"""Streaming co-simulation: the exhaustive check passes on the true RTL, fails on a broken one with the
right first mismatch, and covers exactly the vectors it claims; input spaces, shards and report merging.

Quick tier (``make test``): the reciprocal ``small`` preset over all 2**16 inputs, true and broken (inputs
counted by the wrapper and read from the vector files), on ``SIM``; the divider, and two other units of unlike
port shapes, on hard cases and random vectors (the slow tier: every registered unit). Slow tier (``-m slow``, run
by ``make exhaustive``'s pytest line if it has one): every target of :data:`tools.exhaustive.TARGETS`, sharded
four ways so pytest-xdist spreads the shards over workers, merged into ``build/exhaustive/report.json``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tools import exhaustive
from cosim.stream import (ArraySpace, ConcatSpace, ProductSpace, full_space, grid_space, measure_throughput,
                          parse_shard, run_stream, shard_range, wrapper_verilog)
from fxmodel.unit import preset, preset_names, units


def broken_recip(params, entry: int, delta: int = 1):
    """A copy of reciprocal ``params`` whose table word ``entry`` is off by ``delta`` (its ROM, hence its RTL,
    and its model); the centring bias stays the true table's, as a wrong ROM word would leave it."""
    codes = np.array(params.table_codes, copy=True)
    codes[entry] += delta
    bad = params.with_table(codes)
    assert bad.rom[entry] == params.rom[entry] + delta and bad.bias_code == params.bias_code
    return bad


# -- the RTL check itself -------------------------------------------------------------------------------------
def test_recip_small_exhaustive(sim):
    """All 2**16 inputs, in four chunks (exercises the chunk handshake), bit-exact, nothing skipped."""
    params = preset("recip", "small")
    result = run_stream(params, sim=sim, chunk=1 << 14)
    assert result["vectors"] == result["expected_vectors"] == 1 << 16
    assert result["chunks"] == 4
    assert result.ok, result.describe()


def test_broken_rom_word_is_caught_with_the_right_first_mismatch(sim):
    """One ROM word off by one in the RTL; the model stays true. Every row where the broken datapath differs must
    be counted, and the first records must be those rows with the broken model's outputs as the RTL's."""
    params = preset("recip", "small")
    bad = broken_recip(params, entry=5)
    inputs = params.all_inputs()
    want, got = params.compute(inputs), bad.compute(inputs)
    rows = np.flatnonzero(np.any(want != got, axis=1))
    assert len(rows) > 100, "the broken table word must change some outputs, or this test proves nothing"
    result = run_stream(params, sim=sim, rtl_params=bad, variant="rom5plus1", keep=4)
    assert not result.ok
    assert result["vectors"] == 1 << 16
    assert result["valid_errors"] == 0 and result["missing"] == 0
    assert result["mismatches"] == len(rows)
    assert result["first"] == [{"index": int(r), "inputs": inputs[r].tolist(), "rtl": got[r].tolist(),
                                "model": want[r].tolist()} for r in rows[:4]]


@pytest.mark.parametrize("given", ["space", "vectors"])
def test_broken_variant_in_a_shard_reports_space_indices(sim, given):
    """The same kind of fault seen from the second of two shards, with the inputs counted by the wrapper (the
    whole space) or read from the vector files (the same inputs given as vectors): indices count from the start
    of the space, and both ways find the same rows."""
    params = preset("recip", "small")
    bad = broken_recip(params, entry=31)
    inputs = params.all_inputs()
    want, got = params.compute(inputs), bad.compute(inputs)
    rows = np.flatnonzero(np.any(want != got, axis=1))
    lo, hi = shard_range(len(inputs), (2, 2))
    inside = rows[(rows >= lo) & (rows < hi)]
    assert len(inside)
    result = run_stream(params, None if given == "space" else inputs, sim=sim, shard="2/2", rtl_params=bad,
                        variant="rom31plus1", keep=2)
    assert result["range"] == [lo, hi] and result["vectors"] == hi - lo
    assert result["mismatches"] == len(inside)
    assert result["first"] == [{"index": int(r), "inputs": inputs[r].tolist(), "rtl": got[r].tolist(),
                                "model": want[r].tolist()} for r in inside[:2]]


def test_divide_hard_and_random(sim):
    params = preset("divide", "default")
    rng = np.random.default_rng(6)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 30_000)])
    result = run_stream(params, vectors, sim=sim)
    assert result["vectors"] == len(vectors)
    assert result.ok, result.describe()


#: Units with unlike port shapes for the quick tier (many inputs and words above 64 bits; unsigned and 3-bit
#: fields); the slow tier runs every registered unit.
QUICK_UNITS = ("bump", "cube")


@pytest.mark.parametrize("unit", [pytest.param(u, marks=() if u in QUICK_UNITS else pytest.mark.slow)
                                  for u in units() if u not in ("recip", "divide")])
def test_every_unit_streams(sim, unit):
    """The wrapper is generated from the parameter object alone: every registered unit runs unchanged."""
    params = preset(unit, "small" if "small" in preset_names(unit) else "default")
    rng = np.random.default_rng(1)
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, 300)])[:600]
    result = run_stream(params, vectors, sim=sim)
    assert result["vectors"] == len(vectors)
    assert result.ok, result.describe()


# -- spaces, shards, reports (no simulator) -------------------------------------------------------------------
def test_wrapper_connects_every_port_by_name():
    params = preset("divide", "default")
    text = wrapper_verilog(params, "stream_divide", "divide_dut")
    for p in params.inputs + params.outputs:
        assert f".{p.name}(" in text
    assert "LATENCY = %d" % params.latency in text


def test_spaces_enumerate_as_documented():
    params = preset("divide", "default")
    assert np.array_equal(full_space(params).take(70_000, 70_010), params.all_inputs(70_000, 70_010))
    prod = ProductSpace(params, {"n": [-5, 3]})
    assert len(prod) == 2 << 16
    rows = prod.take(65_535, 65_538)
    assert rows.tolist() == [[-5, 32767], [3, -32768], [3, -32767]]
    both = ConcatSpace(ArraySpace([[1, 2], [3, 4]]), prod)
    assert both.take(1, 4).tolist() == [[3, 4], [-5, -32768], [-5, -32767]]
    with pytest.raises(ValueError, match="no input port q"):
        ProductSpace(params, {"q": [1]})
    with pytest.raises(ValueError, match="outside"):
        ProductSpace(params, {"n": [1 << 20]})
    grid = grid_space(params, 7, full=("d",))
    hard = len(params.hard_cases())
    n_codes = np.unique(grid.take(hard, len(grid))[:, 0])
    assert {-(1 << 15), -1, 0, 1, (1 << 15) - 1} <= set(n_codes.tolist())
    assert len(n_codes) == 128 + 5 and len(grid) == hard + (len(n_codes) << 16)


@pytest.mark.parametrize("size,n", [(10, 3), (1 << 24, 7), (5, 5), (3, 4)])
def test_shards_partition_the_range(size, n):
    ranges = [shard_range(size, (i, n)) for i in range(1, n + 1)]
    assert ranges[0][0] == 0 and ranges[-1][1] == size
    assert all(a[1] == b[0] for a, b in zip(ranges, ranges[1:]))
    assert max(b - a for a, b in ranges) - min(b - a for a, b in ranges) <= 1


@pytest.mark.parametrize("text", ["0/4", "5/4", "1-4", "a/b", "3"])
def test_bad_shard_is_named(text):
    with pytest.raises(ValueError, match="shard"):
        parse_shard(text)


def test_run_rejects_bad_arguments():
    params = preset("recip", "small")
    with pytest.raises(ValueError, match="variant"):
        run_stream(params, rtl_params=broken_recip(params, 1))
    with pytest.raises(ValueError, match="chunk"):
        run_stream(params, chunk=0)
    with pytest.raises(ValueError, match="not inside"):
        run_stream(params, lo=10, hi=1 << 20)


def test_merge_shard_files(tmp_path):
    def rec(i, n, lo, hi, mism, first):
        return {"unit": "recip", "preset": "small", "simulator": "icarus", "vectors": hi - lo, "mismatches": mism,
                "seconds": 2.0, "process_seconds": 2.0, "vectors_per_second": (hi - lo) / 2,
                "ok": mism == 0, "valid_errors": 0,
                "missing": 0, "expected_vectors": hi - lo, "space": "s", "range": [lo, hi], "first": first,
                "build_seconds": 1.0, "started": 100.0 + i, "finished": 110.0 + i, "wall_seconds": 10.0,
                "shard": [i, n]}
    (tmp_path / "recip-small-icarus-2of3.json").write_text(json.dumps(rec(2, 3, 4, 8, 1, [{"index": 5}])))
    (tmp_path / "recip-small-icarus-1of3.json").write_text(json.dumps(rec(1, 3, 0, 4, 0, [])))
    assert exhaustive.merge_shards(tmp_path) == []                 # shard 3 still missing: nothing merged
    (tmp_path / "recip-small-icarus-3of3.json").write_text(json.dumps(rec(3, 3, 8, 10, 2, [{"index": 8}])))
    [m] = exhaustive.merge_shards(tmp_path)
    assert (m["vectors"], m["mismatches"], m["seconds"], m["shards"], m["range"]) == (10, 3, 6.0, 3, [0, 10])
    assert m["vectors_per_second"] == 10 / 6.0 and m["wall_seconds"] == 12.0 and not m["ok"]
    assert [f["index"] for f in m["first"]] == [5, 8]
    assert not list(tmp_path.glob("*.json"))
    report = exhaustive.update_report([m], tmp_path / "report.json")
    report = exhaustive.update_report([dict(m, mismatches=0)], tmp_path / "report.json")
    assert len(report) == 1 and report[0]["mismatches"] == 0


# -- slow tier: the exhaustive targets, sharded for pytest-xdist ----------------------------------------------
SHARDS = 4


@pytest.mark.slow
@pytest.mark.parametrize("shard", range(1, SHARDS + 1))
@pytest.mark.parametrize("name", [t.name for t in exhaustive.TARGETS])
def test_exhaustive_target(sim, name, shard):
    rec = exhaustive.run_target(exhaustive.target(name), sim, shard=(shard, SHARDS))
    merged = exhaustive.merge_shards()
    if merged:
        exhaustive.update_report(merged)
    assert rec["vectors"] == rec["expected_vectors"] > 0
    assert rec["ok"], f"{name} shard {shard}/{SHARDS} on {sim}: {rec['mismatches']} mismatches, first {rec['first']}"


def test_measure_throughput(sim):
    """The figure ``make bench`` reports beside the per-vector harness's (a positive rate of a bit-exact run)."""
    assert measure_throughput(preset("recip", "small"), sim, vectors=5000) > 0
