"""Read-manager entries (:data:`formal.readers.READ_MANAGERS`) of the decoupled texel cache
(``rtl/texcache_decoupled.py``, Igehy et al.: several bursts outstanding, a lookup FIFO) and of the texture fetch
(``rtl/texfetch.py``: both maps' caches forked and joined per fragment on one AXI4 read port), for the texture
lookups of the pixel pipeline (paper, sections 3.2 and 4).

Besides the generic harness's properties (AXI4 read channels, stream rules, no answer without a request, the
capacity), each entry adds:

- the decoupled cache: its white-box invariants (lines owed = lines queued for ``AR`` + bursts outstanding + lines
  complete in the fill buffer, never above ``misses``; the slot queue as long; the beat counter the burst's; a copy
  only of a complete line; lookups inside = the input FIFO + the set, prefetch and tag stages + the lookup FIFO +
  its head + the output register; the set stage's lines and sets are its request's; the tag store's copies agree
  and the held lookup's rows are its sets' rows in the store), which make k-induction close; covers: ``misses``
  bursts outstanding, the lookup FIFO full;
- the texture fetch: each ``AR`` comes from exactly one cache's handshake with its fields (``ar_from_one``), each
  cache's own bursts outstanding at most its ``misses`` (``c*_outstanding``), and every ``R`` beat routed to
  exactly the cache that issued its burst (``r_to_owner``, against a queue of the issuing caches kept by the
  harness), none lost (``r_routed``); checked to a bounded depth (:data:`FETCH_DEPTH`, why below).
"""

from __future__ import annotations

from dataclasses import replace

from amaranth.hdl import Array, Cat, Signal
from amaranth.lib.fifo import SyncFIFOBuffered

from fxmodel.units.texcache import Layout, TexCacheParams
from rtl.texcache_decoupled import AFTER, HELD, INPUT_DEPTH, DecoupledTexCache
from rtl.texcache_tags import row_states, row_word
from rtl.texfetch import MAPS, TexFetch

from . import whitebox
from .axiread import LenQueue
from .manager import STALL, ReadManager
from .props import Harness, bits_for

__all__ = ["ENTRIES", "DEC_PARAMS", "small_decoupled", "small_texfetch", "FETCH_DEPTH", "cache_invariants"]

#: The smallest decoupled cache that builds: 2 x 2 texel lines (4-beat bursts), 2 sets of 2 ways, 4-bit texels, a
#: lookup FIFO of 2, 4 lines owed at most (the least ``misses`` allowed).
DEC_PARAMS = TexCacheParams(block=2, sets=2, ways=2, index="linear", texel_bits=4, lookup_depth=2, misses=4)


def small_decoupled(replacement: str = DEC_PARAMS.replacement) -> DecoupledTexCache:
    """The decoupled cache of :data:`DEC_PARAMS` (with ``replacement``) over an 8 x 8 map placed across a 4 KB
    boundary (16-bit addresses)."""
    p = replace(DEC_PARAMS, replacement=replacement)
    layout = Layout(((("m", 0), 8, 8),), p.block, p.texel_bytes, base=4096 - 4 * p.line_bytes)
    return DecoupledTexCache(p, layout, addr_bits=16)


def small_texfetch(cls=TexFetch) -> TexFetch:
    """Both maps' caches of :data:`DEC_PARAMS` over two 4 x 4 maps, the first line of the second map the first
    line after a 4 KB boundary (16-bit addresses), a 1-bit sideband (``cls``: the class, or a function of its
    arguments that builds a variant)."""
    p = DEC_PARAMS
    layout = Layout(tuple(((k, 0), 4, 4) for k in MAPS), p.block, p.texel_bytes, base=4096 - 4 * p.line_bytes)
    return cls({k: p for k in MAPS}, layout, side_bits=1, addr_bits=16)


def _capacity(p: TexCacheParams) -> int:
    """Lookups a decoupled cache holds at most: the input FIFO's, the set, prefetch and tag stages', the lookup FIFO's,
    its head's, the data banks' read's and the output register's."""
    return INPUT_DEPTH + HELD + p.lookup_depth + AFTER


