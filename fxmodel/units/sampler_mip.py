"""Trilinear sampling (MIP mapping), step 5 of :mod:`fxmodel.units.sampler`: the texel memories and their MIP
levels, the level and blend weight from the level of detail, each level's bilinear blends (exact, or narrowed by
``blend_frac``) and the blend between the two levels. :class:`TrilinearSampling` is a part of
:class:`fxmodel.units.sampler.SamplerParams` (its fields and the bilinear steps are there); the algorithm and the
error bound are in that module's docstring.
"""

from __future__ import annotations

import hashlib
from functools import cached_property

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import require
from fxmodel.units.mip import mip_pyramid, mip_sizes

__all__ = ["Texels", "mip_texels", "TrilinearSampling"]


class Texels:
    """A read-only texel memory: codes of shape ``(faces, height, width, channels)``.

    Compared and hashed by content (a SHA-1 digest), so parameter objects holding one stay hashable and their
    ``repr`` (used to key build caches) is short.
    """

    def __init__(self, codes):
        arr = np.array(codes, dtype=np.int64)
        if arr.ndim != 4:
            raise ValueError(f"texels must have shape (faces, height, width, channels), not {arr.shape}")
        arr.setflags(write=False)
        self.codes = arr
        self.digest = hashlib.sha1(repr(arr.shape).encode() + arr.tobytes()).hexdigest()

    @property
    def shape(self):
        return self.codes.shape

    def __eq__(self, other):
        return isinstance(other, Texels) and other.digest == self.digest

    def __hash__(self):
        return hash(self.digest)

    def __repr__(self):
        return f"Texels(shape={self.shape}, sha1={self.digest[:12]})"


def mip_texels(texels: Texels, levels: int | None = None) -> tuple:
    """The MIP levels 1, 2, ... of a one-face map (``mips`` of :class:`SamplerParams`), by
    :func:`fxmodel.units.mip.mip_pyramid`: down to ``1 x 1``, or ``levels`` levels in all (level 0 included)."""
    faces = texels.shape[0]
    if faces != 1:
        raise ValueError(f"texels: a MIP pyramid needs one face, not {faces}")
    return tuple(Texels(lv[None]) for lv in mip_pyramid(texels.codes[0], levels)[1:])


