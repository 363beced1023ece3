"""The documented depth precision (fxmodel/units/raster.py, "Depth"; docs/design.md, "Depth"): two surfaces whose exact
depths ``Z = near / w_c`` at a shared pixel differ by more than ``RasterParams.depth_precision()`` get fixed-point
codes ordered the same way, checked against exact rational planes (fractions), on pairs of triangles built to
cross or nearly coincide so that the gaps fall around the threshold."""

import dataclasses
from fractions import Fraction

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from fxmodel.units.raster import RasterParams, scan, setup

DEFAULT = RasterParams.PRESETS["default"]
#: The default preset's Z alone: the same format, viewport limit and guard bits, so the same bound.
P = dataclasses.replace(DEFAULT, attrs=(("Z", DEFAULT.out_fmt("Z")),), consts=())
S = P.S
ULP = P.out_fmt("Z").ulp
WIDTH, HEIGHT = 48, 40


def exact_z(X, Y, v, x, y) -> list:
    """The plane through vertex values ``v`` (floats, taken exactly) at pixel centres ``(x, y)``, as Fractions:
    barycentrics from determinants of the snapped coordinates (pixel centres are integers in 1/S pixel)."""
    total = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0])
    vf = [Fraction(float(t)) for t in v]
    out = []
    for px, py in zip(((2 * np.asarray(x) + 1) * S // 2).tolist(), ((2 * np.asarray(y) + 1) * S // 2).tolist()):
        lam = [(X[(e + 1) % 3] - px) * (Y[(e + 2) % 3] - py) - (X[(e + 2) % 3] - px) * (Y[(e + 1) % 3] - py)
               for e in range(3)]
        out.append(sum(lam[e] * vf[e] for e in range(3)) / total)
    return out


def plane_at(X, Y, v, px, py) -> Fraction:
    """The same plane at an arbitrary point ``(px, py)`` (1/S pixel)."""
    total = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0])
    lam = [(X[(e + 1) % 3] - px) * (Y[(e + 2) % 3] - py) - (X[(e + 2) % 3] - px) * (Y[(e + 1) % 3] - py)
           for e in range(3)]
    return sum(lam[e] * Fraction(float(v[e])) for e in range(3)) / total


class _Skip(Exception):
    """A triangle of the pair covers no pixel of the viewport."""


def draw_pair(X, Y, v):
    """Both triangles' Z codes and exact Z at their shared pixels (drawing order: triangle 0, then 1)."""
    recs = setup(P, np.array(X), np.array(Y), {"Z": np.array(v)}, WIDTH, HEIGHT)
    if len(recs) != 2:
        raise _Skip

    res = scan(P, recs)
    key = res.codes["y"] * WIDTH + res.codes["x"]
    first, second = res.record == 0, res.record == 1
    shared, i1, i2 = np.intersect1d(key[first], key[second], return_indices=True)
    x, y = shared % WIDTH, shared // WIDTH
    c1, c2 = res.codes["Z"][first][i1], res.codes["Z"][second][i2]
    return x, y, c1, c2, exact_z(X[0], Y[0], v[0], x, y), exact_z(X[1], Y[1], v[1], x, y)


coord = st.integers(-4 * S, (WIDTH + 4) * S)


@st.composite
def crossing_pairs(draw):
    """Two triangles over a common area on one random depth plane (its values at three corners of the viewport in
    ``[0.3, 0.7]``, so it stays within ``Z``'s format near the viewport); each vertex value is the plane's plus a few
    ulps (``near``: nearly coplanar, gaps of about the threshold everywhere) or, for the second triangle, plus up
    to a few ulps per pixel (``cross``: the surfaces cross mid-triangle, every gap near the crossing line)."""
    X1 = [draw(coord) for _ in range(3)]
    Y1 = [draw(coord) for _ in range(3)]
    assume((X1[1] - X1[0]) * (Y1[2] - Y1[0]) != (X1[2] - X1[0]) * (Y1[1] - Y1[0]))
    X2 = [x + draw(st.integers(-12 * S, 12 * S)) for x in X1]
    Y2 = [y + draw(st.integers(-12 * S, 12 * S)) for y in Y1]
    corners = [draw(st.floats(0.3, 0.7)) for _ in range(3)]
    CX, CY = [0, WIDTH * S, 0], [0, 0, HEIGHT * S]
    kind = draw(st.sampled_from(["near", "cross"]))
    u = float(ULP)
    v1 = [float(plane_at(CX, CY, corners, X1[e], Y1[e])) + draw(st.floats(-4 * u, 4 * u)) for e in range(3)]
    spread = 4 * u if kind == "near" else 4 * u * WIDTH
    v2 = [float(plane_at(CX, CY, corners, X2[e], Y2[e])) + draw(st.floats(-spread, spread)) for e in range(3)]
    return [X1, X2], [Y1, Y2], [v1, v2]


@settings(max_examples=60)
@given(crossing_pairs())
def test_depths_further_apart_than_the_precision_are_ordered_the_same_way(pair):
    X, Y, v = pair
    try:
        x, y, c1, c2, z1, z2 = draw_pair(X, Y, v)
    except _Skip:
        assume(False)
    b, precision = P.error_bound("Z"), P.depth_precision("Z")
    assert precision == 2 * b and float(precision / ULP) < 1.5
    for k in range(len(x)):
        assert abs(int(c1[k]) * ULP - z1[k]) <= b and abs(int(c2[k]) * ULP - z2[k]) <= b   # the proof's premise
        gap = z1[k] - z2[k]
        if gap > precision:
            assert c1[k] > c2[k], (int(x[k]), int(y[k]), float(gap / ULP))
        elif -gap > precision:
            assert c2[k] > c1[k], (int(x[k]), int(y[k]), float(gap / ULP))
        elif abs(gap) > precision - ULP:           # between 0.5 and 1.5 ulp: equal codes at worst, never reversed
            assert (c1[k] - c2[k]) * (1 if gap > 0 else -1) >= 0, (int(x[k]), int(y[k]), float(gap / ULP))


def test_the_precision_is_not_loose_gaps_above_half_an_ulp_can_tie():
    """The threshold is about tight: on two nearly coplanar triangles over the whole viewport, some pixel has a gap
    above half an ulp and equal codes (a threshold of half an ulp would be wrong), and every pixel with a gap above
    the precision is ordered right."""
    X = [[-S, (WIDTH + 1) * S, -S]] * 2                  # the same triangle twice, over the whole viewport
    Y = [[-S, -S, (HEIGHT + 1) * S]] * 2
    v1 = [0.30, 0.55, 0.71]
    v2 = [t + float(ULP) * d for t, d in zip(v1, (1.3, -0.7, 2.1))]
    x, y, c1, c2, z1, z2 = draw_pair(X, Y, [v1, v2])
    assert len(x) > 500
    gaps = [float((a - b) / ULP) for a, b in zip(z1, z2)]
    ties = [g for g, a, b in zip(gaps, c1, c2) if a == b and abs(g) > 0.5]
    assert ties, "no tie above half an ulp: the sample does not probe the threshold"
    prec = float(P.depth_precision("Z") / ULP)
    assert all((a > b) if g > prec else (b > a) for g, a, b in zip(gaps, c1, c2) if abs(g) > prec)
    assert any(abs(g) > prec for g in gaps)
