"""``make bench``'s fixed-point core comparison (tools/bench.py): it times both cores, and only on identical results."""

import numpy as np
import pytest

from tools import bench


def test_core_rates_times_the_own_core_and_apytypes():
    rows = bench.core_rates(3000, 1, np.random.default_rng(0))
    assert [r["what"].split(" ")[0] for r in rows] == ["fxmodel.rounding.narrow", "apytypes", "apytypes,"]
    assert all(r["per_second"] > 0 and "s2.14" in r["workload"] for r in rows)


def test_core_rates_refuses_to_time_results_that_differ(monkeypatch):
    real = bench.narrow_apy

    def off_by_one(*args):
        codes, flag = real(*args)
        return codes + (np.arange(len(codes)) == 7), flag

    monkeypatch.setattr(bench, "narrow_apy", off_by_one)
    with pytest.raises(SystemExit, match="differ"):
        bench.core_rates(3000, 1, np.random.default_rng(0))
