r"""Texel cache in front of external memory: the lookups' texel addresses, a blocked memory layout and an exact
cache simulation (hits, misses, fills, memory bytes and AXI4 bursts), so an RTL cache can be checked against it
access for access and byte for byte.

The pixel pipeline (paper, sections 3.2 and 4) makes two lookups per pixel into maps that grow with the scene:
the bump map at ``(s, t)`` and the color texture at ``(sc, tc)`` (the reflectance cubes stay on chip). A bilinear
lookup reads the 2 x 2 texels ``(x0 | x1, y0 | y1)`` of :meth:`fxmodel.units.sampler.SamplerParams.positions`
(one texel for ``nearest``).

Trace (:class:`Trace`)
    One row per lookup, in the order the engine makes them: fragment by fragment in the scan converter's order,
    and within a fragment the maps in the order given (bump map, then color texture). Each row names its
    ``surface`` (a map and a MIP level: :class:`Layout` maps ``(map, level)`` to a surface; level 0 until the
    filtering work adds levels) and its footprint ``x0, x1, y0, y1``.

Layout (:class:`Layout`)
    Each surface is stored in ``B x B``-texel blocks (``B`` = :attr:`TexCacheParams.block`), row of blocks by
    row of blocks, each block's texels row by row; the surface is padded to whole blocks and starts at a multiple
    of the line size. One block is one cache line, so a line is a compact square of the map: a bilinear
    footprint touches one line with probability ``((B - 1) / B)^2`` and never more than four, whatever the
    direction the map is walked in (a linear layout would put a vertical neighbour a whole map row away).

Cache (:class:`TexCacheParams`, :func:`simulate`)
    ``sets x ways`` lines, one tag per line (the line number). The set of a line is ``line mod sets``
    (``index='linear'``) or, from the block coordinates ``bx, by`` of the line in its surface, ``bx XOR
    rot(by)`` (``index='xor'``: any ``2^h x 2^(s-h)`` tile of blocks falls into distinct sets, ``h = ceil(s /
    2)``, ``sets = 2^s``; both XOR the surface's first line number in). Replacement ``lru``, tree ``plru`` or
    ``fifo``; a miss fills the lowest-numbered invalid way first. ``fifo`` (round robin): a hit changes nothing, each
    set's pointer names the next way to fill and moves past the way each fill takes; when every way is valid the victim
    is the pointer's way, or the next one after it that the same lookup has not used (so a lookup never evicts a line it
    needs while another way is free of it). Only misses change a ``fifo`` cache's state, which is what lets a tag stage
    check hits without a loop through the replacement state. Data are banked by texel parity: bank ``(x mod 2) + 2 (y
    mod 2)`` holds the texels of that parity of every line, so the four texels of a footprint lie in four banks (``x1 =
    x0 + 1``) and a lookup whose lines all hit is one read per bank -- except ``repeat`` wrapping an odd map size, where
    ``x0 = W - 1`` and ``x1 = 0`` share a parity (counted as ``bank_conflicts``).

    A lookup's distinct lines are looked up in corner order ``(x0, y0), (x1, y0), (x0, y1), (x1, y1)``, each
    updating the replacement state as it goes; a missing line is fetched with one AXI4 ``INCR`` burst of
    ``line_bytes / bus_bytes`` beats (two or more only if that exceeds 256 beats), whose address is the line
    number times the line size. The cache starts empty (invalidated when a texture is loaded).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fxmodel.core.cost import Memory
from fxmodel.core.unit import require

__all__ = ["REPLACEMENTS", "INDEXES", "TexCacheParams", "CHOSEN_CACHE", "Layout", "Trace", "CacheResult", "footprints",
           "level_lookups", "interleave", "simulate", "bank_of", "plru_touch", "plru_victim"]

REPLACEMENTS = ("lru", "plru", "fifo")
INDEXES = ("linear", "xor")

#: AXI4 INCR bursts have at most 256 beats.
AXI_MAX_BEATS = 256


def _pow2(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 1 and v & (v - 1) == 0


@dataclass(frozen=True)
class TexCacheParams:
    """Parameters of one texel cache (see the module docstring).

    Parameters
    ----------
    block : int
        ``B``: a line is a ``B x B`` block of texels (a power of two, at least 2 so each line has texels of
        every parity).
    sets, ways : int
        Sets (a power of two) and lines per set (a power of two for ``plru``).
    replacement : str
        ``lru``, ``plru`` (tree pseudo-LRU) or ``fifo`` (round robin; hits change nothing).
    index : str
        ``linear`` or ``xor`` set index.
    texel_bytes : int
        Bytes of one texel in memory (1, 2, 4 or 8): 4 for a bump-map texel (two 14-bit slopes) and for an
        RGB texel (padded).
    bus_bytes : int
        Data width of the AXI4 read port in bytes (4: one texel a beat; or 8).
    texel_bits : int
        Bits of a texel as the data banks store it (for the block-RAM count), at most ``8 texel_bytes``.
    lookup_depth : int
        Lookups the decoupled RTL (``rtl/texcache_decoupled.py``) holds between its tag and data stages (Igehy et
        al.'s lookup FIFO): a lookup waiting for its fill holds the ones behind it, so this bounds the memory
        latency plus line transfer hidden. Cost: a FIFO of this many entries (:meth:`memories`).
    misses : int
        Lines the decoupled RTL may have outstanding (requested and not yet written into the data banks): the
        bursts in flight and the fill buffer's lines (``misses x B^2`` texels, :meth:`memories`). At least 4: a
        lookup's fills are written when it reaches the data stage, after all of its lines are requested.
    """

    block: int = 4
    sets: int = 64
    ways: int = 2
    replacement: str = "lru"
    index: str = "xor"
    texel_bytes: int = 4
    bus_bytes: int = 4
    texel_bits: int = 32
    lookup_depth: int = 128
    misses: int = 8

    def __post_init__(self):
        require(_pow2(self.block) and 2 <= self.block <= 32, "block", self.block, "must be a power of two in 2..32")
        require(_pow2(self.sets) and self.sets <= 1 << 16, "sets", self.sets, "must be a power of two up to 65536")
        require(isinstance(self.ways, int) and 1 <= self.ways <= 64, "ways", self.ways, "must be an int in 1..64")
        require(self.replacement in REPLACEMENTS, "replacement", self.replacement, f"must be one of {REPLACEMENTS}")
        require(self.replacement != "plru" or _pow2(self.ways), "ways", self.ways,
                "must be a power of two for replacement='plru'")
        require(self.index in INDEXES, "index", self.index, f"must be one of {INDEXES}")
        require(self.texel_bytes in (1, 2, 4, 8), "texel_bytes", self.texel_bytes, "must be 1, 2, 4 or 8")
        require(self.bus_bytes in (4, 8), "bus_bytes", self.bus_bytes, "must be 4 or 8 (a 32- or 64-bit AXI4 bus)")
        require(self.line_bytes >= self.bus_bytes, "bus_bytes", self.bus_bytes,
                f"must not exceed the line size {self.line_bytes} bytes")
        require(self.line_bytes <= 4096, "block", self.block,
                "gives a line over 4 KB (an AXI4 burst cannot cross 4 KB)")
        require(isinstance(self.texel_bits, int) and 1 <= self.texel_bits <= 8 * self.texel_bytes, "texel_bits",
                self.texel_bits, f"must be an int in 1..{8 * self.texel_bytes}")
        require(_pow2(self.lookup_depth) and 2 <= self.lookup_depth <= 4096, "lookup_depth", self.lookup_depth,
                "must be a power of two in 2..4096")
        require(_pow2(self.misses) and 4 <= self.misses <= 256, "misses", self.misses,
                "must be a power of two in 4..256 (a lookup may hold four lines' fills before it can be served)")

    @property
    def line_texels(self) -> int:
        return self.block * self.block

    @property
    def line_bytes(self) -> int:
        return self.line_texels * self.texel_bytes

    @property
    def lines(self) -> int:
        return self.sets * self.ways

    @property
    def size_bytes(self) -> int:
        """Data capacity in bytes (memory bytes of the lines it holds)."""
        return self.lines * self.line_bytes

    @property
    def beats_per_line(self) -> int:
        return self.line_bytes // self.bus_bytes

    @property
    def bursts_per_line(self) -> int:
        return math.ceil(self.beats_per_line / AXI_MAX_BEATS)

    @property
    def lookup_bits(self) -> int:
        """Bits of one lookup-FIFO entry of the decoupled RTL without its sideband: a word address per data bank,
        the bank of each corner (2 bits) and the lookup's fill count (0..4)."""
        return 4 * max(1, (self.lines * self.line_texels // 4 - 1).bit_length()) + 4 * 2 + 3

    def memories(self, address_bits: int = 32, side_bits: int = 0, decoupled: bool = False) -> tuple:
        """The RAMs an RTL cache builds (:class:`fxmodel.core.cost.Memory`): four data banks by texel parity, one
        read port each (the fill writes through the block RAM's second port), and the tags (the line number, of
        ``address_bits - log2(line_bytes)`` bits, plus a valid bit, one word per set holding every way). With
        ``decoupled`` the data banks are read through their blocks' output registers (``rtl/bram.py``) and there
        are also the lookup FIFO (:attr:`lookup_depth` entries of :attr:`lookup_bits` plus
        ``side_bits``) and the fill buffer (four banks by parity, :attr:`misses` lines)."""
        tag_bits = address_bits - self.line_bytes.bit_length() + 1 + 1
        mems = (Memory(self.lines * self.line_texels // 4, self.texel_bits, 1, rom=False, count=4, kind="texels",
                       name="texel cache bank", registered=decoupled),
                Memory(self.sets, tag_bits * self.ways, 1, rom=False, kind="table", name="texel cache tags"))
        if decoupled:
            mems += (Memory(self.lookup_depth, self.lookup_bits + side_bits, 1, rom=False, kind="table",
                            name="texel cache lookup FIFO"),
                     Memory(self.misses * self.line_texels // 4, self.texel_bits, 1, rom=False, count=4,
                            kind="table", name="texel cache fill buffer"))
        return mems

    def info(self) -> dict:
        return {"block": self.block, "sets": self.sets, "ways": self.ways, "replacement": self.replacement,
                "index": self.index, "line_bytes": self.line_bytes, "size_bytes": self.size_bytes,
                "bus_bytes": self.bus_bytes, "beats_per_line": self.beats_per_line,
                "bursts_per_line": self.bursts_per_line}


def bank_of(x, y):
    """Data bank ``(x mod 2) + 2 (y mod 2)`` of texel ``(x, y)``."""
    return (np.asarray(x) & 1) + 2 * (np.asarray(y) & 1)


#: The texel cache ``bumpmap cache-sweep`` chose (``docs/texcache.md``, ``docs/records/texcache.json``), one per map.
CHOSEN_CACHE = TexCacheParams(block=8, sets=32, ways=4)


@dataclass(frozen=True)
class Layout:
    """The blocked memory layout of a set of surfaces (see the module docstring).

    Parameters
    ----------
    surfaces : tuple
        ``((map, level), height, width)`` per surface, in memory order.
    block : int
        ``B``, the block (line) edge in texels.
    texel_bytes : int
    base : int
        Byte address of the first surface (a multiple of the line size).
    """

    surfaces: tuple
    block: int
    texel_bytes: int = 4
    base: int = 0

    def __post_init__(self):
        require(_pow2(self.block), "block", self.block, "must be a power of two")
        require(self.texel_bytes in (1, 2, 4, 8), "texel_bytes", self.texel_bytes, "must be 1, 2, 4 or 8")
        require(isinstance(self.base, int) and self.base >= 0 and self.base % self.line_bytes == 0, "base", self.base,
                f"must be a non-negative multiple of the line size {self.line_bytes}")
        keys = [s[0] for s in self.surfaces]
        require(len(set(keys)) == len(keys), "surfaces", keys, "must name each (map, level) once")
        for key, h, w in self.surfaces:
            require(isinstance(h, int) and isinstance(w, int) and h >= 1 and w >= 1, "surfaces", (key, h, w),
                    "must have positive int height and width")

    @property
    def line_bytes(self) -> int:
        return self.block * self.block * self.texel_bytes

    @cached_property
    def surface_index(self) -> dict:
        return {s[0]: k for k, s in enumerate(self.surfaces)}

    @cached_property
    def blocks_per_row(self) -> np.ndarray:
        return np.array([-(-w // self.block) for _, _, w in self.surfaces], dtype=np.int64)

    @cached_property
    def first_line(self) -> np.ndarray:
        """Line number of each surface's first block."""
        blocks = [-(-h // self.block) * -(-w // self.block) for _, h, w in self.surfaces]
        return self.base // self.line_bytes + np.concatenate([[0], np.cumsum(blocks)[:-1]]).astype(np.int64)

    @property
    def size_bytes(self) -> int:
        """Bytes from :attr:`base` to the end of the last surface."""
        _, h, w = self.surfaces[-1]
        last = int(self.first_line[-1]) + -(-h // self.block) * -(-w // self.block)
        return last * self.line_bytes - self.base

    def blocks(self, surface, x, y):
        """Block coordinates ``(bx, by)`` and the line number of texel ``(x, y)`` of surface index ``surface``."""
        surface, x, y = (np.asarray(v, dtype=np.int64) for v in (surface, x, y))
        bx, by = x // self.block, y // self.block
        return bx, by, self.first_line[surface] + by * self.blocks_per_row[surface] + bx

    def address(self, surface, x, y):
        """Byte address of texel ``(x, y)`` of surface index ``surface`` (arrays)."""
        _, _, line = self.blocks(surface, x, y)
        B = self.block
        return (line * (B * B) + (np.asarray(y) % B) * B + np.asarray(x) % B) * self.texel_bytes

    def texel_at(self, address: int):
        """``(surface index, x, y)`` of the texel stored at byte ``address``, ``None`` for padding or outside."""
        if address % self.texel_bytes or address < self.base:
            return None
        B = self.block
        line, offset = divmod(address // self.texel_bytes, B * B)
        k = int(np.searchsorted(self.first_line, line, side="right")) - 1
        if k < 0:
            return None
        _, h, w = self.surfaces[k]
        by, bx = divmod(line - int(self.first_line[k]), int(self.blocks_per_row[k]))
        x, y = bx * B + offset % B, by * B + offset // B
        return (k, x, y) if x < w and y < h else None

    def span(self, name) -> tuple[int, int]:
        """``(address, bytes)`` of the surfaces of map ``name`` (its levels), from the first's first line to the end
        of its last (they follow each other in memory order); ``KeyError`` for a map with no surface."""
        ks = [k for k, s in enumerate(self.surfaces) if s[0][0] == name]
        if not ks:
            raise KeyError(f"no surface of map {name!r} in the layout")
        _, h, w = self.surfaces[ks[-1]]
        end = int(self.first_line[ks[-1]]) + -(-h // self.block) * -(-w // self.block)
        return int(self.first_line[ks[0]]) * self.line_bytes, (end - int(self.first_line[ks[0]])) * self.line_bytes

    def image(self, maps: list) -> bytes:
        """The surfaces' texel words (``maps[k]``: ``(height, width)`` of surface ``k``) at their addresses
        (little-endian, :attr:`texel_bytes` a texel), from :attr:`base` to the end; padding zero."""
        img = bytearray(self.size_bytes)
        tb = self.texel_bytes
        for k, words in enumerate(maps):
            h, w = words.shape
            yy, xx = np.mgrid[0:h, 0:w]
            addr = self.address(np.full(xx.size, k, np.int64), xx.ravel(), yy.ravel()) - self.base
            for a, v in zip(addr.tolist(), words.ravel().tolist()):
                img[a:a + tb] = int(v).to_bytes(tb, "little")
        return bytes(img)

    def set_of(self, params: TexCacheParams, surface, x, y):
        """The cache set of the line holding texel ``(x, y)`` (``params.index``)."""
        bx, by, line = self.blocks(surface, x, y)
        mask = params.sets - 1
        if params.index == "linear":
            return line & mask
        s = params.sets.bit_length() - 1
        h = (s + 1) // 2
        salt = self.first_line[np.asarray(surface, dtype=np.int64)]
        return (bx ^ (by << h) ^ (by >> (s - h)) ^ salt) & mask


@dataclass(frozen=True)
class Trace:
    """Texel lookups in the engine's order (module docstring): arrays of one row per lookup.

    ``fragment`` (index of the fragment in drawing order), ``surface`` (index into the :class:`Layout`'s
    surfaces), and the footprint ``x0, x1, y0, y1`` (``x1 = x0``, ``y1 = y0`` for a nearest lookup).
    """

    fragment: np.ndarray
    surface: np.ndarray
    x0: np.ndarray
    x1: np.ndarray
    y0: np.ndarray
    y1: np.ndarray

    def __post_init__(self):
        n = len(self.fragment)
        for name in ("surface", "x0", "x1", "y0", "y1"):
            require(len(getattr(self, name)) == n, name, len(getattr(self, name)), f"must have {n} rows")

    def __len__(self):
        return len(self.fragment)

    def corners(self):
        """``(x, y)`` arrays ``(n, 4)`` of the footprint's texels in corner order."""
        x = np.stack([self.x0, self.x1, self.x0, self.x1], axis=1)
        y = np.stack([self.y0, self.y0, self.y1, self.y1], axis=1)
        return x, y


def footprints(sampler, s, t, surface: int) -> Trace:
    """The :class:`Trace` of one sampler's lookups at coordinate codes ``s, t`` (one face), fragment ``k`` = row
    ``k``: the texel indices :meth:`~fxmodel.units.sampler.SamplerParams.positions` computes."""
    require(sampler.faces == 1, "sampler.faces", sampler.faces, "must be 1 (cube maps stay on chip)")
    s, t = np.asarray(s, dtype=np.int64), np.asarray(t, dtype=np.int64)
    x0, x1, _ = sampler.positions(s, sampler.width)
    y0, y1, _ = sampler.positions(t, sampler.height)
    if x1 is None:
        x1, y1 = x0, y0
    n = len(s)
    return Trace(np.arange(n, dtype=np.int64), np.full(n, surface, np.int64), *(np.asarray(v, np.int64) for v in
                                                                                  (x0, x1, y0, y1)))


def level_lookups(sampler, s, t, lod, surfaces) -> tuple:
    """A trilinear sampler's lookups split by level parity, one cache per parity (as its on-chip memories are,
    :meth:`fxmodel.units.sampler.SamplerParams.memories`): ``(trace_even, trace_odd)``.

    Per fragment ``k`` (row ``k`` of ``s, t, lod``, codes), with ``L, L + 1, g`` of
    :meth:`~fxmodel.units.sampler.SamplerParams.level`, the cache of parity ``p`` looks up the level of parity ``p``
    among ``L, L + 1`` (``L - 1`` at the last level) at the sampler's footprint for that level's size, on surface
    ``surfaces[level]`` (a :class:`Layout` index) -- when the level is needed: level ``L`` always, the other only
    when the blend weight ``g`` is not 0 (at ``g = 0`` the blend is level ``L``'s exactly, whatever the other
    level's texels). A lookup that is not needed is not made (its cache sees nothing), so each trace holds only
    the needed lookups, ``fragment`` naming their fragment."""
    require(sampler.trilinear, "sampler.filter", sampler.filter, "must be trilinear")
    s, t = np.asarray(s, dtype=np.int64), np.asarray(t, dtype=np.int64)
    L, _, g = sampler.level(lod)
    top = sampler.levels - 1
    out = []
    for p in (0, 1):
        mine = np.where(L % 2 == p, L, np.where(L < top, L + 1, L - 1))
        need = np.flatnonzero((mine == L) | (g != 0))
        rows = {f: np.zeros(len(need), np.int64) for f in ("x0", "x1", "y0", "y1")}
        for lv in np.unique(mine[need]):
            sel = np.flatnonzero(mine[need] == lv)
            h, w = sampler.level_sizes[int(lv)]
            x0, x1, _ = sampler.positions(s[need[sel]], w)
            y0, y1, _ = sampler.positions(t[need[sel]], h)
            for f, v in (("x0", x0), ("x1", x1), ("y0", y0), ("y1", y1)):
                rows[f][sel] = v
        surf = np.asarray(surfaces, np.int64)[mine[need]] if len(need) else np.zeros(0, np.int64)
        out.append(Trace(need.astype(np.int64), surf, rows["x0"], rows["x1"], rows["y0"], rows["y1"]))
    return tuple(out)


def interleave(*traces: Trace) -> Trace:
    """Traces of the same fragments merged in engine order: fragment by fragment, the traces' lookups in the
    order given."""
    n = len(traces[0])
    require(all(len(t) == n for t in traces), "traces", [len(t) for t in traces], "must all have the same rows")
    cols = {f: np.stack([getattr(t, f) for t in traces], axis=1).ravel()
            for f in ("fragment", "surface", "x0", "x1", "y0", "y1")}
    return Trace(**cols)


@dataclass
class CacheResult:
    """What :func:`simulate` found: per line access (``lookup``, ``line``, ``set``, ``way``, ``hit``, in the
    order the cache makes them), per lookup (``lines`` touched, ``bank_conflict``), the line numbers filled in
    order (``fills``; burst address = line x line bytes) and the totals (:attr:`totals`)."""

    params: TexCacheParams
    lookup: np.ndarray
    line: np.ndarray
    set: np.ndarray
    way: np.ndarray
    hit: np.ndarray
    lines: np.ndarray
    bank_conflict: np.ndarray
    self_evictions: int
    fills: np.ndarray = field(init=False)

    def __post_init__(self):
        self.fills = self.line[~self.hit]

    @property
    def lookup_hit(self) -> np.ndarray:
        """Per lookup: every line of its footprint hit."""
        missed = np.zeros(len(self.lines), bool)
        missed[self.lookup[~self.hit]] = True
        return ~missed

    def burst_addresses(self) -> np.ndarray:
        """Byte address of each AXI4 burst in issue order (``bursts_per_line`` per fill)."""
        p = self.params
        step = AXI_MAX_BEATS * p.bus_bytes
        return (self.fills[:, None] * p.line_bytes + step * np.arange(p.bursts_per_line)).ravel()

    @property
    def totals(self) -> dict:
        p = self.params
        n, acc, hits = len(self.lines), len(self.hit), int(self.hit.sum())
        fills = acc - hits
        return {"lookups": n, "line_accesses": acc, "hits": hits, "misses": fills, "fills": fills,
                "lookup_hits": int(self.lookup_hit.sum()), "distinct_lines": len(np.unique(self.line)),
                "hit_rate": hits / acc if acc else 1.0,
                "lookup_hit_rate": float(self.lookup_hit.mean()) if n else 1.0,
                "memory_bytes": fills * p.line_bytes, "bursts": fills * p.bursts_per_line,
                "beats": fills * p.beats_per_line, "bank_conflicts": int(self.bank_conflict.sum()),
                "self_evictions": self.self_evictions}


def plru_victim(bits: int, ways: int) -> int:
    """The way a tree pseudo-LRU points at: from the root (node 0, children ``2n + 1``, ``2n + 2``), bit 0 goes
    left (lower ways), 1 right."""
    node, lo, span = 0, 0, ways
    while span > 1:
        span //= 2
        right = (bits >> node) & 1
        lo += span * right
        node = 2 * node + 1 + right
    return lo


def plru_touch(bits: int, ways: int, way: int) -> int:
    """Tree bits after using ``way``: each node on its path points away from it."""
    node, lo, span = 0, 0, ways
    while span > 1:
        span //= 2
        right = int(way >= lo + span)
        bits = (bits & ~(1 << node)) | ((1 - right) << node)
        lo += span * right
        node = 2 * node + 1 + right
    return bits


def _accesses(params: TexCacheParams, layout: Layout, trace: Trace):
    """Per line access in order: ``(lookup, line, set)``, and per lookup the lines touched and bank conflicts."""
    require(layout.block == params.block and layout.texel_bytes == params.texel_bytes, "layout",
            (layout.block, layout.texel_bytes), f"must have the cache's block {params.block} and texel_bytes "
            f"{params.texel_bytes}")
    x, y = trace.corners()
    surf = np.repeat(np.asarray(trace.surface, np.int64)[:, None], 4, axis=1)
    _, _, line = layout.blocks(surf, x, y)
    sets = layout.set_of(params, surf, x, y)
    keep = np.ones(line.shape, bool)
    for c in range(1, 4):
        keep[:, c] = np.all(line[:, :c] != line[:, c:c + 1], axis=1)
    conflict = np.zeros(len(trace), bool)
    for a in range(4):
        for b in range(a + 1, 4):
            same_bank = bank_of(x[:, a], y[:, a]) == bank_of(x[:, b], y[:, b])
            conflict |= same_bank & ((x[:, a] != x[:, b]) | (y[:, a] != y[:, b]))
    lookup = np.repeat(np.arange(len(trace)), 4).reshape(-1, 4)
    return lookup[keep], line[keep], sets[keep], keep.sum(axis=1), conflict


def simulate(params: TexCacheParams, layout: Layout, trace: Trace) -> CacheResult:
    """Run ``trace`` through an empty cache of ``params`` over ``layout``: every line access's hit or miss and
    way, in order (module docstring)."""
    lookup, line, sets, lines, conflict = _accesses(params, layout, trace)
    W, plru, fifo = params.ways, params.replacement == "plru", params.replacement == "fifo"
    tags = [[-1] * W for _ in range(params.sets)]
    stamp = [[0] * W for _ in range(params.sets)]             # lru: time of last use
    tree = [0] * params.sets                                   # plru: tree bits
    nxt = [0] * params.sets                                    # fifo: the next way to fill
    hit = np.zeros(len(line), bool)
    way = np.zeros(len(line), np.int64)
    used_by = {}                                               # (set, way) -> lookup that last used it
    self_evictions = 0
    for k, (lk, ln, st) in enumerate(zip(lookup.tolist(), line.tolist(), sets.tolist())):
        row = tags[st]
        if ln in row:
            w = row.index(ln)
            hit[k] = True
        else:
            if -1 in row:
                w = row.index(-1)
            elif fifo:
                w = next((v % W for v in range(nxt[st], nxt[st] + W) if used_by.get((st, v % W)) != lk), nxt[st])
            else:
                w = plru_victim(tree[st], W) if plru else min(range(W), key=stamp[st].__getitem__)
            nxt[st] = (w + 1) % W
            if row[w] != -1 and used_by.get((st, w)) == lk:
                self_evictions += 1                            # the lookup evicts a line it needs itself
            row[w] = ln
        used_by[(st, w)] = lk
        way[k] = w
        stamp[st][w] = k + 1
        if plru:
            tree[st] = plru_touch(tree[st], W, w)
    return CacheResult(params, lookup, line, sets, way, hit, lines, conflict, self_evictions)