def buffered_fifo_invariants(h: Harness, sig, fifo, name: str):
    """An Amaranth ``SyncFIFOBuffered`` (depth at least 2; ``sig(n)`` finds its signals): its level is the inner
    FIFO's plus the output register's, and the output register is empty only right after a write into an empty
    FIFO (the inner FIFO holds at most that one entry)."""
    inner = sig("inner_level")
    h.check(fifo.level == inner + fifo.r_rdy, f"{name}_level_split")
    h.check(fifo.r_rdy | (inner <= 1), f"{name}_output_refilled")


def cache_invariants(h: Harness, sig, top, path: str, cache, pend, beat_ref, inside, *, prove: bool = True):
    """The decoupled cache at ``path`` (``cache``, its component): ``pend`` its bursts outstanding, ``beat_ref``
    the beat count of its current burst, ``inside`` its lookups inside. Covers: ``misses`` bursts outstanding,
    the lookup FIFO full."""
    p = cache.params
    s = lambda name: sig(name, path)                   # noqa: E731
    lfifo = whitebox.origin(top, f"{path}/lfifo".strip("/"), SyncFIFOBuffered)
    arq = whitebox.origin(top, f"{path}/arq".strip("/"), SyncFIFOBuffered)
    slots = whitebox.origin(top, f"{path}/slots".strip("/"), SyncFIFOBuffered)
    ififo = whitebox.origin(top, f"{path}/ififo".strip("/"), SyncFIFOBuffered)
    inflight, filled, beat, copying = s("inflight"), s("filled"), s("beat"), s("copying")
    if prove:
        for name, fifo in (("lfifo", lfifo), ("arq", arq), ("slots", slots), ("ififo", ififo)):
            buffered_fifo_invariants(h, lambda n, name=name: sig(n, f"{path}/{name}".strip("/")),
                                     fifo, name)
        # the tag stage's copy of the lookup FIFO's room and inner level (rtl/streams.py buffered_room)
        h.check((s("lfifo_inner") == sig("inner_level", f"{path}/lfifo".strip("/"))) & (s("lfifo_room") == lfifo.w_rdy),
                "lfifo_room_is_w_rdy")
        h.check(slots.r_rdy | ((slots.level == arq.level) & ~arq.r_rdy), "slot_queue_ahead")
        # the input FIFO's output register holds the corners' sets of the lookup it holds (rtl.streams
        # TailFIFOBuffered), the sets the set stage loads
        h.check(~ififo.r_rdy | (ififo.r_tail == Cat(*(s(f"f_set{q}") for q in range(4)))), "ififo_tail")
        h.check(inflight == arq.level + pend + filled, "owed_lines")
        h.check(inflight <= p.misses, "owed_bound")
        h.check(slots.level == inflight, "slot_queue")
        h.check(~copying | (filled != 0), "copy_of_complete_line")
        h.check(beat == beat_ref, "beat_is_burst_beat")
        held = s("s_valid") + s("p_valid") + s("t_valid")
        h.check(inside == ififo.level + held + lfifo.level + s("h_valid") + s("rd_valid") + s("o_valid"),
                "inside_is_stages")
        rows_coherent(h, s, p)
        next_lines(h, s, cache)
    h.cover(pend == p.misses, "misses_outstanding_reach")
    h.cover((lfifo.level == p.lookup_depth) & s("t_valid"), "lookup_fifo_full_reach")


def next_lines(h: Harness, s, cache: DecoupledTexCache):
    """``next_lines``: while the set stage holds a lookup, its registered corner lines and sets are the ones its
    request names (the input FIFO's storage may hold anything in the induction state; this ties the stage's copy
    to the request it carries)."""
    ok = 1
    for q, (line, set_) in enumerate(cache.corner_lines(cache.req(s("nreq")))):
        ok = ok & (s(f"nline{q}") == line) & (s(f"nset{q}") == set_)
    h.check(~s("s_valid") | ok, "next_lines")


