"""Mesh generators of the scene files (paper, section 3.2: every vertex carries a normal and texture
coordinates ``(u, v)``; section 5: the test objects are planes and spheres).

:func:`quad_mesh` (a planar parallelogram split into cells) and :func:`sphere_mesh` (a UV sphere with exact unit
normals) return frozen float64 arrays of positions, normals and texture coordinates per triangle corner; the
scene reader (:mod:`host.scene`) calls them for a mesh of ``kind = "quad"`` or ``"sphere"`` and documents the
texture-space conventions they follow.
"""

from __future__ import annotations

import numpy as np

__all__ = ["frozen_array", "quad_mesh", "sphere_mesh"]


def frozen_array(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array that cannot be written (the meshes of a frozen scene)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    a.setflags(write=False)
    return a


def quad_mesh(origin, edge_u, edge_v, uv=((0.0, 0.0), (1.0, 1.0)), divisions=(1, 1)):
    """A planar parallelogram split into ``2 * nu * nv`` triangles.

    Parameters
    ----------
    origin, edge_u, edge_v : array_like, shape (3,)
        The corner where ``(u, v) = uv[0]`` and the two edge vectors (along ``u`` and along ``v``).
    uv : ((u0, v0), (u1, v1))
        Texture coordinates at ``origin`` and at ``origin + edge_u + edge_v``.
    divisions : (nu, nv)
        Cells along ``u`` and ``v``.

    Returns
    -------
    positions, normals, uvs : ndarray, shapes (T, 3, 3), (T, 3, 3), (T, 3, 2)
        The front normal is ``normalize(edge_v x edge_u)`` (``u`` right, ``v`` down seen from the front); each
        triangle is counter-clockwise about it. Cells are split along the diagonal from ``(0, 0)`` to ``(1, 1)``.
    """
    o, eu, ev = (np.asarray(x, np.float64) for x in (origin, edge_u, edge_v))
    n = np.cross(ev, eu)
    n = n / np.linalg.norm(n)
    (u0, v0), (u1, v1) = uv
    nu, nv = divisions
    # one grid of vertices: a vertex shared by neighbouring cells is computed once (bit-identical, no cracks)
    a = np.arange(nu + 1) / nu
    b = np.arange(nv + 1) / nv
    grid_p = o + a[:, None, None] * eu + b[None, :, None] * ev                    # (nu + 1, nv + 1, 3)
    grid_uv = np.stack(np.broadcast_arrays(u0 + a[:, None] * (u1 - u0), v0 + b[None, :] * (v1 - v0)), -1)
    i, j = (x.ravel() for x in np.meshgrid(np.arange(nu), np.arange(nv), indexing="xy"))
    # corners of cell (i, j): c00, c10, c11, c01 (first index along u); counter-clockwise about
    # n = ev x eu is c00 -> c11 -> c10, and c00 -> c01 -> c11
    corner = {"00": (i, j), "10": (i + 1, j), "11": (i + 1, j + 1), "01": (i, j + 1)}
    tris = [("00", "11", "10"), ("00", "01", "11")]
    P = np.concatenate([np.stack([grid_p[corner[c]] for c in t], axis=1) for t in tris])
    UV = np.concatenate([np.stack([grid_uv[corner[c]] for c in t], axis=1) for t in tris])
    N = np.broadcast_to(n, P.shape)
    return frozen_array(P), frozen_array(N), frozen_array(UV)


def sphere_mesh(center, radius, segments=32, rings=16):
    """A tessellated UV sphere about the +y axis with analytic (exact, unit) vertex normals.

    ``u = phi / (2 pi)`` with longitude ``phi`` measured from +z toward +x, ``v = theta / pi`` with colatitude
    ``theta`` from the +y pole; seen from outside, ``u`` goes right and ``v`` down. Each pole row is a fan of
    ``segments`` triangles whose pole vertex sits at the middle of its segment's ``u`` range; the other rows have
    two triangles per cell. Triangles are counter-clockwise seen from outside.

    Returns
    -------
    positions, normals, uvs : ndarray, shapes (T, 3, 3), (T, 3, 3), (T, 3, 2), ``T = 2 segments (rings - 1)``
    """
    c = np.asarray(center, np.float64)
    # vertex grid by integer indices: ring i (0 .. rings), meridian j (0 .. segments); meridian `segments` is
    # meridian 0 again (same position and normal, bit for bit: no crack at the seam) but with u = 1
    i = np.arange(rings + 1)[:, None]
    j = np.arange(segments + 1)[None, :]
    phi = 2 * np.pi * (j % segments) / segments
    theta = np.pi * i / rings
    st = np.where((i == 0) | (i == rings), 0.0, np.sin(theta))       # exact poles: sin(pi) != 0 in floats
    ct = np.where(i == 0, 1.0, np.where(i == rings, -1.0, np.cos(theta)))
    d = np.stack(np.broadcast_arrays(st * np.sin(phi), ct, st * np.cos(phi)), -1)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)                 # (rings + 1, segments + 1, 3)
    uvg = np.stack(np.broadcast_arrays(j / segments, i / rings), -1).astype(np.float64)

    def pole_uv(v):
        return np.stack([(np.arange(segments) + 0.5) / segments, np.full(segments, float(v))], -1)

    js = np.arange(segments)
    tris_d, tris_uv = [], []
    for r in range(rings):
        a, b = (r, js), (r, js + 1)                  # ring r, meridians j and j + 1
        cc, dd = (r + 1, js), (r + 1, js + 1)        # ring r + 1
        if r == 0:
            tris_d.append(np.stack([d[0, js], d[cc], d[dd]], 1))
            tris_uv.append(np.stack([pole_uv(0.0), uvg[cc], uvg[dd]], 1))
        elif r == rings - 1:
            tris_d.append(np.stack([d[a], d[rings, js], d[b]], 1))
            tris_uv.append(np.stack([uvg[a], pole_uv(1.0), uvg[b]], 1))
        else:
            tris_d += [np.stack([d[a], d[cc], d[dd]], 1), np.stack([d[a], d[dd], d[b]], 1)]
            tris_uv += [np.stack([uvg[a], uvg[cc], uvg[dd]], 1), np.stack([uvg[a], uvg[dd], uvg[b]], 1)]
    N = np.concatenate(tris_d)
    UV = np.concatenate(tris_uv)
    P = c + radius * N
    return frozen_array(P), frozen_array(N), frozen_array(UV)
