"""The texel cache model (``fxmodel/units/texcache.py``) against a brute-force reference written differently (a dict
of sets holding explicit recency lists; the pseudo-LRU tree as a dict of intervals), on random traces; the
footprint-per-bank property; the blocked layout's bijectivity; validation."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fxmodel.core.fixed import Fmt
from fxmodel.units.sampler import SamplerParams, Texels
from fxmodel.units.texcache import (
    Layout,
    TexCacheParams,
    Trace,
    bank_of,
    footprints,
    interleave,
    level_lookups,
    plru_touch,
    plru_victim,
    simulate,
)


def ref_set_index(params, layout, k, x, y):
    """The set of texel ``(x, y)`` of surface ``k``, from the documented rule with Python ints."""
    _, h, w = layout.surfaces[k]
    B = params.block
    bx, by = x // B, y // B
    first = layout.base // layout.line_bytes + sum(-(-hh // B) * -(-ww // B) for _, hh, ww in layout.surfaces[:k])
    line = first + by * -(-w // B) + bx
    if params.index == "linear":
        return line, line % params.sets
    s = params.sets.bit_length() - 1
    hh = (s + 1) // 2
    return line, (bx ^ (by << hh) ^ (by >> (s - hh)) ^ first) % params.sets


class RefPLRU:
    """Tree pseudo-LRU kept as a dict ``(lo, hi) -> True`` when the next victim is in the upper half."""

    def __init__(self, ways):
        self.ways, self.upper = ways, {}

    def victim(self):
        lo, hi = 0, self.ways
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if self.upper.get((lo, hi), False) else (lo, mid)
        return lo

    def touch(self, way):
        lo, hi = 0, self.ways
        while hi - lo > 1:
            mid = (lo + hi) // 2
            self.upper[(lo, hi)] = way < mid
            lo, hi = (lo, mid) if way < mid else (mid, hi)


def reference(params, layout, trace):
    """Brute force: per lookup the distinct lines in corner order, per set a recency list of ``[line, way]``
    (most recent first) and the free ways; returns ``[(lookup, line, way, hit)]``."""
    recency = {}
    free = {}
    plru = {}
    ring = {}                                   # fifo: per set, the ways in round-robin order from the next one
    users = {}                                  # (set, way) -> the lookup that used it last
    out = []
    for n in range(len(trace)):
        k = int(trace.surface[n])
        seen = []
        for x, y in ((trace.x0[n], trace.y0[n]), (trace.x1[n], trace.y0[n]), (trace.x0[n], trace.y1[n]),
                     (trace.x1[n], trace.y1[n])):
            line, s = ref_set_index(params, layout, k, int(x), int(y))
            if line in seen:
                continue
            seen.append(line)
            lst = recency.setdefault(s, [])
            fr = free.setdefault(s, set(range(params.ways)))
            tree = plru.setdefault(s, RefPLRU(params.ways))
            entry = next((e for e in lst if e[0] == line), None)
            if entry is not None:
                hit, way = True, entry[1]
                lst.remove(entry)
            elif fr:
                hit, way = False, min(fr)
                fr.discard(way)
            else:
                hit = False
                if params.replacement == "lru":
                    way = lst[-1][1]
                elif params.replacement == "plru":
                    way = tree.victim()
                else:                           # the next way in the ring this lookup has not used
                    hand = ring.setdefault(s, list(range(params.ways)))
                    way = next((v for v in hand if users.get((s, v)) != n), hand[0])
                lst[:] = [e for e in lst if e[1] != way]
            if not hit:                         # the ring turns to the way after the one filled
                hand = ring.setdefault(s, list(range(params.ways)))
                turn = hand.index(way) + 1
                hand[:] = hand[turn:] + hand[:turn]
            lst.insert(0, [line, way])
            tree.touch(way)
            users[(s, way)] = n
            out.append((n, line, way, hit))
    return out


@st.composite
def cases(draw):
    B = draw(st.sampled_from([2, 4, 8]))
    sets = draw(st.sampled_from([1, 2, 4, 8, 16]))
    repl = draw(st.sampled_from(["lru", "plru", "fifo"]))
    ways = draw(st.sampled_from([1, 2, 4, 8] if repl == "plru" else [1, 2, 3, 4, 5]))
    params = TexCacheParams(block=B, sets=sets, ways=ways, replacement=repl,
                            index=draw(st.sampled_from(["linear", "xor"])), bus_bytes=draw(st.sampled_from([4, 8])))
    n_surf = draw(st.integers(1, 3))
    shapes = [(draw(st.integers(1, 40)), draw(st.integers(1, 40))) for _ in range(n_surf)]
    layout = Layout(tuple(((f"m{k}", 0), h, w) for k, (h, w) in enumerate(shapes)), B,
                    base=draw(st.integers(0, 5)) * params.line_bytes)
    n = draw(st.integers(0, 120))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    surf = rng.integers(0, n_surf, n)
    h = np.array([shapes[k][0] for k in surf], dtype=np.int64)
    w = np.array([shapes[k][1] for k in surf], dtype=np.int64)
    # a walk (locality, so hits happen) plus jumps; the footprint wraps like ``repeat``
    x0 = (np.cumsum(rng.integers(-2, 3, n)) + rng.integers(0, 3, n) * (rng.random(n) < 0.1) * 17) % w
    y0 = (np.cumsum(rng.integers(-1, 2, n)) + (rng.random(n) < 0.1) * 11) % h
    trace = Trace(np.arange(n), surf, x0, (x0 + 1) % w, y0, (y0 + 1) % h)
    return params, layout, trace


@settings(max_examples=300, deadline=None)
@given(cases())
def test_simulate_matches_brute_force(case):
    params, layout, trace = case
    res = simulate(params, layout, trace)
    ref = reference(params, layout, trace)
    got = list(zip(res.lookup.tolist(), res.line.tolist(), res.way.tolist(), res.hit.tolist()))
    assert got == ref
    tot = res.totals
    misses = sum(1 for r in ref if not r[3])
    assert tot["misses"] == tot["fills"] == misses
    assert tot["memory_bytes"] == misses * params.block ** 2 * params.texel_bytes
    assert tot["beats"] * params.bus_bytes == tot["memory_bytes"]
    assert len(res.burst_addresses()) == tot["bursts"]
    assert all(a % params.line_bytes == 0 for a in res.burst_addresses())


@given(st.integers(0, 2**32 - 1), st.sampled_from([1, 2, 4, 8]))
def test_plru_tree_matches_interval_reference(seed, ways):
    rng = np.random.default_rng(seed)
    bits, ref = 0, RefPLRU(ways)
    for way in rng.integers(0, ways, 50).tolist():
        assert plru_victim(bits, ways) == ref.victim()
        bits = plru_touch(bits, ways, way)
        ref.touch(way)
        assert plru_victim(bits, ways) != way or ways == 1


@given(st.integers(1, 37), st.integers(1, 37), st.sampled_from([2, 4, 8, 16]), st.integers(0, 2**32 - 1))
def test_footprint_one_read_per_bank(h, w, B, seed):
    """Any bilinear footprint of a sampler (repeat, clamp) puts its texels in four banks, two texels in one bank
    only as the same texel -- except repeat wrapping an odd size, which the model counts as a bank conflict."""
    rng = np.random.default_rng(seed)
    for edge in ("repeat", "clamp"):
        smp = SamplerParams(texels=Texels(np.zeros((1, h, w, 1), np.int64)), channels=(Fmt(True, 1, 9),),
                            coord_fmt=Fmt(True, 3, 8), edge=edge)
        s, t = rng.integers(-3000, 3000, 200), rng.integers(-3000, 3000, 200)
        tr = footprints(smp, s, t, 0)
        x, y = tr.corners()
        bank = bank_of(x, y)
        wraps = (edge == "repeat") & (((w % 2 == 1) & (tr.x1 < tr.x0)) | ((h % 2 == 1) & (tr.y1 < tr.y0)))
        clash = np.zeros(len(tr), bool)
        for a in range(4):
            for b in range(a + 1, 4):
                clash |= (bank[:, a] == bank[:, b]) & ((x[:, a] != x[:, b]) | (y[:, a] != y[:, b]))
        assert not np.any(clash & ~wraps)
        res = simulate(TexCacheParams(block=B), Layout(((("m", 0), h, w),), B), tr)
        assert np.array_equal(res.bank_conflict, clash)


@given(st.lists(st.tuples(st.integers(1, 30), st.integers(1, 30)), min_size=1, max_size=4),
       st.sampled_from([2, 4, 8]), st.sampled_from([1, 2, 4, 8]), st.integers(0, 3))
def test_layout_is_a_bijection(shapes, B, tb, base_lines):
    lay = Layout(tuple(((f"m{k}", 0), h, w) for k, (h, w) in enumerate(shapes)), B, tb,
                 base=base_lines * B * B * tb)
    addrs = {}
    for k, (h, w) in enumerate(shapes):
        yy, xx = np.mgrid[0:h, 0:w]
        a = lay.address(np.full(xx.size, k), xx.ravel(), yy.ravel())
        for ai, xi, yi in zip(a.tolist(), xx.ravel().tolist(), yy.ravel().tolist()):
            assert ai not in addrs
            addrs[ai] = (k, xi, yi)
            assert lay.texel_at(ai) == (k, xi, yi)
            assert lay.base <= ai < lay.base + lay.size_bytes
    # every other address of the span is padding (or not texel-aligned)
    for a in range(lay.base, lay.base + lay.size_bytes, tb):
        assert (lay.texel_at(a) is None) == (a not in addrs)
    # a block is one line: the texels of a line are contiguous and line-aligned
    k, x, y = addrs[min(addrs)]
    assert min(addrs) % lay.line_bytes == 0


@given(st.lists(st.tuples(st.integers(1, 3), st.integers(1, 20), st.integers(1, 20)), min_size=1, max_size=3),
       st.sampled_from([2, 4]), st.integers(0, 3), st.integers(0, 2**31 - 1))
def test_map_spans_and_the_image(maps, B, base_lines, seed):
    """Each map's span holds exactly its levels' texels and nothing of another map's, the spans tile the layout in
    order; the image holds each texel's word at its address (read back through ``texel_at``), padding zero."""
    surfaces = tuple(((f"m{k}", lv), max(1, h >> lv), max(1, w >> lv)) for k, (n, h, w) in enumerate(maps)
                     for lv in range(n))
    lay = Layout(surfaces, B, 4, base=base_lines * B * B * 4)
    rng = np.random.default_rng(seed)
    words = [rng.integers(1, 1 << 32, (h, w)) for _, h, w in surfaces]
    img = lay.image(words)
    assert len(img) == lay.size_bytes
    end = lay.base
    for k in range(len(maps)):
        a, n = lay.span(f"m{k}")
        assert a == end and n > 0 and n % lay.line_bytes == 0
        end = a + n
        for off in range(0, n, 4):
            at = lay.texel_at(a + off)
            assert at is None or surfaces[at[0]][0][0] == f"m{k}"
    assert end == lay.base + lay.size_bytes
    for off in range(0, len(img), 4):
        at = lay.texel_at(lay.base + off)
        want = 0 if at is None else int(words[at[0]][at[2], at[1]])
        assert int.from_bytes(img[off:off + 4], "little") == want
    with pytest.raises(KeyError, match="no surface"):
        lay.span("absent")


