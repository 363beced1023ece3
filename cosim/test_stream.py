"""Streaming co-simulation: the exhaustive check passes on the true RTL, fails on a broken one with the
right first mismatch, and covers exactly the vectors it claims; input spaces, shards and report merging.

Quick tier (``make test``): the reciprocal ``small`` preset over all 2**16 inputs, true and broken (inputs
counted by the wrapper and read from the vector files), on ``SIM`` (every unit and preset under stalls:
``cosim/test_stress.py``). The exhaustive run's own tests (shard merging, every target) are
``tests/tools/test_exhaustive.py``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cosim.stream import (
    ArraySpace,
    ConcatSpace,
    ProductSpace,
    full_space,
    grid_space,
    measure_throughput,
    parse_shard,
    run_stream,
    shard_range,
    wrapper_verilog,
)
from fxmodel.core.paths import build_dir
from fxmodel.core.unit import preset


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


# -- spaces, shards, reports (no simulator) -------------------------------------------------------------------
def test_memory_word_parts_are_the_payloads():
    """The vector word (its layout as the wrapper's header lists it) is the input payload then the output payload,
    every field at its offset in the rtl.streams layouts, so the wrapper connects both whole; the counted rows
    (first port most significant) are rearranged into the payload's order."""
    import re

    from rtl.streams import input_layout, output_layout
    params = preset("divide", "default")
    text = wrapper_verilog(params, "stream_divide", "divide_dut")
    word = {m[3]: (int(m[1]), int(m[2])) for m in re.finditer(r"^//   \[(\d+):(\d+)\] (\w+) ", text, re.M)}
    ow = output_layout(params).size
    assert set(word) == {p.name for p in params.inputs + params.outputs}
    for name, field in input_layout(params):
        assert word[name] == (ow + field.offset + field.width - 1, ow + field.offset)
    for name, field in output_layout(params):
        assert word[name] == (field.offset + field.width - 1, field.offset)
    assert ".i__payload(in_word)" in text and ".o__payload(got)" in text
    n, d = (p.fmt.width for p in params.inputs)       # the row: n above d; the payload: d above n
    assert f"{{row[{d - 1}:0], row[{n + d - 1}:{d}]}}" in text
    assert f"LATENCY = {params.latency}" in text and "divide_dut dut (" in text
    # expand mode (triangle records): the word is the input payload alone, the dump the output payload
    text = wrapper_verilog(params, "stream_divide", "divide_dut", expand=True)
    word = {m[3]: (int(m[1]), int(m[2])) for m in re.finditer(r"^//   \[(\d+):(\d+)\] (\w+) ", text, re.M)}
    for layout_, shift in ((input_layout(params), 0), (output_layout(params), 0)):
        for name, field in layout_:
            assert word[name] == (shift + field.offset + field.width - 1, shift + field.offset)
    assert "in_word <= next;" in text


@pytest.mark.parametrize("weights, shards", [([5, 1, 1, 1, 1, 1], 2), ([1] * 7, 3), ([3, 0, 0, 9], 4),
                                             ([2, 2], 5), ([0, 0, 0], 2), ([7], 1),
                                             ([4, 4, 2], 2), ([1, 9], 2)])
def test_shard_weights_cover_the_items_in_contiguous_balanced_ranges(weights, shards):
    """Contiguous, none empty, covering every item in order, at most one per item; no boundary could move one
    item and bring the heavier side of it closer to an equal share."""
    from cosim.stream import shard_weights
    parts = shard_weights(weights, shards)
    assert len(parts) == min(shards, len(weights))
    assert parts[0][0] == 0 and parts[-1][1] == len(weights)
    assert all(a < b for a, b in parts) and all(p[1] == q[0] for p, q in zip(parts, parts[1:]))
    if len(parts) == 2:
        total, (_, cut) = sum(weights), parts[0]
        share = lambda c: abs(sum(weights[:c]) - total / 2)       # noqa: E731
        assert all(share(cut) <= share(c) for c in (cut - 1, cut + 1) if 0 < c < len(weights))


def test_wrapper_template_refuses_an_undefined_name(tmp_path):
    from cosim.stream import render
    (tmp_path / "t.j2").write_text("module {{ top }}; {{ missing }}")
    with pytest.raises(Exception, match="missing"):
        render(tmp_path / "t.j2", top="x")


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


def test_measure_throughput(sim):
    """The figure ``make bench`` reports beside the per-vector harness's (a positive rate of a bit-exact run)."""
    res = measure_throughput(preset("recip", "small"), sim, vectors=5000, pattern="random")
    assert res["vectors"] == 5000 and res["vectors_per_second"] > 0 and res["stalled"] > 0


def test_sim_command_streams_a_unit_with_backpressure(sim):
    """``bumpmap sim --unit``: the streaming harness under a stall pattern, the report written, exit 0."""
    from cosim.sim import main
    assert main(["--unit", "recip", "--preset", "small", "--vectors", "500", "--pattern", "stalls",
                 "--sim", sim]) == 0
    report = json.loads((build_dir("sim") / "recip_small" / "report.json").read_text())
    assert report["vectors"] == len(preset("recip", "small").hard_cases()) + 500
    assert report["mismatches"] == 0 and report["missing"] == 0 and report["stalled"] > 0
