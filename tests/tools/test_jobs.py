"""The Dask job runner (tools/jobs.py): serial and clustered runs agree, a killed worker's pieces are redone,
results resume from the cache, and the model-side proof (tools/prove.py) finds a wrong output."""

import json
import os
import signal
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.stream import FullSpace, shard_range
from fxmodel.core.unit import preset
from fxmodel.units import exact
from tools import jobs
from tools.main import main as bumpmap
from tools.prove import ProofPiece, check_range, prove_piece

ROOT = jobs.ROOT
TIMING = ("seconds", "vectors_per_second", "sim_cpu_seconds", "started", "finished")


def _pieces(name: str, n: int, size: int | None = None) -> list[ProofPiece]:
    params = preset("recip", name)
    space = FullSpace(params)
    return [ProofPiece(params, space, *shard_range(size or len(space), (i, n))) for i in range(1, n + 1)]


def _strip(records):
    return [{k: v for k, v in r.items() if k not in TIMING} for r in records]


def test_importing_the_model_and_the_runner_does_not_import_dask():
    code = ("import sys, fxmodel.pipeline.pixel, fxmodel.units.recip, rtl, cosim.stream, tools.jobs, tools.prove; "
            "assert not [m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')], 'dask imported'")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT,
                   env={**os.environ, "PYTHONPATH": str(ROOT)})


@given(st.integers(0, 2 ** 62), st.integers(1, 2 ** 62), st.fractions(Fraction(1, 10 ** 6), 4))
def test_within_screen_agrees_with_exact_integers(num, den, bound):
    near = int(bound * den)                  # the ratio at the bound, and a few codes either side
    nums = np.array([num, near, max(near - 1, 0), near + 1][: 4 if near < 2 ** 62 else 1], dtype=np.int64)
    dens = np.full(len(nums), den, dtype=np.int64)
    want = [Fraction(int(a), int(d)) <= bound for a, d in zip(nums, dens)]
    assert exact.within(nums, dens, bound).tolist() == want


def test_model_proof_is_exact_and_finds_a_wrong_table_word():
    params = preset("recip", "small")
    space = FullSpace(params)
    rec = check_range(params, space, 0, len(space), chunk=1 << 12)
    assert rec["ok"] and rec["vectors"] == 1 << 16 and rec["unfaithful"] == 0
    assert rec["max_error_ulp"] <= float(params.error_bound_ulp)
    codes = params.table_codes.copy()
    codes[5] += 3                                     # a wrong ROM word: the model now breaks its bound
    broken = params.with_table(codes)
    bad = check_range(broken, space, 0, len(space), bound=params.error_bound_ulp)
    assert not bad["ok"] and bad["mismatches"] > 0 and len(bad["first"]) == 8
    f = bad["first"][0]
    w = f["inputs"][0]
    num, den = exact.recip_error_ulp(np.array([w]), np.array([f["model"][0]]), np.array([f["model"][1]]),
                                     params.in_fmt.frac_bits, params.fo)
    assert Fraction(int(num[0]), int(den[0])) > params.error_bound_ulp


def test_resume_runs_only_the_missing_pieces(tmp_path):
    pieces = _pieces("small", 4)
    key = lambda p: jobs.content_key("recip", p.params, "exact", p.lo, p.hi)  # noqa: E731
    ran = []
    first = jobs.run_pieces(prove_piece, pieces, key=key, cache=tmp_path, progress=False,
                            callback=lambda i, r: ran.append(i))
    assert ran == [0, 1, 2, 3] and len(list(tmp_path.glob("*.json"))) == 4
    (tmp_path / f"{key(pieces[2])}.json").unlink()
    ran.clear()
    again = jobs.run_pieces(prove_piece, pieces, key=key, cache=tmp_path, progress=False,
                            callback=lambda i, r: ran.append(i))
    first = json.loads(json.dumps(first))
    assert ran == [2] and again[:2] == first[:2] and again[3] == first[3]          # loaded, timings and all
    assert _strip(again) == _strip(first)


