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

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding

__all__ = ["round_exact", "narrow_exact", "recip_error_ulp", "divide_error", "wrapped_error", "bump_error",
           "recip_monotone", "as_float", "within"]


def round_exact(x, rounding: Rounding) -> int:
    """The rational ``x`` (an ``int`` or a :class:`~fractions.Fraction`) rounded to an integer by ``rounding``.

    The oracle of :func:`fxmodel.core.rounding.shift_round` and :func:`~fxmodel.core.rounding.quantize`, written from
    the definitions (floor; nearest with ties up; nearest with ties to the even integer), with no shift or mask.
    """
    x = Fraction(x)
    q, r = divmod(x.numerator, x.denominator)        # x = q + r / den, 0 <= r < den
    if rounding is Rounding.TRUNC or r == 0:
        return q
    if rounding is Rounding.HALF_UP:
        return q + (2 * r >= x.denominator)
    return q + (2 * r > x.denominator or (2 * r == x.denominator and q % 2 == 1))


def narrow_exact(x: int, from_frac: int, fmt: Fmt, rounding: Rounding, overflow: Overflow):
    """The oracle of :func:`fxmodel.core.rounding.narrow` for one code: ``(code, flag, fits)``.

    ``fits`` says whether the rounded value lies in ``fmt``'s range. Out of range, ``SATURATE`` clamps and flags;
    ``PROVEN`` keeps the low ``fmt.width`` bits, which is what the RTL does (the model raises instead).
    """
    y = round_exact(Fraction(x) / Fraction(2) ** (from_frac - fmt.frac_bits), rounding)
    fits = fmt.min_code <= y <= fmt.max_code
    if overflow is Overflow.SATURATE:
        return min(max(y, fmt.min_code), fmt.max_code), not fits, fits
    low = y & ((1 << fmt.width) - 1)
    return (low - (1 << fmt.width) if fmt.signed and low >> (fmt.width - 1) else low), False, fits


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


def wrapped_error(n, d, c, num_frac: int, den_frac: int, out_frac: int):
    """Distance on the unit circle between ``c * 2**-out_frac`` and the exact ``n / d`` (codes ``n``, ``d`` with
    ``num_frac``, ``den_frac`` fraction bits), modulo 1: the perspective unit's repeat-wrapped coordinate error.

    Returns ``(num, den)`` with distance ``num / den`` in ``[0, 1/2]``; rows with ``d = 0`` give ``(0, 1)``.
    With ``P = |d| 2**(out_frac + num_frac)`` (one whole repeat), ``(c 2**-out_frac - n/d) P`` is the integer
    ``c |d| 2**num_frac - sign(d) n 2**(den_frac + out_frac)``, reduced modulo ``P`` and folded to the nearer side.
    """
    N, D, C = (np.asarray(a, dtype=np.int64) for a in (n, d, c))
    bits = max(int(np.abs(D).max(initial=1)).bit_length() + out_frac + num_frac,
               int(np.abs(N).max(initial=1)).bit_length() + den_frac + out_frac) + 2
    big = bits > 62
    sgn = _ints(np.sign(D), big)
    Da = _ints(np.where(D == 0, 1, np.abs(D)), big)
    one = _ints(np.ones_like(D), big)
    period = Da * (one << (out_frac + num_frac))
    x = (_ints(C, big) * Da * (one << num_frac) - sgn * _ints(N, big) * (one << (den_frac + out_frac))) % period
    num = np.minimum(x, period - x)
    zero = D == 0
    return np.where(zero, 0, num), np.where(zero, 1, period)


