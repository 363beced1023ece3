"""Choosing the reciprocal's table words by minimax (:class:`fxmodel.units.recip.RecipParams`, table modes
``minimax`` and ``midpoint-minimax``; paper, section 4.1, improved as the module docstring of
:mod:`fxmodel.units.recip` explains).
"""

from __future__ import annotations

import numpy as np

__all__ = ["minimax_codes"]


def minimax_codes(params) -> list[int]:
    """Per interval, the ``b``-bit word minimising the worst ``|T(B, d) - 1/(c - d)|`` over the interval.

    Only the *choice* uses float64 (on 1025 points of each interval: the error is smooth, about ``2**-52``
    float error against errors above ``2**-40``); the documented bound is then computed exactly from the
    chosen words. Both ends of the error rise with ``B``, so bisection finds the real ``B`` that centres the
    error; the best of the four codes around it is kept.
    """
    fb = params.b - 1
    c = np.array(params.centers, dtype=np.float64) / 2.0 ** params.n          # exact: at most 48 bits
    d = np.linspace(float(params.d_range[0]), float(params.d_range[1]), 1025)
    inv = 1.0 / (c[:, None] - d[None, :])

    def err(B):
        return params.series(B[:, None], d[None, :]) - inv

    B0 = 1.0 / c
    span = 4 * np.abs(err(B0)).max(axis=1) + 2.0 ** -fb
    lo, hi = B0 - span, B0 + span
    for _ in range(100):
        mid = (lo + hi) / 2
        e = err(mid)
        up = e.max(axis=1) + e.min(axis=1) > 0
        hi, lo = np.where(up, mid, hi), np.where(up, lo, mid)
    base = np.floor(lo * 2.0 ** fb)
    cands = base[:, None] + np.arange(-1, 3)[None, :]
    worst = np.stack([np.abs(err(cands[:, j] / 2.0 ** fb)).max(axis=1) for j in range(cands.shape[1])], 1)
    return [int(v) for v in cands[np.arange(len(c)), np.argmin(worst, axis=1)]]
