r"""Front end: projection, clipping, triangle set-up and scan conversion into fragments (paper, sections 3.2 and 4).

Everything here is float64 host-side work; the pixel pipeline (``fxmodel/pipeline/pixel.py``, the RTL) starts at the
fragment. :func:`rasterize` turns a :class:`~host.scene.Scene` into one :class:`Fragments` row per visible
pixel.

Steps
-----
1. **World -> camera -> clip.** Camera space is right-handed, x right, y up, looking down ``-z``
   (:meth:`Camera.basis`). Clip coordinates are OpenGL's: ``x_c = (f / aspect) x_e``, ``y_c = f y_e``,
   ``w_c = -z_e`` (the distance along the view axis), ``f = 1 / tan(fov / 2)``, ``aspect = width / height``.
2. **Clipping** (homogeneous, Sutherland-Hodgman, attributes interpolated linearly in clip space, which is exact
   for attributes affine on the triangle): against the near and far planes ``near <= w_c <= far`` and a guard
   band ``GUARD_PIXELS`` outside the viewport (so snapped coordinates stay small); a clipped polygon is split
   into a fan of new triangles. An intersection is always computed from the two end points in a canonical order,
   so two triangles sharing a clipped edge get bit-identical new vertices (no cracks).
3. **Viewport and snapping.** ``x_s = (x_c / w_c + 1) width / 2``, ``y_s = (1 - y_c / w_c) height / 2``: pixel
   ``(x, y)`` covers ``[x, x + 1) x [y, y + 1)`` with its center at ``(x + 0.5, y + 0.5)``, **y down** (row 0 is
   the top row). Vertices are snapped to ``1 / 2**SUBPIXEL_BITS`` of a pixel (round to nearest), as hardware
   does; coverage and interpolation both use the snapped triangle.
4. **Back faces.** A triangle is front-facing when its vertices appear counter-clockwise on screen (the right-hand
   rule of the scene's winding convention), decided exactly on the snapped integer coordinates. Back faces are
   culled, unless the mesh is ``two_sided``: then they are drawn with ``N`` and ``A`` negated (the back of the
   bumpy surface: ``N' = -(N + du A0 + dv A1)``) and ``front = False``. Zero-area triangles are dropped.
5. **Scan conversion** with integer edge functions (exact) and the **top-left fill rule** (section 4: "to visit
   the pixels of adjacent triangles only once"): a pixel center exactly on an edge belongs to the triangle only
   if the edge is a top edge (horizontal, the triangle below it) or a left edge. Equivalently, a pixel is
   inside when the point shifted by an infinitesimal ``(e, e**2)`` is: so in a mesh without T-junctions every
   pixel of the union of triangles is visited exactly once, shared edges and vertices included. Each triangle is
   vectorized over its bounding box.
6. **Z-buffer.** The nearest fragment per pixel wins (largest ``1/w_c``; on a tie, the triangle drawn first).
   Only visible fragments are returned, so the pipeline shades each pixel once.
7. **Attributes** of the visible fragments, all at once: barycentrics from the exact edge functions, then
   perspective-correct interpolation (interpolate ``q / w_c`` and ``1 / w_c`` linearly in screen space, divide).

Output conventions (see :class:`Fragments`)
-------------------------------------------
``U = k (u_b - tile_u) / w_c``, ``V = k (v_b - tile_v) / w_c``, ``W = k / w_c`` with ``(u_b, v_b) = (u ru,
v rv)`` the bump-map address (the material's bump ``repeat`` applied; one tile per unit), ``k`` one constant per
rasterized triangle, the smallest ``w_c`` of its three vertices (the triangle's largest ``W`` is exactly 1 and
``W`` lies in ``(0, 1]``, to rounding, while ``U / W`` is unchanged by ``k``), and ``(tile_u, tile_v)`` the
triangle's integer **tile offset** (range normalization in the triangle set-up, free because the pipeline wraps
``s = U / W`` to ``[0, 1)``: ``U / W`` stays within half the triangle's span in texture space of 0, whatever the
repeat and wherever the triangle lies in texture space). ``Uc, Vc`` are the same for the color texture's repeat
(equal to ``U, V`` when both repeats agree). The pipeline takes ``W`` in ``persp.recip.in_fmt`` and ``U, V`` in
``persp.uv_fmt`` (``bumpmap info persp`` prints them): ``|U| <= |s - tile|`` as ``W <= 1``, so a
triangle spanning up to twice the range of ``uv_fmt`` in tiles fits, and ``W`` is small only for a triangle
spanning a large depth range (``W >= w_min / w_max`` over the triangle).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from fxmodel.units.raster import RasterParams, area2, edge_setup, setup
from host.bumpmap import bump_gain, triangle_matrix
from host.scene import Scene

__all__ = ["SUBPIXEL_BITS", "GUARD_PIXELS", "Fragments", "rasterize", "clip_space", "screen_space", "snap",
           "scan_triangle", "edge_setup", "clip_triangles",
           "screen_triangles", "triangle_records", "inverse_w"]

#: Fraction bits of snapped screen coordinates (1/256 pixel).
SUBPIXEL_BITS = 8
#: Triangles are clipped this many pixels outside the viewport (a guard band keeping the integers small).
GUARD_PIXELS = 4096

_ONE = 1 << SUBPIXEL_BITS
_HALF = _ONE >> 1


# ------------------------------------------------------------------------------------------------------------
# transforms
# ------------------------------------------------------------------------------------------------------------
def clip_space(scene: Scene, points) -> np.ndarray:
    """World ``points`` ``(..., 3)`` -> clip coordinates ``(..., 3)``: ``(x_c, y_c, w_c)`` (``z_c`` is not needed:
    depth is ``w_c``). Element-wise arithmetic (no BLAS), so equal inputs give bit-identical outputs."""
    cam = scene.camera
    r, u, f = cam.basis()
    d = np.asarray(points, dtype=np.float64) - np.asarray(cam.position, dtype=np.float64)
    dx, dy, dz = d[..., 0], d[..., 1], d[..., 2]
    xe = r[0] * dx + r[1] * dy + r[2] * dz
    ye = u[0] * dx + u[1] * dy + u[2] * dz
    we = f[0] * dx + f[1] * dy + f[2] * dz                     # = -z_e
    fy = 1.0 / np.tan(np.radians(cam.fov) / 2.0)
    fx = fy * scene.height / scene.width
    return np.stack([fx * xe, fy * ye, we], axis=-1)


def screen_space(clip, width: int, height: int) -> np.ndarray:
    """Clip ``(..., 3)`` with ``w_c > 0`` -> screen ``(..., 2)``: pixels, x right, y down, centers at ``+0.5``."""
    clip = np.asarray(clip, dtype=np.float64)
    w = clip[..., 2]
    return np.stack([(clip[..., 0] / w + 1.0) * (width / 2.0), (1.0 - clip[..., 1] / w) * (height / 2.0)], -1)


def snap(xy) -> np.ndarray:
    """Screen coordinates -> int64 fixed point with :data:`SUBPIXEL_BITS` fraction bits (round to nearest)."""
    return np.rint(np.ldexp(np.asarray(xy, dtype=np.float64), SUBPIXEL_BITS)).astype(np.int64)


# ------------------------------------------------------------------------------------------------------------
# clipping
# ------------------------------------------------------------------------------------------------------------
def _planes(scene: Scene) -> np.ndarray:
    """Rows ``(a, b, c, d)``: a point is inside when ``a x_c + b y_c + c w_c + d >= 0``."""
    gx = 1.0 + 2.0 * GUARD_PIXELS / scene.width
    gy = 1.0 + 2.0 * GUARD_PIXELS / scene.height
    cam = scene.camera
    return np.array([[0, 0, 1, -cam.near],       # w >= near
                     [0, 0, -1, cam.far],        # w <= far
                     [-1, 0, gx, 0], [1, 0, gx, 0],
                     [0, -1, gy, 0], [0, 1, gy, 0]], dtype=np.float64)


def _intersect(a: np.ndarray, b: np.ndarray, da: float, db: float) -> np.ndarray:
    # canonical order: the same edge gives the same bits whichever triangle (and direction) it comes from
    if tuple(a) > tuple(b):
        a, b, da, db = b, a, db, da
    t = da / (da - db)
    return a + t * (b - a)


def clip_triangles(verts: np.ndarray, planes: np.ndarray):
    """Clip triangles against ``planes``.

    Parameters
    ----------
    verts : ndarray, shape (T, 3, K)
        Per-vertex attribute vectors whose first three entries are ``(x_c, y_c, w_c)``; all ``K`` are interpolated
        linearly in clip space.
    planes : ndarray, shape (M, 4)

    Returns
    -------
    out : ndarray, shape (S, 3, K)
        Triangles inside all planes (unclipped ones unchanged, clipped ones as fans).
    source : ndarray, shape (S,), int64
        Index of the input triangle each output triangle comes from.
    n_clipped : int
        Input triangles that crossed a plane.
    """
    T = verts.shape[0]
    if T == 0:
        return verts, np.zeros(0, np.int64), 0
    h = np.concatenate([verts[..., :3], np.ones(verts.shape[:2] + (1,))], axis=-1)
    d = np.einsum("tvk,mk->tvm", h, planes)                                # (T, 3, M)
    inside = d >= 0
    all_in = inside.all(axis=(1, 2))
    all_out = (~inside).all(axis=1).any(axis=1)
    keep = np.flatnonzero(all_in)
    outs, srcs = [verts[keep]], [keep]
    cross = np.flatnonzero(~all_in & ~all_out)
    for t in cross:
        poly = [verts[t, i] for i in range(3)]
        for plane in planes:
            if not poly:
                break
            dist = [float(plane[:3] @ p[:3] + plane[3]) for p in poly]
            new = []
            for i in range(len(poly)):
                a, b, da, db = poly[i], poly[(i + 1) % len(poly)], dist[i], dist[(i + 1) % len(poly)]
                if da >= 0:
                    new.append(a)
                if (da >= 0) != (db >= 0):
                    new.append(_intersect(a, b, da, db))
            poly = new
        for i in range(1, len(poly) - 1):
            outs.append(np.stack([poly[0], poly[i], poly[i + 1]])[None])
            srcs.append(np.array([t]))
    return np.concatenate(outs), np.concatenate(srcs).astype(np.int64), len(cross)


# ------------------------------------------------------------------------------------------------------------
# scan conversion
# ------------------------------------------------------------------------------------------------------------
def scan_triangle(X, Y, width: int, height: int):
    """Pixels covered by one triangle under the top-left rule.

    Parameters
    ----------
    X, Y : array_like of 3 int
        Snapped vertex coordinates (:func:`snap`), either winding.
    width, height : int
        The viewport; pixels outside are not returned.

    Returns
    -------
    px, py : ndarray, int64
        Covered pixels in row-major order (empty for a zero-area triangle).
    E : ndarray, shape (3, n), int64
        The three edge functions at those pixel centers (in the triangle's positive orientation; ``E_e`` is
        opposite vertex ``e``, of the possibly reordered triangle), and the ``order`` used: a permutation of
        ``(0, 1, 2)``.
    """
    X = np.asarray(X, dtype=np.int64)
    Y = np.asarray(Y, dtype=np.int64)
    a2 = int(area2(X, Y))
    order = np.array([0, 1, 2]) if a2 >= 0 else np.array([0, 2, 1])
    empty = np.zeros(0, np.int64)
    if a2 == 0:
        return empty, empty, np.zeros((3, 0), np.int64), order
    X, Y = X[order], Y[order]
    x0 = max(0, -((_HALF - int(X.min())) // _ONE))          # ceil((minX - HALF) / ONE)
    x1 = min(width - 1, (int(X.max()) - _HALF) // _ONE)
    y0 = max(0, -((_HALF - int(Y.min())) // _ONE))
    y1 = min(height - 1, (int(Y.max()) - _HALF) // _ONE)
    if x1 < x0 or y1 < y0:
        return empty, empty, np.zeros((3, 0), np.int64), order
    A, B, C, bias = edge_setup(X, Y)
    cx = np.arange(x0, x1 + 1, dtype=np.int64) * _ONE + _HALF
    cy = np.arange(y0, y1 + 1, dtype=np.int64) * _ONE + _HALF
    E = [A[e] * cx[None, :] + (B[e] * cy[:, None] + C[e]) for e in range(3)]
    inside = (E[0] >= bias[0]) & (E[1] >= bias[1]) & (E[2] >= bias[2])
    iy, ix = np.nonzero(inside)
    return ix + x0, iy + y0, np.stack([E[e][iy, ix] for e in range(3)]), order


def inverse_w(X, Y, invw, px, py) -> np.ndarray:
    """The z-buffer's depth ``1 / w_c`` at pixel centres: screen-linear interpolation of the vertex values ``invw``
    with the exact integer edge functions, ``(E_0 invw_0 + E_1 invw_1 + E_2 invw_2) / area2``, in this order of
    float64 operations (so every caller gets the same bits).

    Parameters
    ----------
    X, Y : array_like, shape (3,) or (n, 3), int
        Snapped vertices of a positively oriented triangle (:class:`ScreenTriangles`), one or one per pixel.
    invw : array_like, shape (3,) or (n, 3)
        ``1 / w_c`` at the vertices.
    px, py : array_like, shape (n,), int
        Pixels.
    """
    X, Y = np.asarray(X, np.int64), np.asarray(Y, np.int64)
    invw = np.asarray(invw, np.float64)
    cx = np.asarray(px, np.int64) * _ONE + _HALF
    cy = np.asarray(py, np.int64) * _ONE + _HALF
    E = [(X[..., (e + 2) % 3] - X[..., (e + 1) % 3]) * (cy - Y[..., (e + 1) % 3])
         - (Y[..., (e + 2) % 3] - Y[..., (e + 1) % 3]) * (cx - X[..., (e + 1) % 3]) for e in range(3)]
    area = area2(X, Y).astype(np.float64)
    return (E[0] * invw[..., 0] + E[1] * invw[..., 1] + E[2] * invw[..., 2]) / area


# ------------------------------------------------------------------------------------------------------------
# fragments
# ------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Fragments:
    """One row per visible pixel, row-major (sorted by ``y``, then ``x``). All float arrays are float64.

    Attributes
    ----------
    width, height : int
        The image size.
    x, y : ndarray (K,), int64
        Pixel column (right) and row (**down**; row 0 is the top of the image).
    tri : ndarray (K,), int64
        Index of the scene triangle (:meth:`Scene.triangles`, file order, before clipping).
    material : ndarray (K,), int64
        Index into ``scene.materials``.
    front : ndarray (K,), bool
        False for a back face of a two-sided mesh (its ``N`` and ``A`` are negated here).
    U, V, W : ndarray (K,)
        Screen-linear homogeneous bump address ``k (u_b - tile_u) / w_c``, ``k (v_b - tile_v) / w_c``,
        ``k / w_c`` (bump repeat applied; ``k`` per rasterized triangle makes its largest vertex ``W`` equal to 1;
        the tile offset is free with the repeat wrap and keeps ``U / W`` near 0).
    Uc, Vc : ndarray (K,)
        The same for the color texture (color repeat, ``tile_c``); share ``W``.
    tile, tile_c : ndarray (K, 2)
        The rasterized triangle's integer tile offsets of the bump and color addresses: the middle of its vertices'
        address range, rounded to the nearest integer (triangle set-up; ``U = (s - tile_u) W``), so
        ``|U / W| <= span / 2 + 1 / 2``.
    wscale : ndarray (K,)
        ``k`` (world units): ``1 / w_c = W / k``.
    s, t : ndarray (K,)
        Exact perspective-correct bump address ``U / W``, ``V / W`` (not wrapped; 1 = one tile).
    sc, tc : ndarray (K,)
        Color address ``Uc / W``, ``Vc / W``.
    uv : ndarray (K, 2)
        Perspective-correct mesh ``(u, v)`` (no repeat).
    N : ndarray (K, 3)
        Perspective-correct interpolated vertex normal, world space, **not** renormalized (``|N| <= 1``).
    E : ndarray (K, 3)
        Unit eye vector ``normalize(camera - P)``, world space (local viewer).
    P : ndarray (K, 3)
        World position of the fragment.
    depth : ndarray (K,)
        ``w_c``, the distance along the view axis.
    A : ndarray (K, 3, 2)
        The triangle's matrix ``A`` (world space; ``A[:, :, 0]`` along ``+u``, ``A[:, :, 1]`` along ``+v``).
    tri_A : ndarray (T, 3, 2)
        ``A`` of every scene triangle (front-face sign).
    stats : dict
        Counts: ``triangles``, ``clipped``, ``rasterized`` (after clipping), ``culled``, ``degenerate``,
        ``covered`` (pixel visits before the z-test), ``fragments``; ``seconds`` per phase.
    """

    width: int
    height: int
    x: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    tri: np.ndarray = field(repr=False)
    material: np.ndarray = field(repr=False)
    front: np.ndarray = field(repr=False)
    U: np.ndarray = field(repr=False)
    V: np.ndarray = field(repr=False)
    W: np.ndarray = field(repr=False)
    Uc: np.ndarray = field(repr=False)
    Vc: np.ndarray = field(repr=False)
    tile: np.ndarray = field(repr=False)
    tile_c: np.ndarray = field(repr=False)
    wscale: np.ndarray = field(repr=False)
    s: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    sc: np.ndarray = field(repr=False)
    tc: np.ndarray = field(repr=False)
    uv: np.ndarray = field(repr=False)
    N: np.ndarray = field(repr=False)
    E: np.ndarray = field(repr=False)
    P: np.ndarray = field(repr=False)
    depth: np.ndarray = field(repr=False)
    A: np.ndarray = field(repr=False)
    tri_A: np.ndarray = field(repr=False)
    stats: dict = field(default_factory=dict)

    def __post_init__(self):
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)              # read-only: some arrays may share memory

    def __len__(self) -> int:
        return int(self.x.shape[0])

    @property
    def index(self) -> np.ndarray:
        """Linear pixel index ``y * width + x``."""
        return self.y * self.width + self.x

    def image(self, values, fill=0) -> np.ndarray:
        """Scatter per-fragment ``values`` ``(K, ...)`` into an image ``(height, width, ...)`` filled with
        ``fill`` where no fragment is."""
        values = np.asarray(values)
        out = np.empty((self.height, self.width) + values.shape[1:], dtype=values.dtype)
        out[...] = fill
        out[self.y, self.x] = values
        return out


@dataclass
class ScreenTriangles:
    """Steps 1-4 of :func:`rasterize` for a whole scene: the clipped, snapped, culled triangles, each oriented
    positively (``area2 > 0``), with their per-vertex clip-space attributes.

    ``sub`` ``(S, 3, 11)``: ``x_c, y_c, w_c``, world position ``P`` (3), normal ``N`` (3), mesh ``u, v`` per vertex;
    ``src`` the scene triangle of each; ``X, Y`` ``(S, 3)`` snapped coordinates; ``front`` False for a back face of
    a two-sided mesh (drawn with ``N`` and ``A`` negated); ``tri_A`` ``(T, 3, 2)`` per scene triangle.
    """

    tris: object
    T: int
    tri_A: np.ndarray
    bump_rep: np.ndarray
    color_rep: np.ndarray
    sub: np.ndarray
    src: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    front: np.ndarray
    clipped: int
    culled: int
    degenerate: int
    seconds: float


def screen_triangles(scene: Scene, gain) -> ScreenTriangles:
    """Project, clip, snap, cull and orient the triangles of ``scene`` (``gain``: ``a_gain`` per material)."""
    t0 = time.perf_counter()
    tris = scene.triangles()
    T = tris.positions.shape[0]
    bump_rep = np.array([m.bump.repeat if m.bump is not None else (1.0, 1.0) for m in scene.materials])
    color_rep = np.array([m.color.repeat for m in scene.materials])
    tri_A = triangle_matrix(tris.positions, tris.uvs, 1.0, gain[tris.material]) if T else np.zeros((0, 3, 2))

    # 1-2. clip space, clipping; vertex attributes: x_c, y_c, w_c, P(3), N(3), u, v
    clip = clip_space(scene, tris.positions)
    verts = np.concatenate([clip, tris.positions, tris.normals, tris.uvs], axis=-1)
    sub, src, n_clipped = clip_triangles(verts, _planes(scene))

    # 3-4. viewport, snapping, facing
    W_, H_ = scene.width, scene.height
    XY = snap(screen_space(sub[..., :3], W_, H_))                           # (S, 3, 2)
    X, Y = XY[..., 0], XY[..., 1]
    a2 = area2(X, Y)
    front = a2 < 0                      # CCW in the world's y-up view is clockwise in y-down pixel coordinates
    keep = (a2 != 0) & (front | tris.two_sided[src])
    n_degenerate = int(np.count_nonzero(a2 == 0))
    n_culled = int(np.count_nonzero((a2 != 0) & ~keep))
    sub, src, X, Y, front = sub[keep], src[keep], X[keep], Y[keep], front[keep]
    # orient every kept triangle positively (swap vertices 1, 2 of the front faces)
    swap = front
    sub[swap] = sub[swap][:, [0, 2, 1]]
    X[swap] = X[swap][:, [0, 2, 1]]
    Y[swap] = Y[swap][:, [0, 2, 1]]

    return ScreenTriangles(tris=tris, T=int(T), tri_A=tri_A, bump_rep=bump_rep, color_rep=color_rep, sub=sub,
                           src=src, X=X, Y=Y, front=front, clipped=int(n_clipped), culled=n_culled,
                           degenerate=n_degenerate, seconds=time.perf_counter() - t0)


def _gains(scene: Scene, maps) -> np.ndarray:
    if maps is None:
        return np.array([bump_gain(m) for m in scene.materials], dtype=np.float64)
    if len(maps) != len(scene.materials):
        raise ValueError(f"maps: expected {len(scene.materials)} (one per material), got {len(maps)}")
    return np.array([m.a_gain for m in maps], dtype=np.float64)


def vertex_attributes(scene: Scene, st: ScreenTriangles, exponent=None) -> dict:
    """The per-vertex values ``(S, 3)`` of every attribute the scan converter interpolates (see
    :mod:`fxmodel.units.raster`: ``U, V, Uc, Vc, W`` with a per-triangle tile offset, ``Z = near / w_c``, ``N W``,
    ``E_h = c (eye - P) / w_c``, ``A W 2**-e``), for the triangles of :func:`screen_triangles`, and the
    per-triangle block exponent ``Ae`` ``(S,)``: ``exponent[scene triangle]`` (:func:`host.bumpmap.block_exponent`;
    default 0)."""
    sub = st.sub
    invw = 1.0 / sub[..., 2]                                               # (S, 3)
    Wv = np.min(sub[..., 2], axis=1)[:, None] * invw
    mat = st.tris.material[st.src]
    uv = sub[..., 9:11]
    out = {"W": Wv, "Z": scene.camera.near * invw}
    for (u, v), rep in ((("U", "V"), st.bump_rep), (("Uc", "Vc"), st.color_rep)):
        tex = uv * rep[mat][:, None, :]
        tex = tex - np.floor(tex.mean(axis=1))[:, None, :]                 # the tile offset: the repeat wraps
        out[u], out[v] = tex[..., 0] * Wv, tex[..., 1] * Wv
    sign = np.where(st.front, 1.0, -1.0)[:, None]
    for i, c in enumerate("xyz"):
        out[f"N{c}"] = sub[..., 6 + i] * sign * Wv
    eye = (np.asarray(scene.camera.position, dtype=np.float64) - sub[..., 3:6]) * invw[..., None]
    eye /= np.sqrt(np.einsum("svi,svi->sv", eye, eye)).max(axis=1)[:, None, None]
    for i, c in enumerate("xyz"):
        out[f"E{c}"] = eye[..., i]
    e = np.zeros(len(st.src), np.int64) if exponent is None else np.asarray(exponent, np.int64)[st.src]
    out["Ae"] = e
    A = np.ldexp(st.tri_A[st.src] * sign[:, :, None], -e[:, None, None])     # (S, 3, 2): A 2^-e
    for i in range(3):
        for j in range(2):
            out[f"A{i}{j}"] = A[:, None, i, j] * Wv
    return out


def triangle_records(scene: Scene, params: RasterParams, maps=None, exponent=None, tile=None):
    """The scene as triangle records for the scan converter (the host's set-up, :func:`fxmodel.units.raster.setup`).

    Returns ``(records, tri, material)``: the :class:`~fxmodel.units.raster.Records`, and per record the scene triangle
    and material index. ``maps`` as :func:`rasterize`; ``exponent`` the block exponent of ``A`` per scene triangle
    (as :func:`vertex_attributes`). ``tile``: ``(x, y, width, height)``, the records of that tile of the picture
    (its top-left pixel ``x, y``), in its own coordinates (``setup``'s ``origin``), instead of the whole picture's.
    Raises ``ValueError`` for a triangle the preset cannot draw.
    """
    st = screen_triangles(scene, _gains(scene, maps))
    values = vertex_attributes(scene, st, exponent)
    names = params.names + tuple(n for n, _ in params.consts)
    values = {n: values[n] for n in names}
    if tile is None:
        recs = setup(params, st.X, st.Y, values, scene.width, scene.height)
    else:
        x, y, w, h = tile
        recs = setup(params, st.X, st.Y, values, w, h, origin=(x, y), picture=(scene.width, scene.height))
    tri = st.src[recs.source]
    return recs, tri, st.tris.material[tri]


def rasterize(scene: Scene, maps=None) -> Fragments:
    """Project, clip, set up, scan-convert and z-buffer ``scene``; return its visible fragments.

    Parameters
    ----------
    scene : Scene
    maps : sequence of host.bumpmap.MaterialMaps, optional
        Per material; only ``a_gain`` (``strength * scale``) is used, for ``A``. Pass the maps the pipeline
        uses so that ``A`` matches their scale. Default: :func:`host.bumpmap.bump_gain` with the bump
        engine's default ``d_fmt`` (the same numbers :func:`~host.bumpmap.scene_maps` gives). Repeats come
        from the scene.

    Returns
    -------
    Fragments
    """
    clock = [time.perf_counter()]
    st = screen_triangles(scene, _gains(scene, maps))
    tris, T, tri_A, bump_rep, color_rep = st.tris, st.T, st.tri_A, st.bump_rep, st.color_rep
    sub, src, X, Y, front = st.sub, st.src, st.X, st.Y, st.front
    W_, H_ = scene.width, scene.height
    n_clipped, n_culled, n_degenerate = st.clipped, st.culled, st.degenerate
    clock.append(time.perf_counter())
    # 5-6. scan conversion and z-buffer on 1/w
    invw_v = 1.0 / sub[..., 2]                                              # (S, 3)
    area = area2(X, Y).astype(np.float64)
    zbuf = np.zeros((H_, W_))
    owner = np.full((H_, W_), -1, dtype=np.int64)
    covered = 0
    for k in range(sub.shape[0]):
        px, py, E, order = scan_triangle(X[k], Y[k], W_, H_)
        if px.size == 0:
            continue
        covered += px.size
        iw = inverse_w(X[k], Y[k], invw_v[k], px, py)
        nearer = iw > zbuf[py, px]
        px, py = px[nearer], py[nearer]
        zbuf[py, px] = iw[nearer]
        owner[py, px] = k

    clock.append(time.perf_counter())
    # 7. attributes of the visible fragments, one rasterized triangle at a time (no big gathers)
    flat = np.flatnonzero(owner.ravel() >= 0)                               # row-major
    K = flat.size
    ys, xs = np.divmod(flat, W_)
    k_all = owner.ravel()[flat]
    perm = np.argsort(k_all, kind="stable")
    bounds = np.searchsorted(k_all[perm], np.arange(sub.shape[0] + 1))
    invw = np.empty(K)
    attr = np.empty((K, 8))                                                 # P(3), N(3), u, v
    for j in np.flatnonzero(np.diff(bounds)):
        sel = perm[bounds[j]:bounds[j + 1]]
        cx = xs[sel] * _ONE + _HALF
        cy = ys[sel] * _ONE + _HALF
        Xj, Yj = X[j], Y[j]
        lw = np.empty((sel.size, 3))
        for e in range(3):
            a, b = (e + 1) % 3, (e + 2) % 3
            Ee = (Xj[b] - Xj[a]) * (cy - Yj[a]) - (Yj[b] - Yj[a]) * (cx - Xj[a])     # exact int64
            lw[:, e] = Ee * (invw_v[j, e] / area[j])
        iw = lw.sum(axis=1)
        invw[sel] = iw
        vals = np.einsum("kv,va->ka", lw, sub[j, :, 3:])      # einsum, not BLAS: no thread start-up per call
        vals /= iw[:, None]
        attr[sel] = vals
    k = k_all
    P, N, uv = attr[:, 0:3], attr[:, 3:6], attr[:, 6:8]
    wscale = np.min(sub[..., 2], axis=1)[k]
    mat = tris.material[src[k]]
    sign = np.where(front[k], 1.0, -1.0)
    N *= sign[:, None]
    Wf = invw * wscale
    st = uv * bump_rep[mat]
    stc = st if np.array_equal(bump_rep, color_rep) else uv * color_rep[mat]
    # per-triangle integer tile offsets (free with the repeat wrap): the middle of the vertices' address range
    sub_mat = tris.material[src]
    sub_uv = (sub[..., 9:11].min(axis=1) + sub[..., 9:11].max(axis=1)) / 2          # (S, 2)
    tile_b = np.rint(sub_uv * bump_rep[sub_mat])[k]
    tile_c = np.rint(sub_uv * color_rep[sub_mat])[k]
    E_ = np.asarray(scene.camera.position, dtype=np.float64) - P
    E_ /= np.sqrt(np.einsum("ki,ki->k", E_, E_))[:, None]
    clock.append(time.perf_counter())
    stats = {"triangles": int(T), "clipped": int(n_clipped), "rasterized": int(sub.shape[0]),
             "culled": n_culled, "degenerate": n_degenerate, "covered": int(covered), "fragments": int(K),
             "seconds": dict(zip(("clip_setup", "scan_zbuffer", "attributes"),
                                 (float(x) for x in np.diff(clock))))}
    return Fragments(
        width=W_, height=H_, x=xs.astype(np.int64), y=ys.astype(np.int64), tri=src[k], material=mat,
        front=front[k], U=(st[:, 0] - tile_b[:, 0]) * Wf, V=(st[:, 1] - tile_b[:, 1]) * Wf, W=Wf,
        Uc=(stc[:, 0] - tile_c[:, 0]) * Wf, Vc=(stc[:, 1] - tile_c[:, 1]) * Wf, tile=tile_b, tile_c=tile_c,
        wscale=wscale, s=st[:, 0], t=st[:, 1], sc=stc[:, 0], tc=stc[:, 1], uv=uv, N=N, E=E_, P=P,
        depth=1.0 / invw, A=tri_A[src[k]] * sign[:, None, None], tri_A=tri_A, stats=stats)
