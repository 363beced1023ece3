"""Front end (host.frontend): top-left fill rule, perspective-correct attributes, clipping, culling, z-buffer.

Coverage is checked against exact rational edge functions: vertices are multiples of 1/256 pixel and pixel
centers multiples of 1/2, so in units of 1/512 pixel every edge function is an exact integer.
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fxmodel.core.paths import SCENES
from fxmodel.units.bump import BumpParams
from fxmodel.units.persp import PerspParams
from host.frontend import SUBPIXEL_BITS, clip_space, rasterize, scan_triangle, screen_space, snap
from host.scene import load_scene, parse_scene

SIZE = 24                          # viewport of the coverage tests, pixels
ONE = 1 << SUBPIXEL_BITS


# -- exact reference ------------------------------------------------------------------------------------------
def centers(size=SIZE):
    """Pixel centers in units of 1/512 pixel, (size*size, 2), row-major."""
    y, x = np.mgrid[0:size, 0:size]
    return np.stack([(2 * x.ravel() + 1) * ONE, (2 * y.ravel() + 1) * ONE], axis=1)


def orient(a, b, p):
    """Exact edge function of (a -> b) at points p, all in 1/512 pixel (integers)."""
    return (b[0] - a[0]) * (p[:, 1] - a[1]) - (b[1] - a[1]) * (p[:, 0] - a[0])


def closed_inside(tri, p):
    """Points in the closed triangle (either winding)."""
    e = [orient(tri[i], tri[(i + 1) % 3], p) for i in range(3)]
    return ((e[0] >= 0) & (e[1] >= 0) & (e[2] >= 0)) | ((e[0] <= 0) & (e[1] <= 0) & (e[2] <= 0))


def coverage_count(tris, size=SIZE):
    count = np.zeros(size * size, dtype=np.int64)
    for tri in tris:
        px, py, _, _ = scan_triangle([v[0] for v in tri], [v[1] for v in tri], size, size)
        np.add.at(count, py * size + px, 1)
    return count


def check_tiling(tris, outer_edges):
    """Every pixel center inside the union and off its outer boundary is visited exactly once; outside, never."""
    p = centers()
    x2 = [[(2 * v[0], 2 * v[1]) for v in tri] for tri in tris]             # to 1/512 pixel
    inside = np.zeros(len(p), bool)
    for tri in x2:
        inside |= closed_inside(tri, p)
    on_outer = np.zeros(len(p), bool)
    for a, b in outer_edges:
        a2, b2 = (2 * a[0], 2 * a[1]), (2 * b[0], 2 * b[1])
        lo, hi = np.minimum(a2, b2), np.maximum(a2, b2)
        on_outer |= (orient(a2, b2, p) == 0) & np.all((p >= lo) & (p <= hi), axis=1)
    count = coverage_count(tris)
    assert count.max(initial=0) <= 1
    assert np.all(count[inside & ~on_outer] == 1), "gap inside the union"
    assert np.all(count[~inside] == 0), "pixel outside every triangle"
    return count, inside, on_outer


# coordinates in 1/256 pixel, biased toward pixel centers and pixel corners (exact ties)
coord = st.one_of(st.integers(-3 * ONE, (SIZE + 3) * ONE),
                  st.integers(-2, SIZE + 2).map(lambda k: k * ONE + ONE // 2),
                  st.integers(-2, SIZE + 2).map(lambda k: k * ONE))
point = st.tuples(coord, coord)


def side(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


# -- top-left rule -------------------------------------------------------------------------------------------
@given(point, point, point, point)
def test_two_triangles_sharing_an_edge_cover_once(a, b, c, d):
    assume(side(a, b, c) * side(a, b, d) < 0)                   # c and d strictly on opposite sides of ab
    check_tiling([(a, b, c), (b, a, d)], [(b, c), (c, a), (a, d), (d, b)])


@settings(suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(st.data())
def test_fan_around_a_vertex_covers_once(data):
    """A closed fan of 3..8 triangles around a center (often exactly a pixel center): the center's pixel and
    every pixel on a spoke are visited exactly once. Random angles are rejected until no gap is wider than
    0.9 pi or narrower than 0.05 (most draws of 3 angles are): the filter health check would fail at random."""
    c = data.draw(st.one_of(point, st.tuples(st.integers(4, SIZE - 4), st.integers(4, SIZE - 4)).map(
        lambda q: (q[0] * ONE + ONE // 2, q[1] * ONE + ONE // 2))))
    k = data.draw(st.integers(3, 8))
    angles = np.sort(np.array(data.draw(st.lists(st.floats(0, 2 * np.pi, exclude_max=True), min_size=k,
                                                 max_size=k, unique=True))))
    gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
    assume(gaps.max() < 0.9 * np.pi and gaps.min() > 0.05)
    radii = data.draw(st.lists(st.integers(2 * ONE, 14 * ONE), min_size=k, max_size=k))
    snap_to = data.draw(st.sampled_from([1, ONE // 2]))         # sometimes on pixel-center/corner lattices
    pts = [(c[0] + int(r * np.cos(t)) // snap_to * snap_to, c[1] + int(r * np.sin(t)) // snap_to * snap_to)
           for r, t in zip(radii, angles)]
    tris = [(c, pts[i], pts[(i + 1) % k]) for i in range(k)]
    signs = [np.sign(side(*t)) for t in tris]
    assume(all(s == signs[0] != 0 for s in signs))                 # still a proper fan after snapping
    count, inside, on_outer = check_tiling(tris, [(pts[i], pts[(i + 1) % k]) for i in range(k)])
    if (c[0] - ONE // 2) % ONE == 0 and (c[1] - ONE // 2) % ONE == 0 and 0 <= c[0] < SIZE * ONE \
            and 0 <= c[1] < SIZE * ONE:
        assert count[(c[1] // ONE) * SIZE + c[0] // ONE] == 1         # the shared vertex's own pixel


def test_known_ties():
    """Hand cases: a square of two triangles whose edges run through pixel centers."""
    h = ONE // 2
    a, b, c, d = (1 * ONE + h, 1 * ONE + h), (5 * ONE + h, 1 * ONE + h), (5 * ONE + h, 5 * ONE + h), \
        (1 * ONE + h, 5 * ONE + h)
    count = coverage_count([(a, b, c), (a, c, d)])
    grid = count.reshape(SIZE, SIZE)
    # top edge (y = 1) and left edge (x = 1) included; bottom (y = 5) and right (x = 5) excluded; diagonal once
    assert grid[1:5, 1:5].sum() == 16 and np.all(grid[1:5, 1:5] == 1) and grid.sum() == 16
    # either winding gives the same pixels
    assert np.array_equal(coverage_count([(a, c, b)]), coverage_count([(a, b, c)]))


# -- perspective-correct interpolation ------------------------------------------------------------------------
CAMERA = """
[image]
width = {w}
height = {h}

