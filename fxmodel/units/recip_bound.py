r"""The reciprocal's documented error bound, proved from the actual table with exact fractions (paper, section
4.1: the table and Taylor series of the division; the series' sign, fixed in :mod:`fxmodel.units.recip`).

:class:`fxmodel.units.recip.RecipParams` holds the datapath and uses these functions for its ``bias_code`` (the
centring constant), ``error_terms`` and ``error_bound_ulp``; :func:`approx_error` is also the table study of
``bumpmap tables``. Symbols as in :mod:`fxmodel.units.recip`'s docstring; every function takes the
reciprocal's parameter object ``P`` (a :class:`fxmodel.units.recip.RecipParams`, not imported here: the bound sits
below the unit that uses it).

Error bound (``RecipParams.error_bound_ulp``), in ulps of the result (``2**-(p-1)`` of the mantissa)
---------------------------------------------------------------------------------------------------
``round`` mode (the shipped ``default`` and ``small`` presets; their bias and results predate the other modes).
For interval ``i`` with ``B0 = 1/w_h``, table error ``eps = B - B0``, ``delta = 2**-m - 2**-n`` (largest ``d``):

* Taylor truncation, in ``[-tau_i, 0]``, ``tau_i = (delta/w_h)**t / (w_h - delta)`` (worst at ``d = delta``);
* table rounding, ``eps * dT/dB`` with ``1 <= dT/dB <= S = sum_k (k+1) (Bmax delta)**k``: in ``[0, eps S]`` if
  ``eps >= 0``, else in ``[-|eps| S, 0]``;
* datapath truncations, all downward (every operand is non-negative): ``d`` loses ``< 2**-fd`` (weight
  ``Bmax**2 S1``), ``q`` loses ``< 2**-fq`` (weight ``Bmax S1``), each of the ``t - 2`` Horner steps loses
  ``< 2**-fq`` (weight ``Bmax S0``), with ``S1 = sum_(k=1)^(t-1) k Q**(k-1)``, ``S0 = sum_(j=0)^(t-3) Q**j``,
  ``Q = Bmax delta``;
* final half-up rounding, in ``(-1/2, 1/2]`` ulp.

The bound is the largest magnitude of the sum of the lower (resp. upper) ends over all intervals. All terms are
computed exactly with fractions from the actual table, so the bound also holds for tables not made by rounding.

Other modes (general form, :func:`entry_error`, :func:`datapath_error`). The table and
series error ``E(d) = T(B, d) - 1/(c - d)`` of each interval is bounded as a whole (the ``round`` form above
would count ``eps`` and ``tau`` separately, which is loose by ``|eps|`` once ``B`` is chosen to centre them):
``E = f1 + f2`` with ``f1 = T(B, d) - T(B0, d)`` and ``f2 = T(B0, d) - 1/(c - d)``, each monotone on each side
of ``d = 0`` (``f1``'s monotonicity for ``d < 0`` is checked exactly, with a cruder bound as fallback), so on
each of a few pieces of the interval ``min f1 + min f2 <= E <= max f1 + max f2`` with all four ends evaluated
exactly. The datapath terms keep their weights with ``Q = Bmax max|d| + 2**-fq``; with a signed ``d`` three
of them can point upward: ``B`` truncated to ``bq`` bits raises ``Bh d`` and ``Bh g`` where ``d, g < 0``
(``<= e_bh |d_lo|`` and ``<= e_bh gmax``), and a Horner floor carried by an odd power of a negative ``q`` flips
sign. Every other truncation floors a quantity whose effect on the result has a positive weight
(``dT/dd = B**2 G'(B d)``, ``G'(u) = 1 + 2u + 3u**2 > 0``), so it stays downward.
"""

from __future__ import annotations

from fractions import Fraction

__all__ = ["raw_error", "entry_error", "approx_error", "datapath_error"]