def bump_error(N, du, dv, A0, A1, out, n_frac: int, d_frac: int, a_frac: int, out_frac: int, e=None):
    """``|out - (N 2**-e + du A0 + dv A1)|`` per component (real units) as ``(num, den)``, ``num`` of shape
    ``(K, 3)``: every term aligned to ``F = max(n_frac + max(e), d_frac + a_frac, out_frac)`` fraction bits,
    ``den = 2**F``. ``e``: the block exponents (``(K,)``, default 0)."""
    e = np.zeros(len(N), dtype=np.int64) if e is None else np.asarray(e, dtype=np.int64)
    F = max(n_frac + int(e.max(initial=0)), d_frac + a_frac, out_frac)
    N, A0, A1, out = (np.asarray(a, dtype=object) for a in (N, A0, A1, out))
    du = np.asarray(du, dtype=object)[:, None]
    dv = np.asarray(dv, dtype=object)[:, None]
    nscale = np.array([1 << (F - n_frac - int(k)) for k in e], dtype=object)[:, None]
    exact = N * nscale + (du * A0 + dv * A1) * (1 << (F - d_frac - a_frac))
    return np.abs(out * (1 << (F - out_frac)) - exact), 1 << F


def as_float(num, den) -> np.ndarray:
    """Error ratios as float64 (for reporting only)."""
    num = np.asarray(num)
    den = np.asarray(den)
    if num.dtype == object or den.dtype == object:
        # Python int / int is correctly rounded, like float(Fraction(a, b)), and ~20x faster
        return np.asarray(num.astype(object) / den.astype(object), dtype=np.float64)
    return num / den


#: Relative margin of :func:`within`'s float screen (the float ratio is within ``2**-51`` of the exact one).
_SCREEN = 2.0 ** -40


def within(num, den, bound: Fraction) -> np.ndarray:
    """Exact test ``num / den <= bound`` for each row (``num >= 0``, ``den > 0``).

    ``int64`` ratios are screened in float64 first: ``float(num) / float(den)`` is within a relative ``2**-51`` of
    the exact ratio (three roundings of ``2**-53``), so a row whose float ratio is more than a relative
    :data:`_SCREEN` below (above) ``float(bound)`` is inside (outside) for certain; only the rows in between are
    decided with exact integers. Object (big-integer) ratios are always decided exactly.
    """
    bound = Fraction(bound)
    num, den = np.asarray(num), np.asarray(den)

    def exact(n, d):
        return np.asarray(np.asarray(n, dtype=object) * bound.denominator
                          <= np.asarray(d, dtype=object) * bound.numerator, dtype=bool)

    if num.dtype == object or den.dtype == object:
        return exact(num, den)
    ratio = num / den
    b = float(bound)
    inside = ratio <= b * (1 - _SCREEN)
    unsure = ~inside & (ratio < b * (1 + _SCREEN))
    if unsure.any():
        inside[unsure] = exact(num[unsure], den[unsure])
    return inside


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


# -- per-unit measurement used by the CLI (`bumpmap errors`) and the benchmark -----------------------

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


def measure_persp(params, rows, out, s_abs: int = 16) -> dict:
    """Worst and mean wrapped error of ``s`` and ``t`` (and ``sc``, ``tc``) against the exact ``U/W`` for the
    rows with ``W != 0`` and every ``|U/W| <= s_abs`` (the domain of :meth:`PerspParams.error_bound`)."""
    rows = np.asarray(rows, dtype=np.int64)
    nums, W = rows[:, :-1], rows[:, -1]
    uf, wf, c = params.uv_fmt.frac_bits, params.recip.in_fmt.frac_bits, params.coord_bits
    # |U/W| <= s_abs  <=>  |U| 2**wf <= s_abs |W| 2**uf  (exact integers: object arithmetic)
    lhs = np.abs(nums).astype(object) * (1 << wf)
    keep = (W != 0) & np.all(lhs <= (s_abs * np.abs(W).astype(object) * (1 << uf))[:, None], axis=1)
    worst, worst_row, total, count = Fraction(0), None, 0.0, 0
    for j in range(nums.shape[1]):
        num, den = wrapped_error(nums[keep, j], W[keep], out[keep, j], uf, wf, c)
        err = as_float(num, den)
        if err.size:
            i = int(np.argmax(err))
            if Fraction(int(num[i]), int(den[i])) > worst:
                worst, worst_row = Fraction(int(num[i]), int(den[i])), rows[keep][i].tolist()
            total += float(err.sum())
            count += err.size
    bound = params.error_bound(Fraction(s_abs))
    return {"vectors": int(keep.sum()), "s_abs": s_abs, "max_error": float(worst),
            "max_error_ulp": float(worst * (1 << c)), "mean_error": total / count if count else 0.0,
            "worst_input_codes": worst_row, "within_bound": bool(worst <= bound), "bound": float(bound)}