[camera]
position = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
up = [0.0, 1.0, 0.0]
fov = 90.0
near = {near}
far = 100.0

[[materials]]
name = "m"
color = [1.0, 1.0, 1.0]
"""


def fmt_list(a):
    return "[" + ", ".join("[" + ", ".join(repr(float(x)) for x in row) + "]" for row in a) + "]"


def triangles_toml(P, uv, N=None, material="m", two_sided=False):
    text = f'\n[[meshes]]\nkind = "triangles"\nmaterial = "{material}"\ntwo_sided = {str(two_sided).lower()}\n'
    text += f"positions = {fmt_list(P)}\nuvs = {fmt_list(uv)}\n"
    if N is not None:
        text += f"normals = {fmt_list(N)}\n"
    return text


def exact_hit(P, px, py, size):
    """Fractions (alpha, beta, t): pixel center ray (xn, yn, -1) t = P0 + alpha e1 + beta e2 (camera at 0, f = 1)."""
    xn = Fraction(2 * px + 1, size) - 1
    yn = 1 - Fraction(2 * py + 1, size)
    P = [[Fraction(float(x)) for x in v] for v in P]
    e1 = [P[1][i] - P[0][i] for i in range(3)]
    e2 = [P[2][i] - P[0][i] for i in range(3)]
    d = [xn, yn, Fraction(-1)]
    # alpha e1 + beta e2 - t d = -P0 (Cramer)
    cols = [e1, e2, [-x for x in d]]
    rhs = [-x for x in P[0]]

    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    M = [[cols[j][i] for j in range(3)] for i in range(3)]
    D = det(M)
    out = []
    for j in range(3):
        Mj = [[rhs[i] if jj == j else M[i][jj] for jj in range(3)] for i in range(3)]
        out.append(det(Mj) / D)
    return out, d


@given(st.lists(st.integers(-56, 56), min_size=6, max_size=6), st.lists(st.integers(1, 16), min_size=3, max_size=3),
       st.lists(st.floats(-2, 2), min_size=6, max_size=6), st.lists(st.floats(-1, 1), min_size=9, max_size=9),
       st.randoms(use_true_random=False))
def test_perspective_correct_attributes_are_exact(ab, ws, uvs, nrm, rnd):
    """Vertices P = w (a, b, -1) project onto the subpixel grid, so the snapped triangle is the true one; at
    every pixel center, s, t, N, depth, W and E equal the exact values of the ray-triangle hit."""
    size = 32
    a = np.array(ab[:3]) / 64
    b = np.array(ab[3:]) / 64
    w = np.array(ws) / 2.0
    P = np.stack([a * w, b * w, -w], axis=1)
    uv = np.array(uvs).reshape(3, 2)
    N = np.array(nrm).reshape(3, 3)
    assume(np.all(np.linalg.norm(N, axis=1) > 0.1))
    sx, sy = (a + 1) * size / 2, (1 - b) * size / 2
    area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0])
    assume(abs(area) > 4)
    if area > 0:                                     # make it front-facing: counter-clockwise on screen, y up
        P, uv, N = P[[0, 2, 1]], uv[[0, 2, 1]], N[[0, 2, 1]]
    scene = parse_scene(CAMERA.format(w=size, h=size, near=0.1) + triangles_toml(P, uv, N))
    fr = rasterize(scene)
    # the pixel set is the top-left coverage of the exactly known screen triangle
    X = np.rint((P[:, 0] / -P[:, 2] + 1) * size / 2 * ONE).astype(np.int64)
    Y = np.rint((1 - P[:, 1] / -P[:, 2]) * size / 2 * ONE).astype(np.int64)
    px, py, _, _ = scan_triangle(X, Y, size, size)
    assert sorted(zip(py, px)) == list(zip(fr.y, fr.x))
    assume(len(fr) > 0)
    Nn = N / np.linalg.norm(N, axis=1, keepdims=True)              # the parser normalizes vertex normals
    for i in rnd.sample(range(len(fr)), min(len(fr), 25)):
        (al, be, t), d = exact_hit(P, int(fr.x[i]), int(fr.y[i]), size)
        lam = [1 - al - be, al, be]
        for c in range(2):
            want = float(sum(Fraction(float(uv[v, c])) * lam[v] for v in range(3)))
            assert fr.uv[i, c] == pytest.approx(want, abs=1e-9)
        assert fr.s[i] == pytest.approx(fr.uv[i, 0], abs=1e-15) and fr.t[i] == fr.uv[i, 1]   # repeat 1
        n_want = [float(sum(Fraction(float(Nn[v, c])) * lam[v] for v in range(3))) for c in range(3)]
        assert np.allclose(fr.N[i], n_want, atol=1e-9)
        assert fr.depth[i] == pytest.approx(float(t), rel=1e-9)
        assert fr.W[i] == pytest.approx(float(min(w) / t), rel=1e-9)
        e = -np.array([float(x * t) for x in d])
        assert np.allclose(fr.E[i], e / np.linalg.norm(e), atol=1e-9)
        assert np.allclose(fr.P[i], [float(x * t) for x in d], atol=1e-9)
    assert np.allclose(fr.U / fr.W + fr.tile[:, 0], fr.s, rtol=1e-12, atol=1e-12)
    assert np.allclose(fr.V / fr.W + fr.tile[:, 1], fr.t, atol=1e-12)
    assert np.array_equal(fr.tile, np.rint(fr.tile))
    assert fr.W.max() <= 1 + 1e-12 and np.allclose(fr.W, fr.wscale / fr.depth, rtol=1e-12)
    assert np.all(np.linalg.norm(fr.N, axis=1) <= 1 + 1e-12)                  # never renormalized


def test_tile_offset_keeps_the_address_near_zero_whatever_the_repeat():
    """Range normalization in the set-up: a triangle far out in texture space (uv offset by 1000 tiles, repeat
    37) gets U / W within half its span (plus rounding) of 0, and the same wrapped address."""
    from host.scene import parse_scene
    fr = rasterize(parse_scene(TILED))
    span = 37 / 2 + 0.5
    assert len(fr) > 100 and np.abs(fr.U / fr.W).max() <= span and np.abs(fr.V / fr.W).max() <= span
    assert np.abs(fr.s).max() > 1000 and np.allclose(np.mod(fr.U / fr.W, 1), np.mod(fr.s, 1), atol=1e-9)


#: A quad far out in texture space (uv offset by 1000 tiles), bump-mapped with repeat 37, in front of CAMERA.
TILED = CAMERA.format(w=32, h=32, near=0.1) + """
[materials.bump]
procedural = "mexican-hat"
size = [8, 8]
repeat = [37, 37]
[[meshes]]
kind = "quad"
material = "m"
origin = [-1.0, -1.0, -1.5]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 2.0, 0.0]
uv = [[1000.0, 1000.0], [1001.0, 1001.0]]
two_sided = true
"""


# -- clipping ---------------------------------------------------------------------------------------------------
def floor_scene(size, near, divisions=(1, 1)):
    return parse_scene(CAMERA.format(w=size, h=size, near=near) + f"""