def rows_coherent(h: Harness, s, p: TexCacheParams):
    """The tag store (``rtl/texcache_tags.py``'s live-value table over LUT RAMs) and the held rows:
    ``store_copies_agree`` (each set's live row is the same through every read port: a write port writes all its
    copies), ``rows_coherent`` and ``p_rows_coherent`` (while the tag stage, or the prefetch stage, holds a lookup,
    each corner's held row is its set's row in the store, both a clock behind the step: the forwarding and the
    updates), the step's write pending a clock (``wp_*``: one corner's row a set at most, its one-hot set; with
    round robin one corner's, a fill's, so the tag stage's outcomes are stale meanwhile) and
    each held row's overlay selects (``fw*_is_pending_sets``: which pending row it takes, or none), the sets' one-hot
    copies and pairwise equalities are the sets' (what the updates select by), and ``hits_current`` (the tag
    stage's registered outcomes, when it marks them current or, LRU, fresh, are its corners' compares with its
    held rows, the pending write over them; fresh, no write is pending and the step is not yet decided:
    ``wp_none_fresh``, ``fresh_not_current``), with
    LRU ``decision_ahead`` (the registers that decide the tag stage's step, decided a clock ahead, are then what
    its registered outcomes, corners and next corner decide); each read port's copy of the live-value table's
    entry (``r_lvt*_is_table``) is the table's for the set stage's set."""
    W = p.ways
    states = row_states(p)                               # LRU's bit per pair of ways, or round robin's pointer
    store = [[s(f"store{j}_r{r}") for j in range(p.sets)] for r in range(4)]
    for j in range(p.sets):
        for r in range(1, 4):
            h.check(store[r][j] == store[0][j], f"store{j}_copy{r}_agrees")
    table = Array(store[0])
    for prefix, valid in (("", "t_valid"), ("p_", "p_valid")):
        ok = 1
        for q in range(4):
            set_ = s(f"{prefix}set{q}")
            h.check(~s(valid) | (s(f"{prefix}hot{q}") == (1 << set_)[:p.sets]), f"{prefix}hot{q}_is_set")
            for j in range(q):
                h.check(~s(valid) | (s(f"{prefix}same{q}_{j}") == (set_ == s(f"{prefix}set{j}"))),
                        f"{prefix}same{q}_{j}_is_sets")
            held = row_word(*([s(f"{prefix}row_{field}{q}_{w}") for w in range(n)]
                              for field, n in (("tag", W), ("valid", W), ("state", states))))
            ok = ok & (held == table[set_])
        h.check(~s(valid) | ok, f"{prefix}rows_coherent")
    # the step's write, pending a clock: at most one corner's row a set, its one-hot set its set's, and each held
    # row's overlay selects (which pending row it takes, or none) the pending sets' equalities with its own set
    for j in range(4):
        h.check(~s(f"wp_en{j}") | (s(f"wp_hot{j}") == (1 << s(f"wp_set{j}"))[:p.sets]), f"wp_hot{j}_is_set")
        for i in range(j):
            both = s(f"wp_en{i}") & s(f"wp_en{j}")
            h.check(~(both & (s(f"wp_set{i}") == s(f"wp_set{j}"))), f"wp_sets{i}_{j}_distinct")
    any_wp = s("wp_en0") | s("wp_en1") | s("wp_en2") | s("wp_en3")
    if p.replacement == "lru":                           # the outcomes, fresh, were taken with no step since
        h.check(~s("hits_fresh") | ~any_wp, "wp_none_fresh")
        h.check(~(s("hits_fresh") & s("hits_ok")), "fresh_not_current")
    if p.replacement == "fifo":                          # round robin writes in a fill step only: one corner's row
        h.check(sum(s(f"wp_en{j}") for j in range(4)) <= 1, "wp_one_corner")
        h.check(~any_wp | ~(s("t_valid") & s("hits_ok")), "wp_outcomes_stale")
    for prefix, valid in (("", "t_valid"), ("p_", "p_valid")):
        for q in range(4):
            takes = [s(f"wp_en{j}") & (s(f"wp_set{j}") == s(f"{prefix}set{q}")) for j in range(4)]
            ok = s(f"{prefix}fw{q}_4") == ~(takes[0] | takes[1] | takes[2] | takes[3])
            for j in range(4):
                ok = ok & (s(f"{prefix}fw{q}_{j}") == takes[j])
            h.check(~s(valid) | ok, f"{prefix}fw{q}_is_pending_sets")
    # lemmas (consequences of the above, stated for the solver): held rows of one set agree with the pending write
    # over them, across corners and across the two stages
    def eff(prefix, q):
        return row_word(*([s(f"{prefix}{q}_{field}{w}") for w in range(n)]
                          for field, n in (("tag", W), ("valid", W), ("state", states))))
    for q in range(4):
        for j in range(4):
            if j < q:
                for prefix, valid, pv in (("e", "t_valid", ""), ("pe", "p_valid", "p_")):
                    h.check(~s(valid) | ~s(f"{pv}same{q}_{j}") | (eff(prefix, q) == eff(prefix, j)),
                            f"{prefix}{q}_{j}_agree")
            h.check(~(s("t_valid") & s("p_valid") & (s(f"set{q}") == s(f"p_set{j}"))) | (eff("e", q) == eff("pe", j)),
                    f"e{q}_pe{j}_agree")
    lvt, written = Array(s(f"lvt{j}") for j in range(p.sets)), Array(s(f"written{j}") for j in range(p.sets))
    for r in range(4):
        set_ = s(f"nset{r}")
        h.check((s(f"r_lvt{r}") == lvt[set_]) & (s(f"r_written{r}") == written[set_]), f"r_lvt{r}_is_table")
    cur = 1
    for q in range(4):
        cur = cur & (s(f"hit{q}") == s(f"t_{q}_hit")) & (~s(f"hit{q}") | (s(f"hit_way{q}") == s(f"t_{q}_hit_way")))
    taken = s("hits_ok") | s("hits_fresh") if p.replacement == "lru" else s("hits_ok")
    h.check(~(s("t_valid") & taken) | cur, "hits_current")
    if p.replacement == "lru":                           # the step decided a clock ahead (_decide_ahead)
        ahead = (s("allin") == s("now_allin")) & (s("step_miss") == s("now_step_miss"))
        h.check(~(s("t_valid") & s("hits_ok")) | ahead, "decision_ahead")
        # the step's firing and its last, registers decided from the next values (_fire_ahead), on every clock
        h.check((s("fire_ahead") == s("now_fire")) & (s("last_ahead") == s("now_last")), "firing_decided_ahead")
    # the data stage's readiness, a clock ahead; an empty head has copied nothing and copies nothing
    h.check(s("h_valid") | ((s("done") == 0) & ~s("copying")), "empty_head_idle")
    h.check(s("head_ready") == s("now_head_ready"), "head_ready_decided_ahead")


