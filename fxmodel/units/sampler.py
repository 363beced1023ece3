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

Properties (tested): periodic with the map size under ``repeat``; a bilinear sample lies within the range of
its four texels and equals a texel exactly at its center (``fx = fy = 0``); nearest returns a stored texel.
Hard cases (each has a test): coordinates 0, 1 - ulp, 1, texel centers and texel edges, negative coordinates and
coordinates far outside ``[0, 1)``, every face.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fxmodel.core.cost import Memory, Product, pieces
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, Unit, register, require

__all__ = ["Texels", "SamplerParams", "FILTERS", "EDGES"]

FILTERS = ("nearest", "bilinear")
EDGES = ("repeat", "clamp", "border")


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




@dataclass(frozen=True)
class SamplerParams(Unit):
    """Parameters of a texture sampler.

    Parameters
    ----------
    texels : Texels
        The memory, ``(faces, height, width, channels)`` codes; ``faces`` is 1 (a texture) or 6 (a cube map,
        with a ``face`` input port).
    channels : tuple of Fmt
        Format of each channel (the outputs have the same formats).
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
    """

    NAME = "sampler"

    texels: Texels
    channels: tuple
    coord_fmt: Fmt = Fmt(True, 8, 16)
    filter: str = "bilinear"
    edge: str = "repeat"
    weight_bits: int = 8
    names: tuple = ()

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
        return self.filter == "bilinear"

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

    @property
    def banked(self) -> bool:
        """Bilinear lookups read their four texels from four banks by texel parity (bank ``(i mod 2, j mod 2)``
        holds texel ``(i, j)`` at ``(face, j // 2, i // 2)``), one read port each: the four texels of a lookup
        always lie in four different banks (``i1 = i0 + 1``), or are the same texel twice (``clamp`` at an edge).
        That stores the map once instead of twice (a block RAM has two read ports), for two more pipeline stages. Not
        for ``repeat`` with an odd map size, where ``i0 = W - 1`` and ``i1 = 0`` share a parity: one memory with four
        read ports there."""
        return self.bilinear and (self.edge != "repeat" or (self.width % 2 == 0 and self.height % 2 == 0))

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

    def memories(self) -> tuple:
        """The physical texel memories the RTL instantiates (:class:`fxmodel.core.cost.Memory`): four banks of one
        read port when :attr:`banked`, else one memory with a read port per corner."""
        if self.banked:
            return (Memory(int(np.prod(self.bank_shape)), self.word_bits, 1, count=4, kind="texels",
                           name="texel bank"),)
        return (Memory(self.depth, self.word_bits, 4 if self.bilinear else 1, kind="texels", name="texels"),)

    def products(self) -> tuple:
        """The bilinear blend's products per channel (``rtl/sampler.py``): ``fx (b - a)``, ``fx (d - c)``, then
        ``fy (bot - top)``, each split into registered partial products when an operand is wider than one
        multiplier block. Operand widths follow the RTL's expressions (Amaranth's shape rules: :func:`_add`,
        :func:`_sub`, :func:`_shl`); none for nearest filtering."""
        if not self.bilinear:
            return ()
        B = self.weight_bits
        weight = (B, False)
        texels = [(fmt.width, fmt.signed) for fmt in self.channels]
        first = [Product(*_interleave(weight, _sub(t, t)), count=2, split=True, name="f*texel difference")
                 for t in texels]                                       # fx (b - a), fx (d - c)
        cut = any(_is_split(p) for p in first)                          # one split_products call for all
        out = []
        for t, p in zip(texels, first):
            top = _add(_shl(t, B), _product_shape(p, cut))              # top = (a << B) + fx (b - a)
            out += [p, Product(*_interleave(weight, _sub(top, top)), split=True, name="f*row difference")]
        return tuple(out)

    @property
    def word_bits(self) -> int:
        return sum(f.width for f in self.channels)

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        ports = (Port("s", self.coord_fmt, "horizontal texture coordinate"),
                 Port("t", self.coord_fmt, "vertical texture coordinate"))
        if self.faces == 6:
            ports = (Port("face", Fmt(False, 3, 0), "cube face 0..5"),) + ports
        return ports

    @property
    def outputs(self):
        return tuple(Port(n, f, "sampled channel") for n, f in zip(self.out_names, self.channels))

    @property
    def latency(self) -> int:
        """Scaled position | indices and weights | texel address | memory read | [bank words registered | bank to
        corner routing, when :attr:`banked`] | [six blend stages, one operation each] | rounding
        (``rtl/sampler.py``: one carry chain or one product per stage, ECP5 timing)."""
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

    def blend(self, a, b, c, d, fx, fy, fmt: Fmt):
        """Step 4: exact bilinear blend of codes, one half-up narrowing to ``fmt``."""
        B = self.weight_bits
        top = (a << B) + fx * (b - a)
        bot = (c << B) + fx * (d - c)
        v = (top << B) + fy * (bot - top)
        out, _ = narrow(v, 2 * B + fmt.frac_bits, fmt, Rounding.HALF_UP, Overflow.PROVEN, "sampler blend")
        return out

    def sample(self, face, s, t):
        """Channel codes ``(K, channels)`` at ``(face, s, t)`` code arrays."""
        tex = self.texels.codes
        i0, i1, fx = self.positions(s, self.width)
        j0, j1, fy = self.positions(t, self.height)
        if not self.bilinear:
            return tex[face, j0, i0]
        a, b, c, d = tex[face, j0, i0], tex[face, j0, i1], tex[face, j1, i0], tex[face, j1, i1]
        return np.stack([self.blend(a[:, k], b[:, k], c[:, k], d[:, k], fx, fy, fmt)
                         for k, fmt in enumerate(self.channels)], axis=1)

    def _compute(self, cols):
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
        return grid

    def _info(self):
        return {"texels": list(self.texels.shape), "filter": self.filter, "edge": self.edge,
                "weight_bits": self.weight_bits, "memory_bits": self.depth * self.word_bits, "banked": self.banked,
                "max_error": {n: float(f.ulp / 2) if self.bilinear else 0.0
                              for n, f in zip(self.out_names, self.channels)}}