def measure_bump(params, rows, out) -> dict:
    """Worst and mean component error of unsaturated bump outputs against the exact ``N 2**-e + du A0 + dv A1``."""
    rows = np.asarray(rows, dtype=np.int64)
    keep = out[:, 3] == 0
    r = rows[keep]
    num, den = bump_error(r[:, 0:3], r[:, 3], r[:, 4], r[:, 5:8], r[:, 8:11], out[keep, :3],
                          params.n_fmt.frac_bits, params.d_fmt.frac_bits, params.a_fmt.frac_bits,
                          params.out_fmt.frac_bits, r[:, 11] if params.exp_bits else None)
    worst_num = int(num.max(initial=0)) if num.size else 0
    worst = Fraction(worst_num, den)
    err = as_float(num.ravel(), np.full(num.size, den, dtype=object)) if num.size else np.zeros(0)
    return {"vectors": int(keep.sum()), "saturated_vectors": int((~keep).sum()), "max_error": float(worst),
            "max_error_ulp": float(worst / params.out_fmt.ulp), "mean_error": float(err.mean()) if err.size else 0.0,
            "worst_input_codes": r[int(np.argmax(num.max(axis=1)))].tolist() if num.size else None,
            "within_bound": bool(worst <= params.max_error), "bound": float(params.max_error)}


# -- cube addressing and reflection -------------------------------------------------------------------------

#: The OpenGL / Vulkan cube table (docs/design.md, "The face table"): per face, (component, sign) of s_c and of t_c;
#: 0, 1, 2 = x, y, z.
CUBE_TABLE = {0: ((2, -1), (1, -1)), 1: ((2, 1), (1, -1)), 2: ((0, 1), (2, 1)),
              3: ((0, 1), (2, -1)), 4: ((0, 1), (1, -1)), 5: ((0, -1), (1, -1))}


def cube_face_exact(v) -> np.ndarray:
    """Exact face of integer vectors ``v`` (``(K, 3)``): the largest magnitude, ties to the later axis
    (z over y over x), negative only if ``< 0``; the zero vector gives +Z (4)."""
    v = np.asarray(v, dtype=np.int64)
    mag = np.abs(v)[:, ::-1]                                      # z, y, x: argmax takes the first maximum
    axis = 2 - np.argmax(mag, axis=1)
    ma = v[np.arange(len(v)), axis]
    return 2 * axis + (ma < 0)