def _decoupled_invariants(h: Harness, sig, rd, inside, *, inner, top):
    cache_invariants(h, sig, top, "", inner, rd.ar_pend, rd.r_beat, inside)


#: Depth of the texture fetch's bounded check (cycles from reset).
FETCH_DEPTH = 14

FETCH_WHY = (
    "k-induction would need the contents of four FIFOs tied to each other (the owner FIFO to each cache's bursts); "
    f"bounded instead to {FETCH_DEPTH} cycles from reset (the solver's time grows steeply with the depth), enough "
    f"for a fragment's misses to be queued in both caches, their 2 x {DEC_PARAMS.misses} bursts granted "
    f"alternately (an AR waits at most {STALL} cycles) and the first of them returned and routed (a lookup FIFO full "
    "and bursts of both caches outstanding at once are reached inside this depth, the rest in the cover run); each "
    "cache alone is proven for all time (texcache_decoupled_axi)")


def _fetch_invariants(h: Harness, sig, rd, inside, *, inner, top):
    """Routing: AR from one cache, each cache's outstanding bound, R beats to the issuing cache."""
    m, axi = h.m, inner.mem
    caches = [inner.caches[k] for k in MAPS]
    subs = [c.mem for c in caches]
    ar_x = [s.arvalid & s.arready for s in subs]
    top_ar = axi.arvalid & axi.arready
    h.check(top_ar == (ar_x[0] | ar_x[1]), "ar_from_one")
    h.check(~(ar_x[0] & ar_x[1]), "ar_one_cache")
    for k, sub in enumerate(subs):
        fields = Cat(sub.araddr, sub.arlen, sub.arsize, sub.arburst, sub.arid)
        h.check(~ar_x[k] | (fields == Cat(axi.araddr, axi.arlen, axi.arsize, axi.arburst, axi.arid)),
                f"ar_fields_c{k}")
    owners = LenQueue(h, rd.max_out + 1, "owner")          # the cache that issued each outstanding burst
    r_x = axi.rvalid & axi.rready
    owners.update(top_ar, ar_x[1], r_x & axi.rlast)
    head = owners.head_len()[0]
    got = [s.rvalid for s in subs]
    h.check(~(got[0] | got[1]) | (owners.count != 0), "r_owner_known")
    for k in range(2):
        h.check(~got[k] | (head == k), f"r_to_owner_c{k}")
        h.check(~got[k] | (subs[k].rlast == axi.rlast) & (subs[k].rdata == axi.rdata), f"r_beat_c{k}")
    h.check(~axi.rvalid | (got[0] ^ got[1]), "r_routed")
    h.check(~r_x | (subs[0].rready & got[0]) | (subs[1].rready & got[1]), "r_taken_by_owner")
    for k, (c, sub) in enumerate(zip(caches, subs)):
        pend = Signal(bits_for(c.params.misses + 2), name=f"f_c{k}_pend")
        m.d.sync += pend.eq(pend + ar_x[k] - (sub.rvalid & sub.rready & sub.rlast))
        h.check(pend <= c.params.misses, f"c{k}_outstanding")
        with h.scope(f"c{k}_"):
            cache_invariants(h, sig, top, MAPS[k], c, pend, 0, inside, prove=False)
    h.cover((owners.count >= 2) & (owners.head_len()[0] != owners.regs[(owners.head + 1) % owners.n][0]),
            "both_caches_outstanding_reach")