[[meshes]]
kind = "quad"
material = "m"
origin = [-4.0, -0.2, -6.0]
edge_u = [8.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 10.0]          # reaches z = 4, behind the camera: the near plane cuts it
divisions = [{divisions[0]}, {divisions[1]}]
""")


@pytest.mark.parametrize("divisions", [(1, 1), (3, 2)])
def test_near_plane_clipping_keeps_covered_pixels(divisions):
    size, near = 48, 0.5
    fr = rasterize(floor_scene(size, near, divisions))
    assert fr.stats["clipped"] >= 1 and fr.stats["covered"] == len(fr)        # no pixel visited twice
    y, x = np.mgrid[0:size, 0:size]
    xn, yn = (2 * x + 1) / size - 1, 1 - (2 * y + 1) / size
    with np.errstate(divide="ignore"):
        t = np.where(yn < 0, -0.2 / yn, np.inf)                            # ray hits the floor at w = t
    hx, hz = t * xn, -t
    margin = 0.02
    definitely_in = (yn < 0) & (t >= near * (1 + margin)) & (np.abs(hx) <= 4 - margin) & (hz >= -6 + margin)
    definitely_out = (yn >= 0) | (t <= near * (1 - margin)) | (np.abs(hx) >= 4 + margin) | (hz <= -6 - margin)
    got = np.zeros((size, size), bool)
    got[fr.y, fr.x] = True
    assert definitely_in.sum() > 300 and np.all(got[definitely_in]) and not np.any(got[definitely_out])
    assert np.any((yn < 0) & (t < near))                     # the near plane really removes floor pixels
    # attributes stay perspective-correct after clipping: u = (x + 4) / 8, v = (z + 6) / 10 at the hit
    assert np.allclose(fr.s, (hx[fr.y, fr.x] + 4) / 8, atol=2e-3)
    assert np.allclose(fr.t, (hz[fr.y, fr.x] + 6) / 10, atol=2e-3)
    assert np.allclose(fr.depth, t[fr.y, fr.x], rtol=2e-3)
    assert fr.W.max() <= 1 + 1e-12 and fr.depth.min() >= near * (1 - 1e-3)


# -- faces, z-buffer, mesh tiling -----------------------------------------------------------------------------
TRI = np.array([[-1.0, -1.0, -3.0], [1.0, -1.0, -3.0], [0.0, 1.0, -3.0]])     # counter-clockwise seen from 0
TRI_UV = np.array([[0.0, 1.0], [1.0, 1.0], [0.5, 0.0]])


def test_back_faces_culled_or_drawn_negated():
    bumpy = '\n[[materials]]\nname = "b"\ncolor = [1.0, 1.0, 1.0]\n[materials.bump]\nprocedural = "mexican-hat"\n'
    base = CAMERA.format(w=32, h=32, near=0.1) + bumpy
    front = rasterize(parse_scene(base + triangles_toml(TRI, TRI_UV, material="b")))
    assert len(front) > 30 and front.front.all() and front.stats["culled"] == 0
    assert np.allclose(front.N, [0, 0, 1]) and np.all(front.E[:, 2] > 0)
    A = front.A[0]
    assert A[0, 0] > 0 and A[1, 1] < 0                              # u along +x, v down (-y)
    rev = TRI[[0, 2, 1]], TRI_UV[[0, 2, 1]]
    culled = rasterize(parse_scene(base + triangles_toml(*rev, material="b")))
    assert len(culled) == 0 and culled.stats["culled"] == 1
    both = rasterize(parse_scene(base + triangles_toml(*rev, material="b", two_sided=True)))
    assert list(zip(both.y, both.x)) == list(zip(front.y, front.x))          # same pixels (same edges)
    assert not both.front.any()
    # its vertex normals (face normals of the reversed winding) point away, (0, 0, -1); drawn negated, the
    # normal of the side we see faces the viewer
    assert np.allclose(both.N, [0, 0, 1])
    assert np.allclose(both.A, -both.tri_A[both.tri])


def test_zbuffer_keeps_the_nearest_whatever_the_order():
    mats = '\n[[materials]]\nname = "far"\ncolor = [0.0, 0.0, 0.0]\n'
    near_tri = triangles_toml(TRI, TRI_UV, material="m")
    far_tri = triangles_toml(TRI * [2.0, 2.0, 1.5] + [0.3, 0.0, 0.0], TRI_UV, material="far")
    base = CAMERA.format(w=32, h=32, near=0.1) + mats
    a = rasterize(parse_scene(base + near_tri + far_tri))
    b = rasterize(parse_scene(base + far_tri + near_tri))
    only_near = rasterize(parse_scene(base + near_tri))
    for fr in (a, b):
        assert fr.stats["covered"] > len(fr)                                 # they overlap
        img = fr.image(fr.material, fill=-1)
        assert np.all(img[only_near.y, only_near.x] == 0)                   # material "m" is the near one
        assert np.all(fr.depth[fr.material == 0] < 3.0 + 1e-9)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.y, b.y) and np.array_equal(a.material, b.material)


def test_subdivided_quad_has_no_gaps_or_overlaps():
    scene = parse_scene(CAMERA.format(w=64, h=64, near=0.1) + """