def raw_error(P) -> tuple[Fraction, Fraction]:
    """``(L, H)``: the exact sum ``B + B g`` (before bias and final rounding) minus ``1/x`` lies in
    ``[L, H]`` for every input; see the module docstring for each term."""
    if P.table != "round":
        lo, hi = P.approx_error                       # cached on the parameter object
        down, up = datapath_error(P)
        return lo - down, hi + up
    n, m, t = P.n, P.m, P.t
    delta = Fraction(1, 1 << m) - Fraction(1, 1 << n)
    bmax = max(Fraction(int(c), 1 << (P.b - 1)) for c in P.table_codes)
    Q = bmax * delta
    S = sum((k + 1) * Q ** k for k in range(t))
    datapath = Fraction(0)
    if t >= 2:
        S1 = sum(k * Q ** (k - 1) for k in range(1, t))
        S0 = sum(Q ** j for j in range(t - 2))
        gmax = sum(Q ** k for k in range(1, t))
        e_bh = Fraction(1, 1 << (P.bq - 1)) if P.bq < P.b else Fraction(0)
        e_d = Fraction(1, 1 << P.fd) if P.fd < n else Fraction(0)
        ulp_q = Fraction(1, 1 << P.fq)
        e_q = (ulp_q if P.bq - 1 + P.fd > P.fq else 0) + e_bh * delta
        e_bg = (ulp_q if P.bq - 1 > 0 else 0) + e_bh * gmax
        datapath = e_d * bmax * bmax * S1 + e_q * bmax * S1 + ulp_q * bmax * S0 + e_bg
    lo_worst, hi_worst = Fraction(0), Fraction(0)
    for i, c in enumerate(P.table_codes):
        wh = Fraction(((1 << (m - 1)) + i + 1) * (1 << (n - m)) - 1, 1 << n)
        eps = Fraction(int(c), 1 << (P.b - 1)) - 1 / wh
        tau = (delta / wh) ** t / (wh - delta)
        lo_worst = min(lo_worst, -tau - (abs(eps) * S if eps < 0 else 0) - datapath)
        hi_worst = max(hi_worst, eps * S if eps > 0 else Fraction(0))
    return lo_worst, hi_worst


def entry_error(P, center: int, code: int, pieces: int = 4,
                splits: int = 64) -> tuple[Fraction, Fraction]:
    """Rigorous ``(min, max)`` of ``E(d) = T(B, d) - 1/(c - d)`` over ``d`` in :attr:`d_range`, exactly.

    ``E = f1 + f2`` with ``f1 = T(B, d) - T(B0, d)`` (``B0 = 1/c``; coefficients ``B**(k+1) - B0**(k+1)``,
    all of the sign of ``B - B0``) and ``f2 = T(B0, d) - 1/(c - d) = -B0 (B0 d)**t / (1 - B0 d)``. ``f2`` is
    monotone on each side of ``d = 0`` (its derivative has the sign of ``d**(t-1)`` as ``B0 d < 1``); ``f1`` is
    monotone for ``d >= 0`` and, for ``d < 0``, when ``|a1| > sum_(k>=2) k |a_k| |d|**(k-1)`` (checked; else
    it is bounded by ``|a0| + sum |a_k| |d|**k``). On a piece ``[u, v]`` where both are monotone,
    ``min f1 + min f2 <= E <= max f1 + max f2`` with the four ends evaluated exactly. Each side starts as
    ``pieces`` equal pieces; up to ``splits`` times, the piece with the worst end bound is halved while that
    bound exceeds the largest (resp. smallest) ``E`` evaluated so far by more than 1/256 of the band.
    """
    import heapq

    t = P.t
    c = Fraction(center, 1 << P.n)
    B = Fraction(code, 1 << (P.b - 1))
    B0 = 1 / c
    a = [B ** (k + 1) - B0 ** (k + 1) for k in range(t)]
    lo, hi = P.d_range
    neg_monotone = t < 2 or abs(a[1]) > sum(k * abs(a[k]) * (-lo) ** (k - 1) for k in range(2, t))
    memo = {}

    def at(d):
        """``(f1(d), f2(d))``, exact."""
        if d not in memo:
            acc = Fraction(0)
            for coef in reversed(a):
                acc = acc * d + coef
            memo[d] = acc, -B0 * (B0 * d) ** t / (1 - B0 * d)
        return memo[d]

    def bounds(u, v):
        (f1u, f2u), (f1v, f2v) = at(u), at(v)
        if u >= 0 or neg_monotone:
            F1 = (min(f1u, f1v), max(f1u, f1v))
        else:
            r = sum(abs(a[k]) * max(-u, abs(v)) ** k for k in range(1, t))
            F1 = (a[0] - r, a[0] + r)
        return F1[0] + min(f2u, f2v), F1[1] + max(f2u, f2v)

    sides = [(lo, Fraction(0)), (Fraction(0), hi)] if lo < 0 < hi else [(lo, hi)]
    segs = [(u0 + (v0 - u0) * j / pieces, u0 + (v0 - u0) * (j + 1) / pieces)
            for u0, v0 in sides for j in range(pieces)]
    result = []
    for sign in (1, -1):                       # the upper end, then the lower end (as a max of -E)
        heap = []
        for u, v in segs:
            e_lo, e_hi = bounds(u, v)
            heapq.heappush(heap, (-(e_hi if sign > 0 else -e_lo), u, v))
        for _ in range(splits):
            known = [sign * (f1 + f2) for f1, f2 in memo.values()]
            band = max(known) - min(known)
            worst, u, v = heap[0]
            if -worst - max(known) <= band / 256:
                break
            heapq.heappop(heap)
            mid = (u + v) / 2
            for uu, vv in ((u, mid), (mid, v)):
                e_lo, e_hi = bounds(uu, vv)
                heapq.heappush(heap, (-(e_hi if sign > 0 else -e_lo), uu, vv))
        result.append(sign * -heap[0][0])
    return result[1], result[0]


