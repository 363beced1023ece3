"""The triangle set-up of the scan converter (:func:`setup`, re-exported by :mod:`fxmodel.units.raster`; paper,
section 4): triangle records from snapped vertices, by exact arithmetic: edge functions with the top-left rule,
each triangle's pixel extent, the Bresenham form of its edges and the exact
planes of its attributes, rounded once into the record's words. Exact integers and rationals throughout; the
module docstring of :mod:`fxmodel.units.raster` derives them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import require

__all__ = ["Records", "setup", "EDGE_OFF", "EDGE_LEFT", "EDGE_RIGHT", "edge_setup", "area2", "triangle_extent",
           "append_edges", "append_planes"]

#: Edge kinds in the record.
EDGE_OFF, EDGE_LEFT, EDGE_RIGHT = 0, 1, 2


def edge_setup(X, Y):
    """Edge functions of one triangle with integer snapped vertices ``X``, ``Y`` (3 each) and positive area.

    Edge ``e`` runs from vertex ``e + 1`` to ``e + 2`` (mod 3), i.e. it is opposite vertex ``e``, and
    ``E_e(p) = (bx - ax)(py - ay) - (by - ay)(px - ax) = A_e px + B_e py + C_e``, positive inside. ``bias_e`` is
    0 for a top or left edge and 1 otherwise; a point is covered when ``E_e(p) >= bias_e`` for all ``e``.

    Returns ``(A, B, C, bias)``, int64 arrays of 3.
    """
    X = np.asarray(X, dtype=np.int64)
    Y = np.asarray(Y, dtype=np.int64)
    ax, ay = X[[1, 2, 0]], Y[[1, 2, 0]]
    bx, by = X[[2, 0, 1]], Y[[2, 0, 1]]
    dx, dy = bx - ax, by - ay
    top_left = (dy < 0) | ((dy == 0) & (dx > 0))        # y down, interior on the left of a -> b seen with y down
    return -dy, dx, dy * ax - dx * ay, np.where(top_left, 0, 1).astype(np.int64)


def area2(X, Y):
    """Twice the signed area of triangles with vertex coordinates ``X``, ``Y`` (``(..., 3)`` integers)."""
    return (X[..., 1] - X[..., 0]) * (Y[..., 2] - Y[..., 0]) - (X[..., 2] - X[..., 0]) * (Y[..., 1] - Y[..., 0])


def _round_half_up(value: Fraction, frac: int) -> int:
    """``value`` rounded half-up to ``frac`` fraction bits, as an integer code (exact)."""
    return math.floor(value * (1 << frac) + Fraction(1, 2))


def _wrap(code: int, fmt: Fmt) -> int:
    """``code`` modulo ``2**width`` as a signed code (the hardware's word)."""
    w = fmt.width
    code &= (1 << w) - 1
    return code - (1 << w) if code >> (w - 1) else code


def _ceil_div(a: int, b: int) -> int:
    return -((-a) // b)


def triangle_extent(P, t: int, Xt, Yt, width: int, height: int, origin=(0, 0), picture=None) -> dict | None:
    """Triangle ``t`` (snapped vertices ``Xt``, ``Yt``) in the ``width`` x ``height`` viewport: its winding
    ``order``, twice its area ``a2``, its rows and columns ``x0, x1, y0, y1`` (pixel centres covered, a horizontal
    edge bounding the rows), its edge functions ``A, B, C`` and each edge's ``kind`` and ``(a, b, c)`` scaled to
    pixel centres; ``None`` if it has no area or covers no pixel centre. ``ValueError`` for a vertex outside the
    guard band of the ``picture`` (``(width, height)``, default the viewport's). ``origin``: the viewport's top
    left pixel in the picture (a tile of it, :func:`setup`): the vertices are given in the picture's coordinates,
    everything returned is in the viewport's."""
    S, half = P.S, P.S // 2
    pw, ph = (width, height) if picture is None else picture
    lo_c = -(P.guard_pixels + 1) * S
    for coord, c, lim in ((Xt, "x", pw), (Yt, "y", ph)):
        hi_c = (lim + P.guard_pixels + 1) * S
        if coord.min() < lo_c or coord.max() > hi_c:
            raise ValueError(f"triangle {t}: vertex {c} {coord.tolist()} (1/{S} pixel) is outside the guard "
                             f"band [{lo_c}, {hi_c}] of the {pw}x{ph} viewport")
    Xt, Yt = Xt - origin[0] * S, Yt - origin[1] * S        # exact: whole pixels
    a2 = int(area2(Xt, Yt))
    if a2 == 0:
        return None
    order = [0, 1, 2] if a2 > 0 else [0, 2, 1]
    Xo, Yo = Xt[order], Yt[order]
    x0 = max(0, _ceil_div(int(Xo.min()) - half, S))
    x1 = min(width - 1, pw - 1 - origin[0], (int(Xo.max()) - half) // S)     # inside the tile and the picture
    y0 = max(0, _ceil_div(int(Yo.min()) - half, S))
    y1 = min(height - 1, ph - 1 - origin[1], (int(Yo.max()) - half) // S)
    A, B, C, bias = (v.tolist() for v in edge_setup(Xo, Yo))
    kinds, es = [], []
    for e in range(3):
        a, b = A[e] * S, B[e] * S
        c = C[e] + (A[e] + B[e]) * half - bias[e]
        if a == 0:                                   # horizontal: b y + c >= 0 bounds the rows
            if b > 0:
                y0 = max(y0, _ceil_div(-c, b))
            else:
                y1 = min(y1, c // (-b))
            kinds.append(EDGE_OFF)
            es.append((0, 0, 0, 0, 0))
            continue
        kinds.append(EDGE_LEFT if a > 0 else EDGE_RIGHT)
        es.append((a, b, c))
    if x1 < x0 or y1 < y0:
        return None
    return {"order": order, "a2": a2, "x0": x0, "x1": x1, "y0": y0, "y1": y1, "A": A, "B": B, "C": C,
            "kinds": kinds, "es": es}


def append_edges(P, fields: dict, tri: dict):
    """Append the record fields of a triangle's rows, columns and edges (the Bresenham form ``p, r, q, m, d`` of
    each edge at row ``y0``; zeros for a horizontal edge) to ``fields`` (lists by record field name)."""
    y0 = tri["y0"]
    for e in range(3):
        f = {k: 0 for k in P.edge_fmts}
        f["kind"] = tri["kinds"][e]
        if f["kind"] != EDGE_OFF:
            a, b, c = tri["es"][e]
            d = abs(a)
            num = b * y0 + c
            f["p"], f["r"] = divmod(num, d)
            f["q"], f["m"] = divmod(b, d)
            f["d"] = d
        for k, v in f.items():
            fields[f"e{e}_{k}"].append(v)
    fields["y0"].append(y0)
    fields["rows"].append(tri["y1"] - y0)
    fields["x0"].append(tri["x0"])
    fields["x1"].append(tri["x1"])


def append_planes(P, fields: dict, tri: dict, values: dict, t: int):
    """Append each attribute's exact plane at the first pixel centre and its steps along x and y, rounded
    half-up into the accumulator format (modulo ``2**N``), to ``fields``: ``a(x, y) = sum_e v_e F_e(x, y) /
    area2``. ``values``: the triangle's three vertex values of each attribute (float64, in vertex order);
    ``ValueError`` naming triangle ``t`` for a value outside its output format."""
    S, half = P.S, P.S // 2
    A, B, C, a2, order = tri["A"], tri["B"], tri["C"], tri["a2"], tri["order"]
    F0 = [A[e] * (S * tri["x0"] + half) + B[e] * (S * tri["y0"] + half) + C[e] for e in range(3)]
    for name in P.names:
        v = values[name][order]
        fmt, acc = P.out_fmt(name), P.acc_fmt(name)
        if not np.all(np.isfinite(v)) or v.min() < fmt.min_value or v.max() > fmt.max_value:
            raise ValueError(f"triangle {t}: attribute {name} has vertex values {v.tolist()} outside its "
                             f"format {fmt} [{float(fmt.min_value)}, {float(fmt.max_value)}]: a triangle "
                             f"this preset cannot draw (widen the format or normalize the range)")
        vf = [Fraction(float(x)) for x in v]
        num0 = sum(vf[e] * F0[e] for e in range(3))
        numx = sum(vf[e] * (A[e] * S) for e in range(3))
        numy = sum(vf[e] * (B[e] * S) for e in range(3))
        fb = acc.frac_bits
        fields[f"{name}_0"].append(_wrap(_round_half_up(num0 / abs(a2), fb), acc))
        fields[f"{name}_dx"].append(_wrap(_round_half_up(numx / abs(a2), fb), acc))
        fields[f"{name}_dy"].append(_wrap(_round_half_up(numy / abs(a2), fb), acc))
        for field, attr, axis, sf in P.slopes:           # the exact step, rounded once to its own format
            if attr == name:
                code = _round_half_up((numx if axis == "x" else numy) / abs(a2), sf.frac_bits)
                if not sf.min_code <= code <= sf.max_code:
                    raise ValueError(f"triangle {t}: {field} = d{name}/d{axis} is {float(code * sf.ulp)}, outside "
                                     f"its format {sf}: a triangle this preset cannot draw")
                fields[field].append(code)


# ------------------------------------------------------------------------------------------------------------
# set-up (host, once per triangle)
# ------------------------------------------------------------------------------------------------------------
@dataclass
class Records:
    """Triangle records: ``codes[field]`` an int64 array ``(T,)`` per record field; ``source`` the index of each
    record's input triangle; ``dropped`` the input triangles that cover no pixel centre of the viewport."""

    params: object                      # the RasterParams that made them
    codes: dict
    source: np.ndarray
    dropped: int = 0

    def __len__(self) -> int:
        return int(self.source.shape[0])

    def matrix(self) -> np.ndarray:
        """Codes ``(T, fields)`` in :attr:`RasterParams.record` order."""
        return np.stack([self.codes[p.name] for p in self.params.record], axis=1) if len(self) else \
            np.zeros((0, len(self.params.record)), np.int64)


def setup(params, X, Y, values: dict, width: int, height: int, origin=(0, 0), picture=None) -> Records:
    """Triangle records from snapped vertices and float64 vertex attributes.

    With ``origin`` and ``picture`` the viewport is one tile of a larger picture (a board draws a picture a tile
    at a time, ``docs/board.md``): the vertices are the picture's (``picture = (width, height)``, whose guard band
    they must lie in), the tile's top-left pixel is ``origin``, and the records are the tile's, in its own
    coordinates (every pixel index counted from its top left); a tile reaching past the picture's edge covers
    only the picture's pixels. Moving the vertices by whole pixels is exact, and
    every record field is an exact function of the tile's coordinates rounded once, so a tile's records are those
    of the picture's triangles moved into a viewport of the tile's size; their fields' formats hold (checked
    below) while the picture is at most ``max_size`` (its coordinates, moved, stay within ``coord_max``). The
    attributes start at each tile's first pixel, so a tile's fragments may differ from the whole picture's by the
    interpolators' bound (``RasterParams.error_bound``), not beyond.

    Parameters
    ----------
    params : RasterParams
        The scan converter (:class:`fxmodel.units.raster.RasterParams`).
    X, Y : array_like, shape (T, 3), int
        Snapped vertex coordinates (``subpixel_bits`` fraction bits), either winding, any area.
    values : dict
        For every attribute of ``params`` an array ``(T, 3)`` of vertex values (float64, within the attribute's
        output format); for every per-triangle constant (:attr:`RasterParams.consts`) an integer array ``(T,)``.
    width, height : int
        The viewport, at most ``max_size`` each.

    Returns
    -------
    Records
        Zero-area triangles and triangles covering no pixel centre of the viewport (an empty row or column range)
        are dropped.

    Raises
    ------
    ValueError
        A viewport larger than ``max_size``, a vertex outside the guard band, a missing attribute or a vertex
        value outside its format (naming the triangle and attribute): a triangle this hardware cannot draw.
    """
    P = params
    X, Y, vals, consts = _setup_inputs(P, X, Y, values, width, height)
    if picture is not None:
        require(1 <= picture[0] <= P.max_size and 1 <= picture[1] <= P.max_size, "picture", picture,
                f"must be within 1..{P.max_size} (RasterParams.max_size)")
        require(all(isinstance(o, int) and 0 <= o < p for o, p in zip(origin, picture)), "origin", origin,
                f"must be a pixel of the {picture[0]}x{picture[1]} picture")
    else:
        require(tuple(origin) == (0, 0), "origin", origin, "needs the picture the tile is in (picture=)")
    fields = {p.name: [] for p in P.record}
    source, dropped = [], 0
    for t in range(X.shape[0]):
        tri = triangle_extent(P, t, X[t], Y[t], width, height, origin, picture)
        if tri is None:                                  # zero area, or no pixel centre covered
            dropped += 1
            continue
        append_edges(P, fields, tri)
        for n, _ in P.consts:
            fields[n].append(int(consts[n][t]))
        append_planes(P, fields, tri, {n: vals[n][t] for n in P.names}, t)
        source.append(t)
    codes = {k: np.array(v, dtype=np.int64) for k, v in fields.items()}
    for p in P.record:
        p.fmt.check(codes[p.name], what=f"raster record field {p.name}")
    return Records(params=P, codes=codes, source=np.array(source, dtype=np.int64), dropped=dropped)


def _setup_inputs(P, X, Y, values: dict, width: int, height: int):
    """:func:`setup`'s arguments checked and shaped: ``(X, Y, attribute values (T, 3), constants (T,))``."""
    require(1 <= width <= P.max_size and 1 <= height <= P.max_size, "viewport", (width, height),
            f"must be within 1..{P.max_size} (RasterParams.max_size)")
    X = np.asarray(X, dtype=np.int64).reshape(-1, 3)
    Y = np.asarray(Y, dtype=np.int64).reshape(-1, 3)
    T = X.shape[0]
    missing = [n for n in P.names + tuple(n for n, _ in P.consts) if n not in values]
    require(not missing, "values", sorted(values), f"missing attributes {missing}")
    vals = {n: np.asarray(values[n], dtype=np.float64).reshape(T, 3) for n in P.names}
    consts = {n: np.asarray(values[n]).reshape(T) for n, _ in P.consts}
    for n, fmt in P.consts:
        c = consts[n]
        bad = np.flatnonzero((c != np.round(c)) | (c < fmt.min_code) | (c > fmt.max_code))
        if len(bad):
            raise ValueError(f"triangle {int(bad[0])}: constant {n} = {c[bad[0]]} is not an integer code of its "
                             f"format {fmt}")
        consts[n] = c.astype(np.int64)
    return X, Y, vals, consts
