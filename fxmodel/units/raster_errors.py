"""Measurement of the scan converter's interpolation error: the error proof of :mod:`fxmodel.units.raster` checked
against exact planes on the longest spans (:func:`measure`; ``bumpmap`` runs it for the design-space sweeps).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .raster import RasterParams, area2, edge_setup, scan, setup

__all__ = ["measure"]


def measure(params: RasterParams, triangles: int = 4, seed: int = 1) -> dict:
    """Worst distance from the exact plane, in output ulps, over triangles spanning the whole ``max_size`` square
    viewport (spans and columns of ``max_size`` pixels, random vertex values within each format): the accumulator
    before the output rounding (the interpolators' own error, bound ``(2 max_size - 1) 2**-(g+1)`` ulps) and the
    output code. The error of the accumulator is linear along a row, so its extremes lie at the span ends: every
    row's first and last pixel is measured exactly (rationals), plus a random sample of interior pixels."""
    rng = np.random.default_rng(seed)
    n, S = params.max_size, params.S
    worst_acc = {name: Fraction(0) for name in params.names}
    worst_out = dict(worst_acc)
    pixels = 0
    for k in range(triangles):
        X = np.array([-S // 2 - int(rng.integers(0, S)), n * S + int(rng.integers(0, S)), int(rng.integers(-S, S))])
        Y = np.array([int(rng.integers(-S, S)), int(rng.integers(-S, S)), n * S + int(rng.integers(0, S))])
        if k % 2:
            X = n * S - X
        vals = {name: rng.uniform(-0.95, 0.95, 3) * float(fmt.max_value) for name, fmt in params.attrs}
        consts = {m: np.array([f.max_code]) for m, f in params.consts}       # carried, not interpolated
        recs = setup(params, X[None], Y[None], {m: v[None] for m, v in vals.items()} | consts, n, n)
        res = scan(params, recs)
        pixels += len(res)
        y, x = res.codes["y"], res.codes["x"]
        ends = np.flatnonzero(np.r_[True, y[1:] != y[:-1]] | np.r_[y[1:] != y[:-1], True])
        pick = np.unique(np.r_[ends, rng.integers(0, len(res), 500)])
        a2 = int(area2(X, Y))
        order = [0, 1, 2] if a2 > 0 else [0, 2, 1]
        A, B, C, _ = (v.tolist() for v in edge_setup(X[order], Y[order]))
        for name, fmt in params.attrs:
            v = [Fraction(float(t)) for t in vals[name][order]]
            gx = sum(v[e] * A[e] for e in range(3)) * S / abs(a2)
            gy = sum(v[e] * B[e] for e in range(3)) * S / abs(a2)
            g0 = sum(v[e] * (A[e] * S // 2 + B[e] * S // 2 + C[e]) for e in range(3)) / abs(a2)
            acc_ulp, out_ulp = params.acc_fmt(name).ulp, fmt.ulp
            for i in pick.tolist():
                exact = g0 + gx * int(x[i]) + gy * int(y[i])
                worst_acc[name] = max(worst_acc[name], abs(int(res.acc[name][i]) * acc_ulp - exact) / out_ulp)
                worst_out[name] = max(worst_out[name], abs(int(res.codes[name][i]) * out_ulp - exact) / out_ulp)
    bound_acc = Fraction(2 * n - 1, 1 << (params.guard_bits + 1))
    return {"max_size": n, "guard_bits": params.guard_bits, "triangles": triangles, "seed": seed,
            "fragments": pixels,
            "accumulator_worst_ulp": max(float(w) for w in worst_acc.values()),
            "accumulator_bound_ulp": float(bound_acc),
            "output_worst_ulp": max(float(w) for w in worst_out.values()),
            "output_bound_ulp": float(bound_acc + Fraction(1, 2)),
            "per_attribute_accumulator_worst_ulp": {m: round(float(w), 5) for m, w in worst_acc.items()}}