ENTRIES = [
    ReadManager("texcache_decoupled_axi",
                f"DecoupledTexCache (block 2, 2 sets x 2 ways, lookup FIFO {DEC_PARAMS.lookup_depth}, misses "
                f"{DEC_PARAMS.misses}, 8x8 map across 4 KB, memory stalls <= {STALL})", small_decoupled,
                arlen=DEC_PARAMS.beats_per_line - 1, max_out=DEC_PARAMS.misses, capacity=_capacity(DEC_PARAMS),
                invariants=_decoupled_invariants, cover_depth=30,
                extra={"covers": "; lines owed = queued + outstanding + filled <= misses, inside = input FIFO + tag "
                                 "stage + lookup FIFO + output, held rows = the tag store's"}),
    ReadManager("texcache_decoupled_rr_axi",
                "DecoupledTexCache as above with round-robin replacement (a row holds one pointer; the victim skips "
                "the ways the same lookup used)", lambda: small_decoupled("fifo"),
                arlen=DEC_PARAMS.beats_per_line - 1, max_out=DEC_PARAMS.misses, capacity=_capacity(DEC_PARAMS),
                invariants=_decoupled_invariants, cover_depth=30,
                extra={"covers": "; as texcache_decoupled_axi, the held rows' pointers the tag store's"}),
    ReadManager("texfetch_axi",
                f"TexFetch: two DecoupledTexCache as above on one AXI4 port (two 4x4 maps, the second across 4 KB, "
                f"memory stalls <= {STALL})", small_texfetch, arlen=DEC_PARAMS.beats_per_line - 1,
                max_out=2 * DEC_PARAMS.misses, capacity=_capacity(DEC_PARAMS), invariants=_fetch_invariants,
                mode="bmc", depth=FETCH_DEPTH, cover_depth=26, why=FETCH_WHY,
                extra={"covers": "; fork/join: fragments in = out + inside; each AR from one cache with its fields, "
                                 "each cache's outstanding <= misses, every R beat to the cache that issued its "
                                 "burst, none lost"}),
]
