"""Model against exact math over a whole input space, in pieces: the model side of an exhaustive proof.

:func:`check_range` evaluates the bit-exact model (``params.compute``) on rows ``lo..hi`` of an input space and
measures every output against the exact rational result with :mod:`fxmodel.units.exact` (integer arithmetic, no
floating point in the decision). A row is a *violation* when its error exceeds the unit's documented bound
(:data:`ORACLES`). The record has the fields of a streaming co-simulation record (:mod:`tools.exhaustive`,
simulator ``exact``), so shards merge and report the same way, plus ``max_error_ulp``, ``worst_index``
``unfaithful`` (rows with an error of one ulp or more) and ``bound_ulp``.

Rows are evaluated :data:`CHUNK` at a time, so a piece of any size runs in bounded memory (about 0.5 GB).
The reciprocal: the paper, section 4.1; its bound: ``RecipParams.error_bound_ulp`` (``fxmodel/units/recip.py``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from fxmodel.units import exact

__all__ = ["ORACLES", "ProofPiece", "check_range", "prove_piece", "CHUNK"]

#: Rows evaluated at once.
CHUNK = 1 << 22
#: Violations recorded in full.
KEEP = 8


def _recip(params, inputs, outputs):
    """``(error in ulps as num/den, faithful)`` of reciprocal outputs."""
    num, den = exact.recip_error_ulp(inputs[:, 0], outputs[:, 0], outputs[:, 1], params.in_fmt.frac_bits, params.fo)
    return num, den, np.asarray(num) < np.asarray(den)


#: Unit name -> ``(oracle(params, inputs, outputs) -> (num, den, faithful), name of the documented bound)``.
ORACLES = {"recip": (_recip, "error_bound_ulp")}


def oracle(params):
    """The exact-math check of ``params``' unit; ``ValueError`` naming the unit if there is none."""
    if params.NAME not in ORACLES:
        raise ValueError(f"unit {params.NAME!r}: no exact-math oracle for a model proof (units with one: "
                         f"{', '.join(sorted(ORACLES))})")
    return ORACLES[params.NAME]


def check_range(params, space, lo: int, hi: int, *, chunk: int = CHUNK, keep: int = KEEP, bound=None) -> dict:
    """Model against exact math on rows ``lo..hi`` of ``space`` (a :class:`cosim.stream.Space`), against the
    unit's documented bound (or ``bound``, ulps)."""
    fn, bound_name = oracle(params)
    bound = getattr(params, bound_name) if bound is None else bound
    started, t0, c0 = time.time(), time.perf_counter(), time.process_time()
    bad = unfaithful = 0
    worst, worst_index, first = -1.0, None, []
    for a in range(lo, hi, chunk):
        b = min(a + chunk, hi)
        inputs = np.asarray(space.take(a, b), dtype=np.int64)
        outputs = params.compute(inputs)
        num, den, faithful = fn(params, inputs, outputs)
        ok = exact.within(num, den, bound)
        err = exact.as_float(num, den)
        k = int(np.argmax(err))
        if err[k] > worst:
            worst, worst_index = float(err[k]), a + k
        unfaithful += int(np.count_nonzero(~faithful))
        rows = np.flatnonzero(~ok)
        for r in rows[:max(0, keep - len(first))]:
            first.append({"index": a + int(r), "inputs": inputs[r].tolist(), "model": outputs[r].tolist(),
                          "error_ulp": float(err[r]), "bound_ulp": float(bound)})
        bad += len(rows)
    seconds = time.perf_counter() - t0
    n = hi - lo
    return {"unit": params.NAME, "simulator": "exact", "vectors": n, "expected_vectors": n, "mismatches": bad,
            "valid_errors": 0, "missing": 0, "ok": bad == 0, "first": first, "seconds": round(seconds, 3),
            "vectors_per_second": n / seconds if seconds else 0.0,
            "sim_cpu_seconds": round(time.process_time() - c0, 3),
            "build_seconds": 0.0, "space": space.describe(), "range": [lo, hi], "started": started,
            "finished": time.time(), "max_error_ulp": worst, "worst_index": worst_index, "unfaithful": unfaithful,
            "bound_ulp": float(bound)}


@dataclass(frozen=True)
class ProofPiece:
    """Rows ``lo..hi`` of ``space`` of the unit ``params`` (everything a worker needs)."""

    params: object
    space: object
    lo: int
    hi: int


def prove_piece(piece: ProofPiece) -> dict:
    """:func:`check_range` of a piece (the task :mod:`tools.jobs` runs)."""
    return check_range(piece.params, piece.space, piece.lo, piece.hi)