def cube_st_error(v, face, s, t, st_frac: int):
    """Exact ``|s - s_exact|`` and ``|t - t_exact|`` of cube outputs for the exact ``face``, as ``(num, den)`` pairs
    ``((num_s, num_t), den)``; the zero vector is measured against ``s = t = 1/2``."""
    v = np.asarray(v, dtype=np.int64)
    big = int(np.abs(v).max(initial=1)).bit_length() + st_frac + 4 > 62
    cast = (lambda a: np.asarray(a, dtype=object)) if big else (lambda a: np.asarray(a, dtype=np.int64))
    face = np.asarray(face, dtype=np.int64)
    rows = np.arange(len(v))
    ma = np.abs(v[rows, face // 2])
    zero = ma == 0
    out = []
    for k, got in ((0, s), (1, t)):
        comp = np.array([CUBE_TABLE[f][k][0] for f in range(6)])[face]
        sign = np.array([CUBE_TABLE[f][k][1] for f in range(6)])[face]
        c = sign * v[rows, comp]
        m = np.where(zero, 1, ma)
        c = np.where(zero, 0, c)
        # s = (c + m) / (2 m):  |S 2**-f - (c + m)/(2m)| = |2 m S - (c + m) 2**f| / (2**(f+1) m)
        out.append(np.abs(cast(2 * m) * cast(got) - cast(c + m) * (1 << st_frac)))
    den = cast(np.where(zero, 1, ma)) * (1 << (st_frac + 1))
    return (out[0], out[1]), den


def measure_cube(params, v, out) -> dict:
    """Face agreement with the exact tie rule, range of s and t, worst s/t error against the exact quotients."""
    v = np.asarray(v, dtype=np.int64)
    face = cube_face_exact(v)
    f = params.st_fmt.frac_bits
    (ns, nt), den = cube_st_error(v, face, out[:, 1], out[:, 2], f)
    es, et = as_float(ns, den), as_float(nt, den)
    err = np.maximum(es, et)
    worst = int(np.argmax(err))
    one = 1 << f
    zero = np.all(v == 0, axis=1)
    return {"vectors": int(len(v)), "face_mismatches": int(np.sum(out[:, 0] != face)),
            "st_in_range": bool(np.all((out[:, 1:3] >= 0) & (out[:, 1:3] <= one))),
            "degenerate_correct": bool(np.all(out[:, 3].astype(bool) == zero)),
            "max_error": float(err[worst]), "max_error_log2": float(np.log2(err[worst])) if err[worst] else None,
            "mean_error": float(err.mean()), "worst_input_codes": v[worst].tolist(),
            "within_bound": bool(np.all(within(ns, den, params.st_bound)) and np.all(within(nt, den, params.st_bound))),
            "bound": float(params.st_bound)}


def reflect_exact(nv, ev) -> np.ndarray:
    """Exact ``R = 2 N (N.E) - E (N.N)`` (EQ 1) as Python integers, ``(K, 3)`` object array."""
    N = np.asarray(nv, dtype=object)
    E = np.asarray(ev, dtype=object)
    p = (N * E).sum(axis=1)
    q = (N * N).sum(axis=1)
    return 2 * N * p[:, None] - E * q[:, None]


def direction_error(R, r):
    """``(sin2_num, sin2_den, dot)`` exactly, for the angle between integer vectors ``R`` and ``r`` (rows):
    ``sin(theta)**2 = |R x r|**2 / (|R|**2 |r|**2)``; ``dot = R . r`` tells the hemisphere."""
    R = np.asarray(R, dtype=object)
    r = np.asarray(r, dtype=object)
    cx = R[:, 1] * r[:, 2] - R[:, 2] * r[:, 1]
    cy = R[:, 2] * r[:, 0] - R[:, 0] * r[:, 2]
    cz = R[:, 0] * r[:, 1] - R[:, 1] * r[:, 0]
    num = cx * cx + cy * cy + cz * cz
    den = (R * R).sum(axis=1) * (r * r).sum(axis=1)
    dot = (R * r).sum(axis=1)
    return num, den, dot


def measure_reflect(params, ne, out) -> dict:
    """Worst angle between the exact R and the output, its bound, degenerate flags, and the implied cube s/t
    error (exact R and output addressed exactly, where both select the same face)."""
    ne = np.asarray(ne, dtype=np.int64)
    R = reflect_exact(ne[:, :3], ne[:, 3:])
    r = np.asarray(out[:, :3], dtype=np.int64)
    zero = np.all(R == 0, axis=1).astype(bool)
    ok = ~zero
    num, den, dot = direction_error(R[ok], r[ok])
    sin2 = as_float(num, np.where(den == 0, 1, den))
    ang = np.arcsin(np.sqrt(np.minimum(sin2, 1.0)))
    ang = np.where(np.asarray(dot > 0, dtype=bool), ang, np.pi - ang)
    worst = int(np.argmax(ang)) if ang.size else 0
    # implied s/t error on the cube (float: reporting only)
    Rf = R[ok].astype(np.float64) if ok.any() else np.zeros((0, 3))
    rf = r[ok].astype(np.float64)
    st_err = _st_float(Rf, rf)
    return {"vectors": int(len(ne)), "degenerate_vectors": int(zero.sum()),
            "degenerate_correct": bool(np.all(out[:, 3].astype(bool) == zero)
                                       and np.all(r[zero] == 0) and np.all(np.any(r[ok] != 0, axis=1))),
            "max_direction_error_rad": float(ang.max(initial=0.0)),
            "mean_direction_error_rad": float(ang.mean()) if ang.size else 0.0,
            "worst_input_codes": ne[ok][worst].tolist() if ang.size else None,
            "within_bound": bool(np.all(np.asarray(dot > 0, dtype=bool))
                                 and np.all(within(num, den, params.sin2_bound))),
            "bound_rad": params.direction_bound,
            "max_cube_st_error": st_err, "cube_st_bound": params.st_bound}


def _st_float(Rf, rf) -> float:
    """Largest |s, t difference| between two float vector sets addressed on the cube, rows on the same face."""
    if not len(Rf):
        return 0.0

    def st(v):
        mag = np.abs(v)[:, ::-1]
        axis = 2 - np.argmax(mag, axis=1)
        rows = np.arange(len(v))
        ma = v[rows, axis]
        face = 2 * axis + (ma < 0)
        res = []
        for k in (0, 1):
            comp = np.array([CUBE_TABLE[f][k][0] for f in range(6)])[face]
            sign = np.array([CUBE_TABLE[f][k][1] for f in range(6)])[face]
            res.append((sign * v[rows, comp] / np.abs(ma) + 1) / 2)
        return face, res[0], res[1]

    fa, sa, ta = st(Rf)
    fb, sb, tb = st(rf)
    same = fa == fb
    return float(np.max(np.maximum(np.abs(sa - sb), np.abs(ta - tb))[same], initial=0.0))


def measure_lod(params, rows, out) -> dict:
    """Worst and mean distance in levels between the LOD unit's unflagged outputs and the exact level of the same
    codes (:meth:`fxmodel.units.lod.LodParams.exact`, exact fractions), on the vectors of the bound's domain
    (conditioning ``kappa <= 2^kappa_bits``, :meth:`~fxmodel.units.lod.LodParams.conditioning`); the vectors beyond
    it counted apart and each held to the bound at its own ``kappa``; flagged rows counted apart, a saturated one
    checked to lie beyond the format's end it stops at."""
    rows = np.asarray(rows, dtype=np.int64)
    lam, flags = out[:, 0], out[:, 1]
    scale = 1 << params.lod_frac
    domain = 2.0 ** params.kappa_bits
    worst, worst_row, total, count, sat_ok, beyond, beyond_ok = 0.0, None, 0.0, 0, True, 0, True
    for i in np.flatnonzero(flags & 0b011 == 0):
        exact = params.exact(*rows[i])
        got = lam[i] / scale
        if flags[i]:                              # saturated: the exact level lies at or beyond the end
            sat_ok &= bool(exact >= got if lam[i] == params.out_fmt.max_code else exact <= got)
            continue
        err = abs(got - exact)
        kappa = params.conditioning(*rows[i])
        if kappa > domain:
            beyond += 1
            beyond_ok &= bool(err <= params.error_bound(kappa * (1 + 1e-9)) + 1e-12)
            continue
        total, count = total + err, count + 1
        if err > worst:
            worst, worst_row = err, rows[i].tolist()
    bound = params.error_bound()
    return {"vectors": count, "max_error_levels": worst, "mean_error_levels": total / count if count else 0.0,
            "worst_input_codes": worst_row, "within_bound": bool(worst <= bound + 1e-12 and sat_ok and beyond_ok),
            "bound_levels": bound, "kappa_domain": domain, "beyond_domain": beyond,
            "flagged": {"zero": int((flags & 1 != 0).sum()), "bad_w": int((flags & 2 != 0).sum()),
                        "saturated": int((flags & 4 != 0).sum())}}


MEASURES = {"recip": measure_recip, "divide": measure_divide, "persp": measure_persp, "bump": measure_bump,
            "cube": measure_cube, "reflect": measure_reflect, "lod": measure_lod}