[[meshes]]
kind = "quad"
material = "m"
origin = [-1.3, 0.9, -3.0]
edge_u = [2.5, 0.4, -1.0]
edge_v = [0.2, -2.0, 0.5]
divisions = [7, 5]
""")
    fr = rasterize(scene)
    assert fr.stats["rasterized"] == 70 and fr.stats["covered"] == len(fr)    # every pixel visited once
    corners = np.array([[-1.3, 0.9, -3.0], [1.2, 1.3, -4.0], [1.4, -0.7, -3.5], [-1.1, -1.1, -2.5]])
    sc = screen_space(clip_space(scene, corners), 64, 64)
    y, x = np.mgrid[0:64, 0:64]
    p = np.stack([x.ravel() + 0.5, y.ravel() + 0.5], 1)
    e = [(sc[(i + 1) % 4, 0] - sc[i, 0]) * (p[:, 1] - sc[i, 1]) - (sc[(i + 1) % 4, 1] - sc[i, 1]) * (p[:, 0] - sc[i, 0])
         for i in range(4)]
    lens = [np.hypot(*(sc[(i + 1) % 4] - sc[i])) for i in range(4)]
    dist = np.stack([e[i] / lens[i] for i in range(4)])                       # signed distance to each edge
    dist = dist if dist.mean() > 0 else -dist
    got = np.zeros(64 * 64, bool)
    got[fr.index] = True
    assert np.all(got[np.all(dist > 0.01, axis=0)]) and not np.any(got[np.any(dist < -0.01, axis=0)])


def test_fragments_are_row_major_and_unique():
    fr = rasterize(load_scene(SCENES / "sphere.toml", size=48))
    idx = fr.index
    assert np.all(np.diff(idx) > 0)
    with pytest.raises(ValueError):
        fr.W[0] = 2.0                                                          # read-only


def test_snap_rounds_to_the_subpixel_grid():
    assert list(snap([0.5, 1.0 / 512 - 1e-12, 3.0 - 1e-13])) == [128, 0, 768]


# -- shipped scenes ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["tin-plane", "berlin-wall", "sphere"])
def test_shipped_scenes_rasterize_into_the_pipeline_formats(name):
    scene = load_scene(SCENES / f"{name}.toml", size=(64, 64))
    fr = rasterize(scene)
    assert len(fr) > 64 * 64 // 4 and fr.stats["covered"] >= len(fr)
    assert len(np.unique(fr.material)) == 1                  # the pipeline holds one material's maps
    uv_fmt, w_fmt = PerspParams().uv_fmt, PerspParams().recip.in_fmt
    n_fmt, a_fmt = BumpParams().n_fmt, BumpParams().a_fmt
    assert np.abs(np.r_[fr.U, fr.V, fr.Uc, fr.Vc]).max() < float(uv_fmt.max_value)
    assert fr.W.min() > 2 ** -4 and fr.W.max() <= 1 + 1e-12 and float(w_fmt.max_value) > 1
    assert np.all(np.linalg.norm(fr.N, axis=1) <= 1 + 1e-12) and np.abs(fr.N).max() < float(n_fmt.max_value)
    assert np.allclose(np.linalg.norm(fr.E, axis=1), 1.0)
    assert np.all(np.einsum("ki,ki->k", fr.E, np.asarray(scene.camera.position) - fr.P) > 0)
    assert np.abs(fr.A).max() < float(a_fmt.max_value)
    assert np.all(np.einsum("ki,ki->k", fr.N, fr.E) > -0.3)                  # visible side (interpolated N)


def test_tessellated_sphere_has_no_holes():
    """A lone sphere: every pixel visited at most once (back faces culled, front faces never overlap) and every
    pixel well inside the silhouette covered (shared edges, the u seam and the pole fans leave no gap)."""
    size, dist, r = 64, 4.0, 1.0
    scene = parse_scene(CAMERA.format(w=size, h=size, near=0.1) + f"""
[[meshes]]
kind = "sphere"
material = "m"
center = [0.0, 0.0, {-dist}]
radius = {r}
segments = 13
rings = 7
""")
    fr = rasterize(scene)
    assert fr.stats["covered"] == len(fr) and fr.stats["culled"] > 0
    rad = np.tan(np.arcsin(r / dist)) * size / 2                             # projected radius, pixels (f = 1)
    y, x = np.mgrid[0:size, 0:size]
    dist_px = np.hypot(x + 0.5 - size / 2, y + 0.5 - size / 2)
    got = np.zeros((size, size), bool)
    got[fr.y, fr.x] = True
    inner = np.cos(np.pi / 13) * np.cos(np.pi / 7)                           # the polyhedron's inscribed part
    assert np.all(got[dist_px < 0.97 * inner * rad]) and not np.any(got[dist_px > rad + 0.5])
