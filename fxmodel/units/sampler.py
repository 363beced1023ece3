r"""Texture sampler: repeat or clamp addressing, nearest or bilinear filtering, from a texel memory.

One unit serves every lookup of the pixel pipeline (paper sections 3.2 and 4): the bump map ``(du, dv)`` and the
color texture at the perspective-correct address ``(u/w, v/w)`` (repeat-wrapped, any map size: the paper's
Fig. 9 bump map is 40 x 40, not a power of two), and the diffuse and specular reflectance cubes at
``(face, s, t)`` from the cube address unit (clamped at face edges).

Algorithm (bit-exact; ``rtl/sampler.py`` builds the same datapath from the same :class:`SamplerParams`)
-------------------------------------------------------------------------------------------------------
Coordinates ``s, t`` are codes of ``coord_fmt`` with ``T`` fraction bits.

1. **Edge rule.** ``repeat``: keep the fraction bits, ``s - floor(s)`` in ``[0, 1)`` -- the texture's repeat,
   exact for negative coordinates and coordinates far outside ``[0, 1)`` (two's complement makes it free: the
   integer bits are simply not used). ``clamp``: ``s`` clamped to ``[0, 1]`` (clamp-to-edge; the cube unit's
   ``s, t`` are already in ``[0, 1]``, so the clamp is idle there). ``border``: like ``clamp``, but each face is
   stored with a one-texel border (``(H + 2) x (W + 2)`` texels) that continues the face past its edges -- for
   a reflectance cube, the lighting evaluated one texel beyond the edge, which is the neighbouring face's
   lighting -- so bilinear filtering never clamps and is seamless across faces to second order (the seamless
   option; no adjacent-face addressing in hardware, only ``4 (W + 1)`` more texels a face).
2. **Texel position** for a map of ``W`` texels: nearest ``i = floor(s W)`` (``s = 1`` gives ``W - 1`` under
   clamp); bilinear ``x = s W - 1/2`` exactly (``T + 1`` fraction bits), ``i0 = floor(x)``, ``i1 = i0 + 1``,
   ``fx`` = the fraction of ``x`` truncated to ``weight_bits`` (``Rounding.TRUNC``). ``repeat`` wraps
   ``i0 = -1`` to ``W - 1`` and ``i1 = W`` to ``0`` (one comparison each: ``x`` lies in ``[-1/2, W - 1/2)``); ``clamp``
   clamps both to ``[0, W - 1]``; ``border`` adds 1 (the border column), no clamp needed. The same for ``t``.
3. **Fetch** the texels at ``(face H + j) W + i``: one read port for nearest, four for bilinear.
4. **Bilinear blend**, exact: ``top = a 2**B + fx (b - a)``, ``bot = c 2**B + fx (d - c)``,
   ``v = top 2**B + fy (bot - top)`` (``B = weight_bits``), then one narrowing to the channel's format,
   ``Rounding.HALF_UP`` and ``Overflow.PROVEN`` (a convex combination of four codes of a format, rounded to
   nearest, stays within their range: the result lies between the smallest and largest of the four texels).
   ``extra_frac = e > 0`` (bilinear only): the narrowing keeps ``e`` more fraction bits than the texels, to the
   output format :attr:`SamplerParams.out_channels` (same integer bits, ``frac + e`` fraction bits), still
   ``Rounding.HALF_UP`` and ``Overflow.PROVEN``: the four texels are codes of the finer grid too (times ``2**e``),
   so the rounded blend still lies between the smallest and largest of them, within the texels' range, which
   the output format holds (same integer bits). The blend's own resolution, not the memory's: no more texel bits.

5. **Trilinear** (MIP mapping, paper section 6's next step): a third input ``lod`` (``lod_fmt``, the LOD unit's
   ``out_fmt``, ``F`` fraction bits) and the MIP levels ``mips`` (:func:`fxmodel.units.mip.mip_pyramid`, each level
   its own size). Level ``L = floor(lod)``, blend weight ``g`` = the fraction of ``lod`` truncated to
   ``level_bits = C`` bits (``Rounding.TRUNC``); ``lod < 0`` (magnified) gives ``L = 0, g = 0``, ``lod >= levels -
   1`` the last level (``1 x 1``) with ``g = 0``. Steps 2-4 at levels ``L`` and ``L + 1`` (same ``s, t``; the blends
   before narrowing, ``2 B + frac`` fraction bits: ``v0, v1``), one exact blend ``v = v0 2**C + g (v1 - v0)`` and one
   narrowing, ``Rounding.HALF_UP``, ``Overflow.PROVEN`` (a convex combination of eight codes, rounded to nearest,
   stays within their range). At ``g = 0`` it is bilinear at level ``L`` exactly.
   ``blend_frac = k >= 1`` narrows each level's blends instead of keeping them exact: ``top`` and ``bot`` to ``k``
   fraction bits beyond the texels' (from ``B``), then ``v`` to ``k`` (from ``k + B``), each ``Rounding.HALF_UP``
   and ``Overflow.PROVEN`` (each is a convex combination of the texels, or of values already in their range, on a
   grid the texels' codes lie on: rounded to nearest, it stays within their range). Each narrowing moves a value
   by at most half of ``2**-k`` texel steps, and a convex combination of moved values moves by no more than
   they did, so ``v`` is within ``2**-k`` steps of the exact ``v`` and the result within ``1/2 + 2**-k`` steps of
   the exact trilinear blend (``max_error``; ``1/2`` when exact). What it buys: the differences ``bot - top``
   and ``v1 - v0`` have ``width + k + 1`` bits, one multiplier block each at ``k = 17 - width`` (``k = 9`` for
   8-bit channels), instead of two each when exact with 12-bit weights. Levels ``L`` and ``L + 1`` differ
   in parity: the RTL keeps even and odd levels in two memories and reads both in one clock (:meth:`memories`).

Properties (tested): periodic with the map size under ``repeat``; a bilinear sample lies within the range of
its four texels and equals a texel exactly at its center (``fx = fy = 0``); nearest returns a stored texel;
a trilinear sample lies within the range of its eight texels, equals bilinear at level ``L`` at an integer
``lod``, equals bilinear at level 0 when magnified.
Hard cases (each has a test): coordinates 0, 1 - ulp, 1, texel centers and texel edges, negative coordinates and
coordinates far outside ``[0, 1)``, every face.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fxmodel.core.cost import Memory, Product
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, Unit, register, require
from fxmodel.units.sampler_mip import Texels, TrilinearSampling, mip_texels
from fxmodel.units.shapes import (
    add_shape,
    interleave_shape,
    is_split,
    product_shape,
    repr_without_defaults,
    shl_shape,
    sub_shape,
)

__all__ = ["Texels", "SamplerParams", "FILTERS", "EDGES", "mip_texels"]

FILTERS = ("nearest", "bilinear", "trilinear")
EDGES = ("repeat", "clamp", "border")


@dataclass(frozen=True)
class SamplerParams(TrilinearSampling, Unit):
    """Parameters of a texture sampler.

    Parameters
    ----------
    texels : Texels
        The memory, ``(faces, height, width, channels)`` codes; ``faces`` is 1 (a texture) or 6 (a cube map,
        with a ``face`` input port).
    channels : tuple of Fmt
        Format of each channel (the outputs: :attr:`out_channels`, the same unless ``extra_frac``).
    coord_fmt : Fmt
        Format of the ``s, t`` inputs.
    filter : str
        ``nearest`` or ``bilinear``.
    edge : str
        ``repeat``, ``clamp`` or ``border`` (see the module docstring, step 1).
    weight_bits : int
        Bits of the bilinear weights ``fx, fy`` (``u0.weight_bits``).
    names : tuple of str
        Output port names, one per channel.
    mips : tuple of Texels
        ``trilinear`` only: MIP levels 1, 2, ... (:func:`mip_texels`), each of one face and the size
        :func:`fxmodel.units.mip.mip_sizes` gives.
    lod_fmt : Fmt or None
        ``trilinear`` only: format of the ``lod`` input (the LOD unit's ``out_fmt``, signed).
    level_bits : int
        ``trilinear`` only: bits of the blend weight between two levels (at most ``lod_fmt``'s fraction bits).
    extra_frac : int
        ``bilinear`` only: fraction bits the blend's output keeps beyond the texels' (step 4; 0 to
        ``2 weight_bits``): the outputs have the formats :attr:`out_channels`. 0 (the default): the texels' formats.
    blend_frac : int
        ``trilinear`` only: 0 (the default) keeps each level's bilinear blends exact; ``k`` in ``1..weight_bits``
        narrows them to ``k`` fraction bits beyond the texels' before the level blend (step 5).
    """

    NAME = "sampler"

    texels: Texels
    channels: tuple
    coord_fmt: Fmt = Fmt(True, 8, 16)
    filter: str = "bilinear"
    edge: str = "repeat"
    weight_bits: int = 8
    names: tuple = ()
    mips: tuple = ()
    lod_fmt: Fmt | None = None
    level_bits: int = 8
    extra_frac: int = 0
    blend_frac: int = 0

    def __post_init__(self):
        require(isinstance(self.texels, Texels), "texels", self.texels, "must be a Texels")
        faces, h, w, ch = self.texels.shape
        require(faces in (1, 6), "texels", self.texels, "must have 1 face (texture) or 6 (cube map)")
        require(h >= 1 + 2 * (self.edge == "border") and w >= 1 + 2 * (self.edge == "border"), "texels",
                 self.texels, "must have at least one texel (plus the border for edge='border')")
        require(isinstance(self.channels, tuple) and len(self.channels) == ch
                 and all(isinstance(c, Fmt) for c in self.channels), "channels", self.channels,
                 f"must be a tuple of {ch} Fmt (one per channel of the texels)")
        for k, fmt in enumerate(self.channels):
            col = self.texels.codes[..., k]
            require(bool(np.all((col >= fmt.min_code) & (col <= fmt.max_code))), "texels", self.texels,
                     f"channel {k} has codes outside {fmt}")
        require(isinstance(self.coord_fmt, Fmt) and self.coord_fmt.frac_bits >= 1, "coord_fmt", self.coord_fmt,
                 "must be an Fmt with at least one fraction bit")
        require(self.filter in FILTERS, "filter", self.filter, f"must be one of {FILTERS}")
        require(self.edge in EDGES, "edge", self.edge, f"must be one of {EDGES}")
        require(isinstance(self.weight_bits, int) and 1 <= self.weight_bits <= 16, "weight_bits",
                 self.weight_bits, "must be an int in 1..16")
        require(self.weight_bits <= self.coord_fmt.frac_bits + 1, "weight_bits", self.weight_bits,
                 f"cannot exceed the coordinate's fraction bits + 1 = {self.coord_fmt.frac_bits + 1}")
        require(isinstance(self.names, tuple) and len(self.names) in (0, ch), "names", self.names,
                 f"must be empty or name all {ch} channels")
        require(max(w, h).bit_length() + self.coord_fmt.frac_bits + 2 <= 62, "texels", self.texels,
                 "map too large for int64 texel positions")
        require(isinstance(self.extra_frac, int) and 0 <= self.extra_frac <= 2 * self.weight_bits
                and (self.extra_frac == 0 or self.filter == "bilinear"), "extra_frac", self.extra_frac,
                f"must be an int in 0..{2 * self.weight_bits} (2 weight_bits), and 0 unless filter='bilinear'")
        require(isinstance(self.blend_frac, int) and 0 <= self.blend_frac <= self.weight_bits
                and (self.blend_frac == 0 or self.filter == "trilinear"), "blend_frac", self.blend_frac,
                f"must be an int in 0..{self.weight_bits} (weight_bits), and 0 unless filter='trilinear'")
        if self.trilinear:
            self._check_trilinear()
        else:
            require(self.mips == () and self.lod_fmt is None, "mips/lod_fmt", (self.mips, self.lod_fmt),
                    "only for filter='trilinear'")

    def __repr__(self):
        """The dataclass ``repr`` without the trilinear fields, ``extra_frac`` and ``blend_frac`` at their defaults:
        complete (a missing field is at its default), and the same as before MIP mapping for every other sampler
        (build caches and recorded resource counts are keyed by it)."""
        return repr_without_defaults(self, ("mips", "lod_fmt", "level_bits", "extra_frac", "blend_frac"))

    # -- shape facts (the RTL reads these) ----------------------------------------------------------------
    @property
    def faces(self) -> int:
        return self.texels.shape[0]

    @property
    def border(self) -> int:
        """Border texels on each side of a face (1 for the ``border`` edge rule)."""
        return 1 if self.edge == "border" else 0

    @property
    def height(self) -> int:
        """Texels of the sample grid along ``t`` (the border excluded)."""
        return self.texels.shape[1] - 2 * self.border

    @property
    def width(self) -> int:
        """Texels of the sample grid along ``s`` (the border excluded)."""
        return self.texels.shape[2] - 2 * self.border

    @property
    def depth(self) -> int:
        """Words in the memory."""
        return int(np.prod(self.texels.shape[:3]))

    @property
    def bilinear(self) -> bool:
        """Bilinear lookups (also within each level of ``trilinear``)."""
        return self.filter in ("bilinear", "trilinear")

    @property
    def trilinear(self) -> bool:
        return self.filter == "trilinear"

    @cached_property
    def out_channels(self) -> tuple:
        """Format of each output: the channel's, with :attr:`extra_frac` more fraction bits."""
        return tuple(Fmt(f.signed, f.int_bits, f.frac_bits + self.extra_frac) for f in self.channels)

    @cached_property
    def out_names(self) -> tuple:
        return self.names or tuple(f"c{k}" for k in range(len(self.channels)))

    def _pack(self, codes) -> list:
        """Words of texel codes ``(..., channels)``: the channels' bit patterns packed, channel 0 in the low bits."""
        codes = np.asarray(codes).reshape(-1, len(self.channels))
        word = np.zeros(len(codes), dtype=object)
        shift = 0
        for k, fmt in enumerate(self.channels):
            word = word + (np.asarray(fmt.to_bits(codes[:, k]), dtype=object) << shift)
            shift += fmt.width
        return [int(v) for v in word]

    @cached_property
    def words(self) -> list:
        """Memory words in texel order ``(face, row, column)`` (one memory; see :attr:`banked`)."""
        return self._pack(self.texels.codes)

    def level_words(self, level: int) -> list:
        """The words of MIP level ``level`` in texel order (row, column): level 0 is :attr:`words` of one face."""
        return self._pack(self.level_codes(level))

    @property
    def banked(self) -> bool:
        """Bilinear lookups read their four texels from four banks by texel parity (bank ``(i mod 2, j mod 2)``
        holds texel ``(i, j)`` at ``(face, j // 2, i // 2)``), one read port each: the four texels of a lookup
        always lie in four different banks (``i1 = i0 + 1``), or are the same texel twice (``clamp`` at an edge).
        That stores the map once instead of twice (a block RAM has two read ports), for two more pipeline stages. Not
        for ``repeat`` with an odd map size, where ``i0 = W - 1`` and ``i1 = 0`` share a parity: one memory with four
        read ports there."""
        return (self.filter == "bilinear"
                and (self.edge != "repeat" or (self.width % 2 == 0 and self.height % 2 == 0)))

    @property
    def bank_shape(self) -> tuple:
        """``(faces, rows, columns)`` of each bank (a map of odd memory size is padded by one row/column)."""
        f, h, w = self.texels.shape[:3]
        return f, (h + 1) // 2, (w + 1) // 2

    @cached_property
    def bank_words(self) -> list:
        """The four banks' words, bank ``2 * (j mod 2) + (i mod 2)``, padding texels zero."""
        f, h, w, ch = self.texels.shape
        padded = np.zeros((f, 2 * self.bank_shape[1], 2 * self.bank_shape[2], ch), dtype=np.int64)
        padded[:, :h, :w] = self.texels.codes
        return [self._pack(padded[:, py::2, px::2]) for py in (0, 1) for px in (0, 1)]

    @cached_property
    def memory_words(self) -> tuple:
        """The words of each texel memory the RTL instantiates, in its order: the even and the odd MIP levels
        (trilinear), the four banks (:attr:`banked`), or the one memory. An upload writes them one after the other
        (:attr:`upload_words`)."""
        if self.trilinear:
            return tuple(self.parity_words)
        if self.banked:
            return tuple(self.bank_words)
        return (self.words,)

    @property
    def upload_words(self) -> list:
        """The words the board's upload of this map writes (``host.protocol.scene_frames``): the memories of
        :attr:`memory_words` one after the other, so the board finds a word's memory and address by comparing its
        index with the memories' bounds (no division by a map's width)."""
        return [w for mem in self.memory_words for w in mem]

    def memories(self) -> tuple:
        """The physical texel memories the RTL instantiates (:class:`fxmodel.core.cost.Memory`): four banks of one
        read port when :attr:`banked`, else one memory with a read port per corner; trilinear: the even levels and
        the odd levels, one memory each with four read ports (the two lookups of a pixel in the same clock)."""
        if self.trilinear:
            return tuple(Memory(max(1, len(w)), self.word_bits, 4, kind="texels", name=f"{par} MIP levels")
                         for par, w in zip(("even", "odd"), self.parity_words))
        if self.banked:
            return (Memory(int(np.prod(self.bank_shape)), self.word_bits, 1, count=4, kind="texels",
                           name="texel bank", registered=True),)
        return (Memory(self.depth, self.word_bits, 4 if self.bilinear else 1, kind="texels", name="texels"),)

    def products(self) -> tuple:
        """The bilinear blend's products per channel (``rtl/sampler.py``): ``fx (b - a)``, ``fx (d - c)``, then
        ``fy (bot - top)``, each split into registered partial products when an operand is wider than one
        multiplier block. Operand widths follow the RTL's expressions (Amaranth's shape rules: :func:`add_shape`,
        :func:`sub_shape`, :func:`shl_shape`); none for nearest filtering."""
        if not self.bilinear:
            return ()
        B = self.weight_bits
        weight = (B, False)
        texels = [(fmt.width, fmt.signed) for fmt in self.channels]
        first = [Product(*interleave_shape(weight, sub_shape(t, t)), count=2, split=True, name="f*texel difference")
                 for t in texels]                                       # fx (b - a), fx (d - c)
        cut = any(is_split(p) for p in first)                          # one split_products call for all
        out, vs = [], []
        for fmt, t, p in zip(self.channels, texels, first):
            top = add_shape(shl_shape(t, B), product_shape(p, cut))              # top = (a << B) + fx (b - a)
            if self.blend_frac:                                                  # narrowed (step 5)
                top = (self.blend_fmt(fmt).width, fmt.signed)
            q = Product(*interleave_shape(weight, sub_shape(top, top)), split=True, name="f*row difference")
            out += [p, q]
            v = add_shape(shl_shape(top, B), product_shape(q, is_split(q)))     # v = (top << B) + fy (bot - top)
            vs.append((self.blend_fmt(fmt).width, fmt.signed) if self.blend_frac else v)
        if not self.trilinear:
            return tuple(out)
        g = (self.level_bits, False)
        return tuple(out) * 2 + tuple(
            Product(*interleave_shape(g, sub_shape(v, v)), split=True, name="g*level difference") for v in vs)

    @property
    def word_bits(self) -> int:
        return sum(f.width for f in self.channels)

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        ports = (Port("s", self.coord_fmt, "horizontal texture coordinate"),
                 Port("t", self.coord_fmt, "vertical texture coordinate"))
        if self.trilinear:
            ports += (Port("lod", self.lod_fmt, "level of detail (the LOD unit's output)"),)
        if self.faces == 6:
            ports = (Port("face", Fmt(False, 3, 0), "cube face 0..5"),) + ports
        return ports

    @property
    def outputs(self):
        return tuple(Port(n, f, "sampled channel") for n, f in zip(self.out_names, self.out_channels))

    @property
    def latency(self) -> int:
        """Scaled position | indices and weights | texel address | memory read | [bank words registered | bank to
        corner routing, when :attr:`banked`] | [six blend stages, one operation each] | rounding
        (``rtl/sampler.py``: one carry chain or one product per stage, ECP5 timing); trilinear: one stage more in
        front (level and blend weight), the level memories' words registered after the read (``rtl/sampler_mip.py``)
        and three after the two bilinear blends (level difference, ``g`` product, level blend)."""
        if self.trilinear:
            return 16
        return (11 + 2 * self.banked) if self.bilinear else 5

    # -- bit-exact model ----------------------------------------------------------------------------------
    def edge_rule(self, s):
        """Step 1: repeat (fraction bits) or clamp to [0, 1]; returns codes with ``T`` fraction bits."""
        T = self.coord_fmt.frac_bits
        if self.edge == "repeat":
            return s & ((1 << T) - 1)
        return np.clip(s, 0, 1 << T)

    def positions(self, s, size: int):
        """Step 2: ``(i0, i1, f)`` texel indices and weight codes along one axis (``i1``, ``f`` unused for
        nearest)."""
        T = self.coord_fmt.frac_bits
        s = self.edge_rule(s)
        if not self.bilinear:
            i = (s * size) >> T
            return np.minimum(i, size - 1) + self.border, None, None
        # s W - 1/2 (+ 1 for the border column) with T + 1 fraction bits
        x = s * (2 * size) + (1 << T) * (2 * self.border - 1)
        i0 = x >> (T + 1)
        f = (x & ((1 << (T + 1)) - 1)) >> (T + 1 - self.weight_bits)
        i1 = i0 + 1
        if self.edge == "repeat":
            i0 = np.where(i0 < 0, size - 1, i0)
            i1 = np.where(i1 >= size, 0, i1)
        elif self.edge == "clamp":
            i0 = np.clip(i0, 0, size - 1)
            i1 = np.clip(i1, 0, size - 1)
        return i0, i1, f                                 # border: i0 in [0, W], i1 in [1, W + 1]

    def blend(self, a, b, c, d, fx, fy, fmt: Fmt, exact: bool = False, out: Fmt | None = None):
        """Step 4: exact bilinear blend of codes of ``fmt``, one half-up narrowing to ``out`` (default ``fmt``;
        the pipeline's: :attr:`out_channels`) (``exact``: the blend before it, ``2 B + frac`` fraction bits)."""
        B = self.weight_bits
        top = (a << B) + fx * (b - a)
        bot = (c << B) + fx * (d - c)
        if exact and self.blend_frac:          # trilinear, narrowed (step 5): v at blend_frac more fraction bits
            top, bot = (self._keep(x, B, fmt, "sampler row blend") for x in (top, bot))
            return self._keep((top << B) + fy * (bot - top), self.blend_frac + B, fmt, "sampler column blend")
        v = (top << B) + fy * (bot - top)
        if exact:
            return v
        res, _ = narrow(v, 2 * B + fmt.frac_bits, out or fmt, Rounding.HALF_UP, Overflow.PROVEN, "sampler blend")
        return res

    def sample(self, face, s, t):
        """Channel codes ``(K, channels)`` at ``(face, s, t)`` code arrays."""
        tex = self.texels.codes
        i0, i1, fx = self.positions(s, self.width)
        j0, j1, fy = self.positions(t, self.height)
        if not self.bilinear:
            return tex[face, j0, i0]
        a, b, c, d = tex[face, j0, i0], tex[face, j0, i1], tex[face, j1, i0], tex[face, j1, i1]
        return np.stack([self.blend(a[:, k], b[:, k], c[:, k], d[:, k], fx, fy, fmt, out=o)
                         for k, (fmt, o) in enumerate(zip(self.channels, self.out_channels))], axis=1)

    def _compute(self, cols):
        if self.trilinear:
            out = self.sample_trilinear(*cols)
            return [out[:, k] for k in range(out.shape[1])]
        if self.faces == 6:
            face, s, t = cols
            if np.any(face > 5):
                raise ValueError(f"sampler input face: row {int(np.flatnonzero(face > 5)[0])}: face > 5")
        else:
            s, t = cols
            face = np.zeros_like(s)
        out = self.sample(face, s, t)
        return [out[:, k] for k in range(out.shape[1])]

    def random_inputs(self, rng, k):
        cols = super().random_inputs(rng, k)
        if self.faces == 6:
            cols[:, 0] %= 6
        if self.trilinear:                          # levels -1 .. levels: magnified, every level, past the last
            F = self.lod_fmt.frac_bits
            lo = max(self.lod_fmt.min_code, -(1 << F))
            hi = min(self.lod_fmt.max_code, (self.levels + 1) << F)
            cols[:, 2] = rng.integers(lo, hi + 1, size=len(cols))
        return cols

    def hard_cases(self) -> np.ndarray:
        T = self.coord_fmt.frac_bits
        one = 1 << T
        fmt = self.coord_fmt
        vals = {0, 1, one - 1, one, one + 1, one // 2, fmt.max_code, fmt.min_code, -1, -one, 3 * one + 5}
        for size in (self.width, self.height):
            for i in range(size + 1):
                vals |= {(i * one) // size, (2 * i + 1) * one // (2 * size)}   # texel edges and centres
        vals = np.array(sorted(v for v in vals if fmt.min_code <= v <= fmt.max_code), dtype=np.int64)
        grid = np.array(np.meshgrid(vals, vals[:: max(1, len(vals) // 24)])).reshape(2, -1).T
        if self.faces == 6:
            grid = np.concatenate([np.column_stack([np.full(len(grid), f), grid]) for f in range(6)])
        if self.trilinear:                          # each grid point at the level boundaries and past both ends
            F, fmt = self.lod_fmt.frac_bits, self.lod_fmt
            lods = {fmt.min_code, fmt.max_code, -1, 0, 1, (1 << F) - 1}
            for lv in range(self.levels + 1):
                lods |= {(lv << F) - 1, lv << F, (lv << F) + 1, (lv << F) + (1 << F) // 2}
            lods = sorted(v for v in lods if fmt.min_code <= v <= fmt.max_code)
            grid = grid[:: max(1, len(grid) // 200)]
            grid = np.concatenate([np.column_stack([grid, np.full(len(grid), v)]) for v in lods])
        return grid

    def _info(self):
        return {"texels": list(self.texels.shape), "filter": self.filter, "edge": self.edge,
                "weight_bits": self.weight_bits, "banked": self.banked,
                "memory_bits": sum(len(w) for w in self.parity_words) * self.word_bits if self.trilinear
                else self.depth * self.word_bits,
                **({"levels": [list(x) for x in self.level_sizes], "level_bits": self.level_bits}
                   if self.trilinear else {}),
                **({"extra_frac": self.extra_frac} if self.extra_frac else {}),
                **({"blend_frac": self.blend_frac} if self.blend_frac else {}),
                "max_error": {n: float(f.ulp) * self.max_error_ulps for n, f in zip(self.out_names, self.out_channels)}}

    @property
    def max_error_ulps(self) -> float:
        """Largest distance of an output from the exact filter of its texels with the same weights, in output
        ulps: 0 nearest, 1/2 bilinear and exact trilinear, ``1/2 + 2**-blend_frac`` narrowed (step 5)."""
        if not self.bilinear:
            return 0.0
        return 0.5 + (2.0 ** -self.blend_frac if self.blend_frac else 0.0)


def _demo_texels() -> Texels:
    """A 5 x 7 two-channel signed map (odd sizes on purpose) for the presets and tests."""
    rng = np.random.default_rng(1995)
    return Texels(rng.integers(-512, 512, size=(1, 5, 7, 2)))


SamplerParams.PRESETS = {
    "default": SamplerParams(texels=_demo_texels(), channels=(Fmt(True, 1, 9), Fmt(True, 1, 9)),
                             names=("du", "dv")),
    "nearest": SamplerParams(texels=_demo_texels(), channels=(Fmt(True, 1, 9), Fmt(True, 1, 9)),
                             filter="nearest", names=("du", "dv")),
    "cube": SamplerParams(texels=Texels(np.random.default_rng(7).integers(0, 4096, size=(6, 4, 4, 3))),
                          channels=(Fmt(False, 2, 10),) * 3, coord_fmt=Fmt(False, 1, 16), edge="clamp",
                          names=("r", "g", "b")),
    "border": SamplerParams(texels=Texels(np.random.default_rng(8).integers(0, 4096, size=(6, 7, 7, 3))),
                            channels=(Fmt(False, 2, 10),) * 3, coord_fmt=Fmt(False, 1, 16), edge="border",
                            names=("r", "g", "b")),
}
_TRI = Texels(np.random.default_rng(9).integers(0, 256, size=(1, 6, 8, 3)))  # levels in logic, as synthesized
SamplerParams.PRESETS["trilinear"] = SamplerParams(texels=_TRI, channels=(Fmt(False, 8, 0),) * 3, filter="trilinear",
                                                   coord_fmt=Fmt(True, 3, 14), names=("r", "g", "b"),
                                                   mips=mip_texels(_TRI), lod_fmt=Fmt(True, 6, 8))
#: The same with each level's blends rounded to 6 fraction bits beyond the texels (both narrowings of step 5 used)
SamplerParams.PRESETS["trilinear-narrow"] = SamplerParams.PRESETS["trilinear"].replace(blend_frac=6)
register(SamplerParams)