def _unify(a: tuple, b: tuple) -> tuple:
    """Amaranth's common shape ``(width, signed)`` of two operands: an unsigned one gains a bit next to a signed
    one."""
    if a[1] == b[1]:
        return max(a[0], b[0]), a[1]
    return max(a[0] + (not a[1]), b[0] + (not b[1])), True


def _add(a: tuple, b: tuple) -> tuple:
    """Shape of an Amaranth sum ``a + b``."""
    w, s = _unify(a, b)
    return w + 1, s


def _sub(a: tuple, b: tuple) -> tuple:
    """Shape of an Amaranth difference ``a - b`` (always signed)."""
    return _unify(a, b)[0] + 1, True


def _shl(a: tuple, c: int) -> tuple:
    """Shape of an Amaranth shift ``a << c`` by a constant: the constant is a ``Const`` of ``bit_length(c)``
    bits, and the shape allows its largest value, ``2**bits - 1`` (wider than ``c`` itself; Yosys trims the
    constant-zero bits)."""
    return a[0] + (1 << max(1, c.bit_length())) - 1, a[1]


def _interleave(a: tuple, b: tuple) -> tuple:
    """``(a_bits, b_bits, a_signed, b_signed)`` of two shapes (the order of :class:`~fxmodel.core.cost.Product`)."""
    return a[0], b[0], a[1], b[1]


def _is_split(p: Product) -> bool:
    """Whether ``p`` has an operand of more than one :func:`~fxmodel.core.cost.pieces`."""
    return len(pieces(p.a_bits, p.a_signed)) > 1 or len(pieces(p.b_bits, p.b_signed)) > 1


def _product_shape(p: Product, cut: bool) -> tuple:
    """Shape of one product ``p`` as the RTL forms it: the registered product, or, when its
    ``rtl.recip.split_products`` call cuts (``cut``: some product of the call is wider than one block), the
    sum ``0 + sum(partial << shift)`` of its registered partial products."""
    if not cut:
        return p.a_bits + p.b_bits, p.a_signed or p.b_signed
    total = (1, False)                                                  # Python's sum starts from 0
    for lo_a, wa, sa in pieces(p.a_bits, p.a_signed):
        for lo_b, wb, sb in pieces(p.b_bits, p.b_signed):
            total = _add(total, _shl((wa + wb, sa or sb), lo_a + lo_b))
    return total


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
register(SamplerParams)
