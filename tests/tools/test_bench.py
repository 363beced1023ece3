"""``make bench``'s fixed-point core comparison (tools/bench.py): it times both cores, and only on identical results."""

import numpy as np
import pytest

from tools import bench
from tools.main import main as bumpmap


def test_core_rates_times_the_own_core_and_apytypes():
    rows = bench.core_rates(3000, 1, np.random.default_rng(0))
    assert [r["what"].split(" ")[0] for r in rows] == ["fxmodel.core.rounding.narrow", "apytypes", "apytypes,"]
    assert all(r["per_second"] > 0 and "s2.14" in r["workload"] for r in rows)


def test_core_rates_refuses_to_time_results_that_differ(monkeypatch):
    real = bench.narrow_apy

    def off_by_one(*args):
        codes, flag = real(*args)
        return codes + (np.arange(len(codes)) == 7), flag

    monkeypatch.setattr(bench, "narrow_apy", off_by_one)
    with pytest.raises(SystemExit, match="differ"):
        bench.core_rates(3000, 1, np.random.default_rng(0))


def test_callgrind_total_reads_the_summary_line(tmp_path):
    out = tmp_path / "callgrind.out"
    out.write_text("version: 1\ncmd: vvp sim.vvp\nevents: Ir\nfn=main\n12 7\nsummary: 123456789\ntotals: 123456789\n")
    assert bench._callgrind_total(out) == 123456789
    (tmp_path / "cut.out").write_text("events: Ir\nfn=main\n")
    with pytest.raises(RuntimeError, match="no summary"):
        bench._callgrind_total(tmp_path / "cut.out")


def test_icarus_profile_says_what_it_needs(monkeypatch, capsys):
    """Without valgrind the profile command stops with the package to install, before any simulation (exit 2)."""
    monkeypatch.setattr(bench.shutil, "which", lambda tool: None)
    assert bumpmap(["bench", "--icarus-profile", "recip"]) == 2
    assert "valgrind" in capsys.readouterr().err