class TrilinearSampling:
    """The trilinear part of :class:`fxmodel.units.sampler.SamplerParams` (step 5): its checks, the level
    memories and the bit-exact level blend."""

    def _check_trilinear(self):
        require(self.faces == 1 and self.edge in ("repeat", "clamp"), "filter", self.filter,
                "trilinear needs one face and the repeat or clamp edge rule")
        require(isinstance(self.lod_fmt, Fmt) and self.lod_fmt.signed, "lod_fmt", self.lod_fmt,
                "must be a signed Fmt (the LOD unit's out_fmt)")
        require(isinstance(self.level_bits, int) and 1 <= self.level_bits <= self.lod_fmt.frac_bits, "level_bits",
                self.level_bits, f"must be an int in 1..{self.lod_fmt.frac_bits} (lod_fmt's fraction bits)")
        require(len(self.mips) >= 1, "mips", self.mips, "trilinear needs at least one level beyond level 0")
        sizes = mip_sizes(self.height, self.width, 1 + len(self.mips))
        require(isinstance(self.mips, tuple) and all(isinstance(m, Texels) for m in self.mips)
                and [m.shape for m in self.mips] == [(1, h, w, len(self.channels)) for h, w in sizes[1:]],
                "mips", self.mips, f"must be Texels of the level sizes {sizes[1:]} (mip_texels)")
        for m in self.mips:
            for k, fmt in enumerate(self.channels):
                col = m.codes[..., k]
                require(bool(np.all((col >= fmt.min_code) & (col <= fmt.max_code))), "mips", m,
                        f"channel {k} has codes outside {fmt}")

    @property
    def levels(self) -> int:
        """MIP levels (1 unless trilinear)."""
        return 1 + len(self.mips)

    @cached_property
    def level_sizes(self) -> tuple:
        """``(height, width)`` of each level."""
        return tuple((self.height, self.width) if lv == 0 else self.mips[lv - 1].shape[1:3]
                     for lv in range(self.levels))

    @cached_property
    def level_bases(self) -> tuple:
        """Base address of each level in its parity's memory (even levels in one, odd in the other)."""
        bases, used = [], [0, 0]
        for lv, (h, w) in enumerate(self.level_sizes):
            bases.append(used[lv % 2])
            used[lv % 2] += h * w
        return tuple(bases)

    def level_codes(self, lv: int) -> np.ndarray:
        """Codes ``(1, H_l, W_l, channels)`` of level ``lv``."""
        return self.texels.codes if lv == 0 else self.mips[lv - 1].codes

    @cached_property
    def parity_words(self) -> tuple:
        """The two level memories' words (even levels, odd levels), each level row-major at its base."""
        return tuple(sum((self._pack(self.level_codes(lv)) for lv in range(par, self.levels, 2)), [])
                     for par in (0, 1))

    def blend_fmt(self, fmt: Fmt) -> Fmt:
        """A level's narrowed blends (``blend_frac``, step 5): ``fmt`` with ``blend_frac`` more fraction bits."""
        return Fmt(fmt.signed, fmt.int_bits, fmt.frac_bits + self.blend_frac)

    @property
    def level_frac(self) -> int:
        """Fraction bits beyond the texels' of each level's blend ``v0, v1`` (step 5): ``2 weight_bits`` exact,
        else ``blend_frac``."""
        return self.blend_frac or 2 * self.weight_bits

    def _keep(self, x, frac: int, fmt: Fmt, what: str):
        """``x`` (``frac`` fraction bits beyond ``fmt``'s) narrowed to :meth:`blend_fmt` (``Rounding.HALF_UP``,
        ``Overflow.PROVEN``: step 5)."""
        out = self.blend_fmt(fmt)
        return narrow(x, fmt.frac_bits + frac, out, Rounding.HALF_UP, Overflow.PROVEN, what)[0]

    def level(self, lod):
        """Step 5: ``(L, L + 1 clamped, g)`` from ``lod`` codes: the level, the next one and the blend weight."""
        F, C, top = self.lod_fmt.frac_bits, self.level_bits, self.levels - 1
        lod = np.asarray(lod, dtype=np.int64)
        L = lod >> F
        g = (lod & ((1 << F) - 1)) >> (F - C)
        g = np.where((lod < 0) | (L >= top), 0, g)
        L = np.clip(L, 0, top)
        return L, np.minimum(L + 1, top), g

    def _raw(self, lv, s, t):
        """Exact bilinear blends ``(K, channels)`` before narrowing, at level ``lv[k]`` per sample."""
        out = np.zeros((len(s), len(self.channels)), dtype=np.int64)
        for v in np.unique(lv):
            sel = np.flatnonzero(lv == v)
            h, w = self.level_sizes[v]
            tex = self.level_codes(int(v))[0]
            i0, i1, fx = self.positions(s[sel], w)
            j0, j1, fy = self.positions(t[sel], h)
            a, b, c, d = tex[j0, i0], tex[j0, i1], tex[j1, i0], tex[j1, i1]
            for k, fmt in enumerate(self.channels):
                out[sel, k] = self.blend(a[:, k], b[:, k], c[:, k], d[:, k], fx, fy, fmt, exact=True)
        return out

    def sample_trilinear(self, s, t, lod):
        """Channel codes ``(K, channels)`` at ``(s, t)`` and level of detail ``lod`` (step 5)."""
        s, t = np.asarray(s, dtype=np.int64), np.asarray(t, dtype=np.int64)
        L0, L1, g = self.level(lod)
        v0, v1 = self._raw(L0, s, t), self._raw(L1, s, t)
        C = self.level_bits
        v = (v0 << C) + g[:, None] * (v1 - v0)
        return np.stack([narrow(v[:, k], self.level_frac + C + fmt.frac_bits, fmt, Rounding.HALF_UP, Overflow.PROVEN,
                                "sampler level blend")[0] for k, fmt in enumerate(self.channels)], axis=1)