def test_footprints_follow_the_sampler_and_interleave():
    smp = SamplerParams.PRESETS["default"]
    s = np.array([0, 100, -5000, 2**15])
    t = np.array([7, 2**16 - 1, 3, 0])
    tr = footprints(smp, s, t, 1)
    i0, i1, _ = smp.positions(s, smp.width)
    j0, j1, _ = smp.positions(t, smp.height)
    assert np.array_equal(tr.x0, i0) and np.array_equal(tr.x1, i1)
    assert np.array_equal(tr.y0, j0) and np.array_equal(tr.y1, j1)
    both = interleave(footprints(smp, s, t, 0), tr)
    assert both.fragment.tolist() == [0, 0, 1, 1, 2, 2, 3, 3] and both.surface.tolist() == [0, 1] * 4


@pytest.mark.parametrize("kw, word", [({"block": 3}, "block"), ({"sets": 12}, "sets"), ({"ways": 0}, "ways"),
                                      ({"ways": 3, "replacement": "plru"}, "ways"), ({"replacement": "mru"},
                                                                                     "replacement"),
                                      ({"bus_bytes": 16}, "bus_bytes"), ({"block": 64}, "block"),
                                      ({"index": "hash"}, "index"), ({"texel_bits": 33}, "texel_bits"),
                                      ({"lookup_depth": 100}, "lookup_depth"), ({"misses": 2}, "misses")])