def test_a_killed_worker_is_replaced_and_the_merged_result_equals_a_serial_run():
    """2 local workers; as the first piece comes back, the worker running another piece is killed (SIGKILL): its
    pieces are rescheduled, and every piece's record equals the serial run's."""
    pieces = _pieces("default", 8, 1 << 23)         # 2**23 inputs in 8 pieces of a fraction of a second
    serial = jobs.run_pieces(prove_piece, pieces, progress=False)
    killed = []
    with jobs.cluster(2) as client:
        pids = client.run(os.getpid)

        def kill(i, result):
            if killed:
                return
            busy = [w for w, keys in client.processing().items() if keys] or list(pids)
            os.kill(pids[busy[0]], signal.SIGKILL)
            killed.append(busy[0])

        dask = jobs.run_pieces(prove_piece, pieces, client=client, progress=False, callback=kill)
        after = client.run(os.getpid)
    assert killed and pids[killed[0]] not in after.values()
    assert all(r["ok"] for r in serial) and sum(r["vectors"] for r in dask) == 1 << 23
    assert _strip(dask) == _strip(serial)


def test_exhaustive_pieces_merge_to_the_whole_and_resume(tmp_path, monkeypatch):
    from tools import exhaustive

    monkeypatch.setattr(exhaustive, "CACHE", tmp_path)
    t = exhaustive.target("recip:small")
    whole = exhaustive.run_target(t, "exact")
    rec = exhaustive.run_dask(t, "exact", count=4, progress=False)
    assert rec["shards"] == 4 and rec["resumed"] == 0 and rec["vectors"] == whole["vectors"] == 1 << 16
    for k in ("ok", "mismatches", "max_error_ulp", "worst_index", "unfaithful", "range", "space", "first"):
        assert rec[k] == whole[k], k
    again = exhaustive.run_dask(t, "exact", count=4, progress=False)
    assert again["resumed"] == 4 and again["max_error_ulp"] == rec["max_error_ulp"]
    assert "within bound" in exhaustive.table([rec])


def test_a_partial_run_covers_the_selected_pieces_and_the_whole_run_resumes_from_them(tmp_path, monkeypatch):
    from tools import exhaustive

    monkeypatch.setattr(exhaustive, "CACHE", tmp_path)
    t = exhaustive.target("recip:small")
    part = exhaustive.run_dask(t, "exact", count=4, progress=False, select=(2, 3))
    assert part["pieces"] == [2, 3] and part["shards"] == 4 and part["range"] == [1 << 14, 3 << 14]
    assert part["vectors"] == 1 << 15 and part["fraction"] == 0.5 and part["ok"]
    assert "partial: pieces 2..3 of 4, 50.0 %" in exhaustive.table([part])
    whole = exhaustive.run_dask(t, "exact", count=4, progress=False)
    assert whole["resumed"] == 2 and whole["vectors"] == 1 << 16 and "pieces" not in whole
    with pytest.raises(ValueError, match="pieces 1..4"):
        exhaustive.run_dask(t, "exact", count=4, progress=False, select=(3, 5))
    assert bumpmap(["exhaustive", "--sim", "exact", "--only", "recip:small", "--select", "2"]) == 2


def test_exact_failures_name_the_input_the_output_and_the_bound():
    from tools import exhaustive

    rec = {"unit": "recip", "preset": "x", "simulator": "exact", "ok": False, "mismatches": 1, "valid_errors": 0,
           "missing": 0, "vectors": 4, "expected_vectors": 4,
           "first": [{"index": 3, "inputs": [7], "model": [1, 2, 0], "error_ulp": 1.25, "bound_ulp": 0.89}]}
    assert "index 3: inputs [7] model [1, 2, 0] error 1.250000 ulp > bound 0.890000" in exhaustive._failures([rec])


def _fails(piece):
    raise ValueError(f"piece {piece} is bad")


def test_a_failing_piece_is_retried_then_named(tmp_path):
    with pytest.raises(jobs.JobError, match=r"piece 7 failed after 2 retries: ValueError\('piece 7 is bad'\)"):
        jobs.run_pieces(_fails, [7], retries=2, progress=False, describe=lambda p: f"piece {p}")
    with pytest.raises(ValueError, match="both key and cache"):
        jobs.run_pieces(_fails, [1], cache=tmp_path)
