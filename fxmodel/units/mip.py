r"""Fixed-point MIP pyramid of a texture's codes, built on the host once per texture (paper section 6: "artifact
reduced MIP mapping", the next step the paper names; the trilinear sampler of :mod:`fxmodel.units.sampler` reads it).

The pyramid is data, like the texel codes it is made of: it is computed from the stored codes (not from the
procedural texture) in exact integer arithmetic and rounded **once per texel**, so the hardware's memory holds
exactly what this function returns and reference (a) reads the same levels.

Filter: the area box
--------------------
Level ``l + 1`` has ``max(1, n // 2)`` texels along an axis of ``n`` texels at level ``l`` (a 64-texel map goes 64,
32, ..., 1; the 40-texel bump map of the paper's Fig. 9 goes 40, 20, 10, 5, 2, 1). Each of its texels is the
**area average** of level 0 over the square it covers: for power-of-two sizes the 2 x 2 box of the level
before, in general texel ``j`` of an ``m``-texel level averages level 0's ``[j N / m, (j + 1) N / m)`` (``N``
texels at level 0), partial texels weighted by the part covered. Why the box (the float study,
``host/mipmap.py`` and ``bumpmap filtering``, measured it against a wider tent): a texel stands for the mean of
the surface it covers and the box is that mean exactly, it keeps the map's mean (a checker's far field is its mean
grey, as in the true image), it has no negative lobes (no ringing, no code outside the range of the texels it
averages), and the bilinear lookup within a level and the blend between two levels widen it to a tent anyway.

Rounding and range
------------------
Every level is computed **from level 0** (one integer weight matrix per axis, :func:`box_weights`, over the
denominator ``H W``: exact integers), and narrowed once, ``Rounding.HALF_UP`` (``floor((2 S + D) / 2 D)``
for the weighted sum ``S`` over the denominator ``D``, also for negative codes). So each stored code is the exact
area average of level 0 rounded to the nearest code, with no error accumulating from level to level. For
power-of-two sizes that is the float study's pyramid (``host.mipmap.pyramid``, box kernel, which averages each
level from the one before) within half a code; on an odd size the two differ: the box of a box weighs a level-0
texel by which level-1 texel it fell in, this one by the area it shares with the new texel. Overflow: ``PROVEN`` -- a
convex combination of codes lies between the smallest and largest of them, and rounding to the nearest integer
keeps it there, so every level holds codes of the channel's format.
"""

from __future__ import annotations

import numpy as np

__all__ = ["box_weights", "mip_sizes", "mip_pyramid"]


def mip_sizes(height: int, width: int, levels: int | None = None) -> list:
    """``(height, width)`` of each level, level 0 first, down to ``1 x 1`` (or ``levels`` levels)."""
    out = [(int(height), int(width))]
    while max(out[-1]) > 1 and (levels is None or len(out) < levels):
        h, w = out[-1]
        out.append((max(1, h // 2), max(1, w // 2)))
    return out


def box_weights(n: int, m: int) -> np.ndarray:
    """Integer area weights ``(m, n)`` (object array) of the box from ``n`` texels (level 0) to ``m``, over the
    denominator ``n``: row ``j`` weighs source texel ``i`` by ``|[j n, (j + 1) n) & [i m, (i + 1) m)|`` (the
    overlap in units of ``1 / m`` texel; each row sums to ``n``)."""
    out = np.zeros((m, n), dtype=object)
    for j in range(m):
        for i in range(n):
            out[j, i] = max(0, min((j + 1) * n, (i + 1) * m) - max(j * n, i * m))
    return out


def mip_pyramid(codes, levels: int | None = None) -> list:
    """The MIP levels of integer codes ``(H, W, C)``: a list of ``int64`` arrays, level 0 the codes themselves,
    down to one texel (or ``levels`` levels); see the module docstring for the filter and the rounding."""
    img = np.asarray(codes)
    if img.ndim != 3 or not np.issubdtype(img.dtype, np.integer):
        raise ValueError(f"codes: must be integer codes of shape (H, W, C), not {img.dtype} {img.shape}")
    if levels is not None and (not isinstance(levels, int) or levels < 1):
        raise ValueError(f"levels={levels!r}: must be a positive int or None")
    sizes = mip_sizes(img.shape[0], img.shape[1], levels)
    base = img.astype(object)
    H, W = sizes[0]
    out = [np.asarray(img, dtype=np.int64)]
    for h, w in sizes[1:]:
        s = np.einsum("jh,hwc->jwc", box_weights(H, h), base)     # each level from level 0: over H, then W
        s = np.einsum("iw,jwc->jic", box_weights(W, w), s)
        d = H * W
        lvl = (2 * s + d) // (2 * d)                  # half-up, exact for negative sums (floor division)
        out.append(np.array(lvl.tolist(), dtype=np.int64).reshape(h, w, img.shape[2]))
    return out
