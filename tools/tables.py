"""Correct bits of the reciprocal's table modes per table size and term count (paper section 4.1).

``bumpmap tables [--m 5 6 7 8 9] [--t 1 2 3 4] [--json FILE]`` prints two Markdown tables:

1. **Approximation bits** of the table and truncated series alone, for each :data:`~fxmodel.units.recip.TABLE_MODES`
   entry: ``-log2`` of the half-width of the exact error band ``[min, max]`` of ``T(B, d) - 1/x`` over every
   interval (:attr:`RecipParams.approx_error`, rigorous, from the actual table), with 40-bit table words so
   that the words' own rounding does not limit it. This is the error left once the free centring constant has
   shifted the band: a faithful ``p``-bit result needs well over ``p`` of these bits (the final rounding takes
   half an ulp). A float64 sample of the same error on 4097 points per interval (``sampled``) shows how tight the
   rigorous figure is.
2. **Faithful output width**: the largest ``p`` whose documented bound (:attr:`RecipParams.error_bound_ulp`,
   every datapath rounding included) is below one ulp, with ``b = p + 3`` table bits, ``guard = 4`` and a
   ``max(p + 2, m + 4)``-bit input: the word and datapath widths a designer would start from.

:func:`table_study` returns the rows for the design-space sweep.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.units.recip import TABLE_MODES, RecipParams
from host.atomic import atomic_json

__all__ = ["approx_params", "approx_bits", "sampled_bits", "faithful_width", "table_study", "markdown", "add_arguments",
           "run"]

#: Input width for the approximation study (``d`` ranges over a 2**-32 grid: effectively continuous).
STUDY_N = 32


def approx_params(m: int, t: int, mode: str) -> RecipParams:
    """Parameters isolating the table and series: 40-bit words, a 32-bit input (datapath widths irrelevant)."""
    return RecipParams(in_fmt=Fmt(True, 2, STUDY_N - 2), m=m, b=40, t=t, p=12, guard=0, table=mode)


def approx_bits(m: int, t: int, mode: str) -> float:
    """Rigorous correct bits of the table and series (:attr:`RecipParams.approx_bits`)."""
    return approx_params(m, t, mode).approx_bits


def sampled_bits(params: RecipParams, points: int = 4097) -> float:
    """The same figure from a float64 sample of ``T(B, d) - 1/(c - d)`` (a check on the rigorous one)."""
    c = np.array(params.centers, dtype=np.float64) / 2.0 ** params.n
    B = params.table_codes.astype(np.float64) / 2.0 ** (params.b - 1)
    d = np.linspace(float(params.d_range[0]), float(params.d_range[1]), points)
    err = params.series(B[:, None], d[None, :]) - 1.0 / (c[:, None] - d[None, :])
    return -math.log2((err.max() - err.min()) / 2)


def _faithful_params(m: int, t: int, mode: str, p: int, guard: int, extra_b: int) -> RecipParams | None:
    n = max(p + 2, m + 4)
    try:
        return RecipParams(in_fmt=Fmt(True, 2, n - 2), m=m, b=p + extra_b, t=t, p=p, guard=guard, table=mode)
    except ValueError:
        return None


def faithful_width(m: int, t: int, mode: str, p_max: int = 30, guard: int = 4, extra_b: int = 3) -> int | None:
    """Largest ``p <= p_max`` with ``error_bound_ulp < 1`` for ``b = p + extra_b``, ``guard`` and an input of
    ``max(p + 2, m + 4)`` bits; ``None`` if the narrowest valid ``p`` is not faithful. The bound in ulps grows
    with ``p`` (the approximation error does not shrink with it), so a bisection finds the boundary."""
    def ok(p):
        params = _faithful_params(m, t, mode, p, guard, extra_b)
        return params is not None and params.error_bound_ulp < 1

    lo = next((p for p in range(2, p_max + 1) if _faithful_params(m, t, mode, p, guard, extra_b)), None)
    if lo is None or not ok(lo):
        return None
    if ok(p_max):
        return p_max
    hi = p_max                                 # ok(lo), not ok(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def table_study(ms=(5, 6, 7, 8, 9), ts=(1, 2, 3, 4), modes=TABLE_MODES, faithful: bool = True) -> list[dict]:
    """One row per ``(t, m)``: entries, and per mode the rigorous and sampled approximation bits and (if
    ``faithful``) the faithful output width."""
    rows = []
    for t in ts:
        for m in ms:
            row = {"t": t, "m": m, "entries": 1 << (m - 1), "modes": {}}
            for mode in modes:
                params = approx_params(m, t, mode)
                entry = {"approx_bits": round(params.approx_bits, 2), "sampled_bits": round(sampled_bits(params), 2)}
                if faithful:
                    entry["faithful_p"] = faithful_width(m, t, mode)
                row["modes"][mode] = entry
            rows.append(row)
    return rows


def markdown(rows) -> str:
    modes = list(rows[0]["modes"])
    out = ["Correct bits of table and series (rigorous; float64 sample in brackets), 40-bit words:", "",
           "| t | entries | " + " | ".join(modes) + " |", "|---:|---:|" + "---:|" * len(modes)]
    for r in rows:
        cells = [f"{r['modes'][k]['approx_bits']:.2f} ({r['modes'][k]['sampled_bits']:.2f})" for k in modes]
        out.append(f"| {r['t']} | {r['entries']} | " + " | ".join(cells) + " |")
    if "faithful_p" in rows[0]["modes"][modes[0]]:
        out += ["", "Largest faithful output width p (up to 30) by the documented bound (b = p + 3, guard = 4, "
                "input of max(p + 2, m + 4) bits):",
                "", "| t | entries | " + " | ".join(modes) + " |", "|---:|---:|" + "---:|" * len(modes)]
        for r in rows:
            cells = [str(r["modes"][k]["faithful_p"] or "-") for k in modes]
            out.append(f"| {r['t']} | {r['entries']} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap tables``, :mod:`tools.main`)."""
    ap.add_argument("--m", type=int, nargs="+", default=[5, 6, 7, 8, 9], help="index bits (2**(m-1) entries)")
    ap.add_argument("--t", type=int, nargs="+", default=[1, 2, 3, 4], help="Taylor terms")
    ap.add_argument("--no-faithful", action="store_true", help="skip the faithful-width search (faster)")
    ap.add_argument("--json", help="also write the rows to this file")


def run(args: argparse.Namespace) -> int:
    try:
        rows = table_study(args.m, args.t, faithful=not args.no_faithful)
    except ValueError as exc:
        print(f"error: {exc}")
        return 2
    print(markdown(rows))
    if args.json:
        atomic_json(args.json, rows)
    return 0
