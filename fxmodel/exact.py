"""Exact error measurement of unit outputs against true rational results, from the codes alone.

Nothing here calls the unit's algorithm: each function takes input codes and the output codes some
implementation produced (the model, the RTL, anything) and measures them against exact math, with integer
arithmetic only (``int64`` where the magnitudes provably fit, exact Python integers otherwise). The tests, the
``errors`` CLI command and the benchmark all use it, so a figure quoted anywhere comes from one definition.

Errors are returned as exact ratios ``num / den`` of integers, so a bound check such as "faithful"
(``num < den``) involves no floating point at all.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = ["recip_error_ulp", "divide_error", "recip_monotone", "as_float", "within"]


def _ints(a, big: bool):
    return np.asarray(a, dtype=object) if big else np.asarray(a, dtype=np.int64)


def _bitlen(x, big: bool):
    if big:
        return np.array([int(v).bit_length() for v in x], dtype=np.int64)
    return np.frexp(np.asarray(x, dtype=np.float64))[1].astype(np.int64)   # exact below 2**53


def recip_error_ulp(w, mant, exp, in_frac: int, mant_frac: int):
    """Error of ``mant * 2**(exp - mant_frac)`` against ``1/w`` (``w = W * 2**-in_frac``) in ulps.

    The ulp is that of the *exact* result's binade: for ``1/|w|`` in ``[2**e, 2**(e+1))`` it is
    ``2**(e - mant_frac)``. Returns ``(num, den)`` with ``|error| = num / den`` ulps; rows with ``w = 0`` give
    ``(0, 1)`` (the unit flags them instead).
    """
    W = np.asarray(w, dtype=np.int64)
    Wa = np.abs(W)
    big = int(Wa.max(initial=1)).bit_length() + mant_frac + 4 > 62
    Wa = _ints(Wa, big)
    M = _ints(mant, big)
    E = _ints(exp, big)
    sgn = _ints(np.sign(W), big)
    k = _bitlen(np.abs(W), big) - 1                              # |W| in [2**k, 2**(k+1))
    pow2 = np.abs(W) == (np.int64(1) << np.maximum(k, 0))
    ebin = in_frac - k - 1 + pow2.astype(np.int64)                # binade of the exact 1/|w|
    sh = np.asarray(E, dtype=np.int64) - ebin
    up = np.maximum(sh, 0)
    down = np.maximum(-sh, 0)
    one = _ints(np.ones_like(W), big)
    target = one << _ints(in_frac + mant_frac - ebin + down, big)  # 2**(F+fo-e) / W, scaled by |W| and 2**down
    num = np.abs(M * Wa * (one << _ints(up, big)) - sgn * target)
    den = Wa * (one << _ints(down, big))
    zero = W == 0
    num = np.where(zero, 0, num)
    den = np.where(zero, 1, den)
    return num, den


def divide_error(n, d, q, num_frac: int, den_frac: int, out_frac: int):
    """Absolute error ``|q * 2**-out_frac - n/d|`` (real units) as ``(num, den)``; rows with ``d = 0`` give 0."""
    N = np.asarray(n, dtype=object)
    D = np.asarray(d, dtype=object)
    Q = np.asarray(q, dtype=object)
    Da = np.abs(D)
    sgn = np.sign(np.asarray(d, dtype=np.int64)).astype(object)
    num = np.abs(Q * Da * (1 << num_frac) - sgn * N * (1 << (den_frac + out_frac)))
    den = np.where(np.asarray(d) == 0, 1, Da * (1 << (out_frac + num_frac)))
    num = np.where(np.asarray(d) == 0, 0, num)
    return num, den


def as_float(num, den) -> np.ndarray:
    """Error ratios as float64 (for reporting only)."""
    num = np.asarray(num)
    den = np.asarray(den)
    if num.dtype == object or den.dtype == object:
        return np.array([float(Fraction(int(a), int(b))) for a, b in zip(num, den)])
    return num / den


def within(num, den, bound: Fraction) -> np.ndarray:
    """Exact test ``num / den <= bound`` for each row."""
    bound = Fraction(bound)
    num = np.asarray(num, dtype=object)
    den = np.asarray(den, dtype=object)
    return np.asarray(num * bound.denominator <= den * bound.numerator, dtype=bool)


def recip_monotone(w, mant, exp) -> dict:
    """Is ``mant * 2**exp`` monotone non-increasing in ``w`` on each sign? ``w`` must be sorted ascending.

    Returns ``{"monotone": bool, "violations": int, "first": w of the first violation or None}``; a violation is a
    pair of neighbouring non-zero inputs of the same sign where the larger ``w`` has the larger ``1/w``.
    """
    W = np.asarray(w, dtype=np.int64)
    M = np.asarray(mant, dtype=np.int64)
    E = np.asarray(exp, dtype=np.int64)
    same = (np.sign(W[:-1]) == np.sign(W[1:])) & (W[:-1] != 0)
    e0 = np.minimum(E[:-1], E[1:])
    a = M[:-1] << (E[:-1] - e0)
    b = M[1:] << (E[1:] - e0)
    bad = same & (b > a)
    count = int(bad.sum())
    return {"monotone": count == 0, "violations": count,
            "first": int(W[:-1][bad][0]) if count else None}


# -- per-unit measurement used by the CLI (`python -m fxmodel errors`) and the benchmark -----------------------

def measure_recip(params, w, out) -> dict:
    """Worst and mean error in ulps (exact ratio for the worst) and faithfulness of recip outputs."""
    num, den = recip_error_ulp(w, out[:, 0], out[:, 1], params.in_fmt.frac_bits, params.fo)
    err = as_float(num, den)
    worst = int(np.argmax(err))
    return {"vectors": int(len(w)), "max_error_ulp": float(err[worst]), "mean_error_ulp": float(err.mean()),
            "worst_input_code": int(w[worst]), "faithful": bool(np.all(np.asarray(num) < np.asarray(den))),
            "within_bound": bool(np.all(within(num, den, params.error_bound_ulp))),
            "bound_ulp": float(params.error_bound_ulp)}


def measure_divide(params, nd, out) -> dict:
    """Worst and mean absolute error of unsaturated divide outputs with ``|n/d| <= quotient_limit``."""
    n, d = nd[:, 0], nd[:, 1]
    rf, nf = params.recip.in_fmt, params.num_fmt
    # |n/d| <= limit  <=>  |N| * 2**Fd <= limit * |D| * 2**Fn  (exact integers)
    keep = (d != 0) & (out[:, 2] == 0) & (np.abs(n).astype(object) * (1 << rf.frac_bits)
                                          <= params.quotient_limit * np.abs(d).astype(object) * (1 << nf.frac_bits))
    num, den = divide_error(n[keep], d[keep], out[keep, 0], nf.frac_bits, rf.frac_bits, params.out_fmt.frac_bits)
    err = as_float(num, den)
    worst = int(np.argmax(err)) if err.size else 0
    return {"vectors": int(keep.sum()), "max_error": float(err.max(initial=0)),
            "mean_error": float(err.mean()) if err.size else 0.0,
            "max_error_ulp": float(err.max(initial=0) * (1 << params.out_fmt.frac_bits)),
            "worst_input_codes": [int(n[keep][worst]), int(d[keep][worst])] if err.size else None,
            "within_bound": bool(np.all(within(num, den, params.max_error))),
            "bound": float(params.max_error)}


MEASURES = {"recip": measure_recip, "divide": measure_divide}
