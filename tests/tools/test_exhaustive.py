"""The exhaustive run (``tools/exhaustive.py``): merging the shard files of a run into the report, and (slow tier,
``-m slow``, run by ``make exhaustive``'s pytest line if it has one) every target of
:data:`tools.exhaustive.TARGETS`, sharded four ways so pytest-xdist spreads the shards over workers, merged into
``build/exhaustive/report.json``.
"""

from __future__ import annotations

import json

import pytest

from cosim.harness import simulator
from tools import exhaustive


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
@pytest.mark.cosim
@pytest.mark.parametrize("shard", range(1, SHARDS + 1))
@pytest.mark.parametrize("name", [t.name for t in exhaustive.TARGETS])
def test_exhaustive_target(name, shard):
    sim = simulator()
    rec = exhaustive.run_target(exhaustive.target(name), sim, shard=(shard, SHARDS))
    merged = exhaustive.merge_shards()
    if merged:
        exhaustive.update_report(merged)
    assert rec["vectors"] == rec["expected_vectors"] > 0
    assert rec["ok"], f"{name} shard {shard}/{SHARDS} on {sim}: {rec['mismatches']} mismatches, first {rec['first']}"