def test_bad_parameters_name_themselves(kw, word):
    with pytest.raises(ValueError, match=f"^{word}="):
        TexCacheParams(**kw)


def test_decoupled_cost_adds_the_lookup_fifo_and_the_fill_buffer():
    """The decoupled RTL's memories: the blocking cache's, its data banks read through their blocks' output
    registers (``rtl/bram.py``), a lookup FIFO of ``lookup_depth`` entries (a word address per bank, a bank per
    corner, the fill count, the sideband) and four fill-buffer banks of ``misses`` lines by parity."""
    p = TexCacheParams(block=8, sets=32, ways=4, texel_bits=28, lookup_depth=64, misses=8)
    base = p.memories()
    mems = p.memories(side_bits=5, decoupled=True)
    assert not base[0].registered and mems[0] == replace(base[0], registered=True)
    assert mems[1] == base[1] and len(mems) == 4
    fifo, fill = mems[2:]
    bank_words = p.lines * 64 // 4                                  # 2048 words: 11 address bits
    assert (fifo.words, fifo.bits) == (64, 4 * (bank_words - 1).bit_length() + 4 * 2 + 3 + 5)
    assert (fill.words, fill.bits, fill.count) == (8 * 64 // 4, 28, 4)


def test_layout_and_cache_must_agree():
    with pytest.raises(ValueError, match="^layout="):
        simulate(TexCacheParams(block=4), Layout(((("m", 0), 8, 8),), 8), Trace(*([np.zeros(1, np.int64)] * 6)))


@settings(max_examples=200, deadline=None)
@given(cases())
def test_self_evictions_are_counted(case):
    """The model's count of lookups evicting a line they need is the reference's (misses into a slot an earlier
    line of the same lookup used); none with true LRU or round robin (which skips the ways the lookup used) and
    at least four ways: a lookup has at most four lines."""
    params, layout, trace = case
    res = simulate(params, layout, trace)
    own = 0
    used = set()
    for n, line, way, hit in reference(params, layout, trace):
        if not used or next(iter(used))[0] != n:
            used = {(n, None, None)}
        slot = (n, _set_of_line(params, layout, trace, n, line), way)
        own += (not hit) and slot in used
        used.add(slot)
    assert res.self_evictions == own
    if params.ways >= 4 and params.replacement in ("lru", "fifo"):
        assert res.self_evictions == 0


@given(st.sampled_from([2, 4, 8, 16, 64]), st.integers(2, 70), st.integers(2, 40), st.integers(0, 68),
       st.integers(0, 38), st.sampled_from(["linear", "xor"]))
def test_footprint_lines_at_most_two_a_set(sets, bpr, rows, bx, by, index):
    """Of the four lines of a footprint that does not wrap around the map's edge, at most two share a set (either
    index, two sets or more): so with two ways such a lookup never evicts a line it needs."""
    bx, by = bx % (bpr - 1), by % (rows - 1)
    params = TexCacheParams(block=2, sets=sets, ways=2, index=index)
    lay = Layout(((("m", 0), 2 * rows, 2 * bpr),), 2)
    x = np.array([2 * bx, 2 * bx + 2, 2 * bx, 2 * bx + 2])
    y = np.array([2 * by, 2 * by, 2 * by + 2, 2 * by + 2])
    got = lay.set_of(params, np.zeros(4, np.int64), x, y).tolist()
    assert max(got.count(v) for v in got) <= 2


def _set_of_line(params, layout, trace, n, line):
    """The set of ``line``, one of lookup ``n``'s lines."""
    k = int(trace.surface[n])
    for x in (trace.x0[n], trace.x1[n]):
        for y in (trace.y0[n], trace.y1[n]):
            got, s = ref_set_index(params, layout, k, int(x), int(y))
            if got == line:
                return s
    raise AssertionError("line not in the footprint")


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), repeat=st.booleans())
def test_level_lookups_are_the_levels_a_trilinear_lookup_needs(seed, repeat):
    """Per fragment the even and the odd cache look up exactly the levels the trilinear blend needs (level ``L``
    always, the other level of ``L, L + 1`` only when ``g != 0``), each in the cache of its parity, at the
    sampler's footprint for that level's size; and the blend is the same whatever the texels of a level not
    looked up (at ``g = 0``)."""
    import dataclasses
    smp = SamplerParams.PRESETS["trilinear"]
    if not repeat:
        smp = dataclasses.replace(smp, edge="clamp")
    rng = np.random.default_rng(seed)
    s, t, lod = smp.random_inputs(rng, 200).T
    surfaces = [10 + 3 * lv for lv in range(smp.levels)]           # any surface numbering
    even, odd = level_lookups(smp, s, t, lod, surfaces)
    L, L1, g = smp.level(lod)
    got = {}
    for p, tr in enumerate((even, odd)):
        for k, sf, x0, x1, y0, y1 in zip(*(getattr(tr, f).tolist() for f in ("fragment", "surface", "x0", "x1",
                                                                            "y0", "y1"))):
            lv = surfaces.index(sf)
            assert lv % 2 == p
            got.setdefault(k, {})[lv] = (x0, x1, y0, y1)
    for k in range(len(s)):
        want = {int(L[k])} | ({int(L1[k])} if g[k] else set())
        assert set(got.get(k, {})) == want
        for lv in want:
            h, w = smp.level_sizes[lv]
            i0, i1, _ = smp.positions(s[k:k + 1], w)
            j0, j1, _ = smp.positions(t[k:k + 1], h)
            assert got[k][lv] == (int(i0[0]), int(i1[0]), int(j0[0]), int(j1[0]))
    # a level not looked up does not matter: every other level's texels scrambled, the same samples
    one = g == 0
    for lv in np.unique(L[one]).tolist():
        rows = np.flatnonzero(one & (L == lv))
        codes = [smp.texels.codes] + [m.codes for m in smp.mips]
        codes = [c if k == lv else rng.integers(0, 256, size=c.shape) for k, c in enumerate(codes)]
        other = dataclasses.replace(smp, texels=Texels(codes[0]), mips=tuple(Texels(c) for c in codes[1:]))
        assert np.array_equal(other.sample_trilinear(s[rows], t[rows], lod[rows]),
                              smp.sample_trilinear(s[rows], t[rows], lod[rows]))
    assert one.any() and (~one).any()