def approx_error(P) -> tuple[Fraction, Fraction]:
    """Rigorous ``(min, max)`` over all intervals of the approximation error ``T(B, d) - 1/x`` of the table
    and the truncated series alone (exact ``d``, no datapath rounding, no bias), from the actual table."""
    ranges = [entry_error(P, c, int(code)) for c, code in zip(P.centers, P.table_codes)]
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def datapath_error(P) -> tuple[Fraction, Fraction]:
    """``(down, up)`` >= 0: the datapath's truncations move ``B + B g`` by at most ``down`` below and ``up``
    above the exact ``T(B, d)`` (module docstring, "Error bound", general form)."""
    t = P.t
    if t < 2:
        return Fraction(0), Fraction(0)
    dlo, dhi = P.d_range
    D, Dneg = max(-dlo, dhi), -dlo
    bmax = max(Fraction(int(c), 1 << (P.b - 1)) for c in P.table_codes)
    ulp_q = Fraction(1, 1 << P.fq)
    Q = bmax * D + ulp_q                                   # bounds |q| (the floor may add an ulp below)
    S1 = sum(k * Q ** (k - 1) for k in range(1, t))        # bounds dG/dq, G(q) = q + ... + q**(t-1); > 0
    S0 = sum(Q ** j for j in range(t - 2))                 # Horner floors, carried by q**j
    S0_odd = sum(Q ** j for j in range(1, t - 2, 2))       # ... those whose sign flips when q < 0
    gmax = sum(Q ** k for k in range(1, t)) + S0 * ulp_q  # bounds |g|
    e_bh = Fraction(1, 1 << (P.bq - 1)) if P.bq < P.b else Fraction(0)
    e_d = Fraction(1, 1 << P.fd) if P.fd < P.n else Fraction(0)
    q_floor = ulp_q if P.bq - 1 + P.fd > P.fq else Fraction(0)
    bg_floor = ulp_q if P.bq - 1 > 0 else Fraction(0)
    down = (e_d * bmax * bmax * S1 + (q_floor + e_bh * dhi) * bmax * S1 + ulp_q * bmax * S0
            + bg_floor + e_bh * gmax)
    up = Fraction(0)
    if Dneg > 0:      # B truncated to Bh raises Bh d and Bh g where d, g < 0; Horner floors flip with q < 0
        up = e_bh * Dneg * bmax * S1 + ulp_q * bmax * S0_odd + e_bh * gmax
    return down, up
