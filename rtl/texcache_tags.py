"""The tag side of the decoupled texel cache (``rtl/texcache_decoupled.py``, the RTL of
:mod:`fxmodel.units.texcache`, for the texture lookups of the pixel pipeline: paper, sections 3.2 and 4): a set's
row as one word (its ways' tags, valid bits and replacement state), the compare of a row with a line, the victim a
miss fills, the row after a step, and the tag store that holds every set's row in LUT RAM.

The replacement state of a row is, for LRU, the order of its ways as a matrix of bits, one per pair of ways
(:func:`lru_pairs`: bit ``(i, j)``, ``i < j``, says way ``i`` is older than way ``j``), or for round robin
(``replacement = "fifo"``) one pointer (the next way to fill): :func:`row_states` fields of :func:`state_bits` bits.
The matrix is exact LRU (the same victims as the model's ages, :mod:`fxmodel.units.texcache`), not an
approximation: a use of way ``u`` sets ``u`` younger than every other way and keeps the others' order, so the
ways stay totally ordered, and the oldest is the way older than all others. Ages (``0`` the youngest, ``ways - 1``
the oldest) would take a way's age, a compare with every other age and an increment to update, and a compare with
``ways - 1`` to find the oldest; a bit of the matrix updates from its own value and the way used alone, and the
oldest is an AND of ``ways - 1`` bits. The update and the victim are on the tag stage's step, which closes
every clock (``docs/texcache.md``), so the matrix keeps them a few gates deep; it is also narrower than the ages
for four ways (six bits against eight).
"""

from __future__ import annotations

from amaranth.hdl import Array, Cat, Const, Mux, Signal
from amaranth.lib.memory import Memory

from fxmodel.units.texcache import TexCacheParams

__all__ = ["age_bits", "lru_pairs", "row_states", "state_bits", "row_word", "row_fields", "compare", "victim",
           "new_rows", "tag_store", "step_decision"]


def age_bits(ways: int) -> int:
    """Bits of a way's LRU age (``0`` the youngest, ``ways - 1`` the oldest), or of the round-robin pointer."""
    return max(1, (ways - 1).bit_length())


def lru_pairs(ways: int) -> list[tuple[int, int]]:
    """The pairs of ways ``(i, j)``, ``i < j``, in the order of a row's LRU bits (bit set: way ``i`` is older)."""
    return [(i, j) for j in range(ways) for i in range(j)]


def row_states(params: TexCacheParams) -> int:
    """Replacement-state fields of a row: a bit per pair of ways (LRU, :func:`lru_pairs`) or one pointer (round
    robin)."""
    return len(lru_pairs(params.ways)) if params.replacement == "lru" else 1


def state_bits(params: TexCacheParams) -> int:
    """Bits of a replacement-state field: one (LRU's pairs) or a way number (round robin's pointer)."""
    return 1 if params.replacement == "lru" else age_bits(params.ways)


def older(states, ways: int, a: int, b: int):
    """Whether way ``a`` is older than way ``b`` (``a != b``) in a row's LRU bits ``states``."""
    k = lru_pairs(ways).index((min(a, b), max(a, b)))
    return states[k] if a < b else ~states[k]


def row_word(tags, valids, states):
    """A set's row as one word of the tag store: its ways' tags, then their valid bits, then its replacement state
    (:func:`row_states` fields)."""
    return Cat(*tags, *valids, *states)


def row_fields(word, ways: int, line_bits: int, states: int, wb: int) -> tuple[list, list, list]:
    """``(tags, valids, state)`` of a word of :func:`row_word` (``ways`` ways of ``line_bits``-bit tags; the
    replacement state: ``states`` fields of ``wb`` bits, :func:`row_states` and :func:`state_bits`)."""
    tags = [word[v * line_bits:(v + 1) * line_bits] for v in range(ways)]
    valids = [word[ways * line_bits + v] for v in range(ways)]
    base = ways * (line_bits + 1)
    return tags, valids, [word[base + v * wb:base + (v + 1) * wb] for v in range(states)]


def compare(m, tags, valids, line, name: str) -> tuple:
    """``(hit, way)``: whether a valid way of the row holds ``line`` and the lowest such way (combinational; one
    comparator a way)."""
    hit, way = Signal(name=f"{name}hit"), Signal(age_bits(len(tags)), name=f"{name}hit_way")
    for w in reversed(range(len(tags))):                         # the lowest way wins
        with m.If(valids[w] & (tags[w] == line)):
            m.d.comb += [hit.eq(1), way.eq(w)]
    return hit, way


def victim(m, params: TexCacheParams, valids, states, used, name: str):
    """The way a miss in the row fills: the lowest invalid way, else the oldest (LRU: the way older than every
    other in the row's bits ``states``), else the pointer's way or the first after it that ``used`` does not name
    (round robin; ``used`` is ``None`` for LRU)."""
    W = params.ways
    wb = age_bits(W)
    free, free_way = Signal(name=f"{name}free"), Signal(wb, name=f"{name}free_way")
    old_way = Signal(wb, name=f"{name}old")
    for w in reversed(range(W)):
        with m.If(~valids[w]):
            m.d.comb += [free.eq(1), free_way.eq(w)]
    if params.replacement == "lru":                              # one way is the oldest: its bits, OR-ed
        for b in range(wb):
            m.d.comb += old_way[b].eq(Cat(*(Cat(*(older(states, W, w, v) for v in range(W) if v != w)).all()
                                            for w in range(W) if w >> b & 1)).any())
    if params.replacement == "fifo":                             # the first way from the pointer on not used
        ptr = states[0]
        m.d.comb += old_way.eq(ptr)
        for d in reversed(range(W)):
            cand = (ptr + d)[:wb] if W & (W - 1) == 0 else Mux(ptr + d >= W, ptr + d - W, ptr + d)[:wb]
            with m.If(~Array(used)[cand]):
                m.d.comb += old_way.eq(cand)
    out = Signal(wb, name=f"{name}victim")
    m.d.comb += out.eq(Mux(free, free_way, old_way))
    return out


def new_rows(m, params: TexCacheParams, line_bits: int, c, way_now) -> list:
    """Each corner's row after its check (``c[q]``: ``line, tags, valids, states, hit, victim``): on a miss, the
    victim's tag and valid bit; the replacement state of LRU (the way used, ``way_now[q]``, becomes the youngest,
    the others keep their order: a pair's bit from its own value and the way used, :func:`lru_pairs`) or of round
    robin (a fill moves the pointer past its way). Round robin writes a row only in a fill (a hit changes none), so
    its new row is the fill's, from the held row and the victim alone. ``[(tags, valids, state)]`` per corner
    (``c[q].states``: the held row's state fields)."""
    W = params.ways
    wb = age_bits(W)
    rr = params.replacement == "fifo"
    out = []
    for q in range(4):
        tags = [Signal(line_bits, name=f"new_tag{q}_{v}") for v in range(W)]
        valids = [Signal(name=f"new_valid{q}_{v}") for v in range(W)]
        for v in range(W):
            fill = c[q].victim == v if rr else ~c[q].hit & (way_now[q] == v)
            m.d.comb += [tags[v].eq(Mux(fill, c[q].line, c[q].tags[v])), valids[v].eq(c[q].valids[v] | fill)]
        if rr:
            out.append((tags, valids, [Mux(c[q].victim == W - 1, 0, c[q].victim + 1)[:wb]]))
            continue
        states = [Signal(name=f"new_older{q}_{i}_{j}") for i, j in lru_pairs(W)]
        for k, (i, j) in enumerate(lru_pairs(W)):     # the way used becomes younger than every other
            m.d.comb += states[k].eq(Mux(way_now[q] == i, 0, Mux(way_now[q] == j, 1, c[q].states[k])))
        out.append((tags, valids, states))
    return out


def tag_store(m, params: TexCacheParams, line_bits: int, c, wr, new, platform, *, read_sets, load,
              next_sets) -> list:
    """The tag store: each set's row in LUT RAM with a write port per corner (corner ``w`` writes ``new[w]`` to
    its set ``c[w].set``, one-hot ``c[w].hot``, when ``wr[w]``; a step writes at most one set per corner, and a set
    from at most one corner; the decoupled cache writes from its step-write registers, a clock after the step) and
    a read port per set of ``read_sets``, built as a live-value table (LaForest & Steffan, FPGA 2010): a memory
    per write and read port (each write port writes its row into its four memories,
    one per read port), and per set a register naming the write port that wrote it last (``lvt``) and whether any
    did since reset (``written``; else the row is the empty one: no way valid, the ways in order, way 0 the
    youngest: every LRU bit clear). A read port
    reads its four memories and takes the live one's word. Returns per read port its set's row ``(tags, valids,
    state)``, combinational.

    ``read_sets`` are registers loaded with ``next_sets`` when ``load``: the live-value table is read a clock
    early, from ``next_sets``, into a copy per read port (``r_lvt{r}``, ``r_written{r}``, kept equal to the
    table's entry for ``read_sets[r]`` by this clock's writes, forwarded), so that a read goes from the set
    register through the LUT RAM and a four-way multiplexer on a register, not through the table. The
    forwarding compares both sets the port may hold next (``n_lvt{r}``: the next set's entry; ``h_lvt{r}``: the
    held set's), and ``load``, late in the clock (it comes from the tag stage's firing), selects between them
    at the last level, not ahead of the compares (the whole engine's slowest routed path ran from the step's
    decision through ``load`` into the compares).

    On the formal platform each set's live row as each read port sees it is named too (``store{j}_r{r}``:
    memories read at every address, as :class:`rtl.streams.CreditFIFO` names its slots), for the proof that the
    held rows are the store's (``formal/fetch.py``)."""
    W, S = params.ways, params.sets
    wb, lb, n = state_bits(params), line_bits, row_states(params)
    empty = row_word([Const(0, lb)] * W, [Const(0, 1)] * W, [Const(0, wb)] * n)
    width = len(empty)
    lvt = [Signal(2, name=f"lvt{j}") for j in range(S)]
    written = [Signal(name=f"written{j}") for j in range(S)]
    for w in range(4):
        with m.If(wr[w]):
            for j in range(S):
                with m.If(c[w].hot[j]):
                    m.d.sync += [lvt[j].eq(w), written[j].eq(1)]

    def live_row(mems, addr, was_written, port, name):   # a set's row through one read port's memories
        row = Signal(width, name=name)              # the live write port's word, or the empty row
        datas = []
        for mem in mems:
            rp = mem.read_port(domain="comb")
            m.d.comb += rp.addr.eq(addr)
            datas.append(rp.data)
        m.d.comb += row.eq(Mux(was_written, Array(datas)[port], empty))
        return row

    out = []
    for r, rset in enumerate(read_sets):
        mems = []
        for w in range(4):
            mem = Memory(shape=width, depth=S, init=[])
            m.submodules[f"tags_w{w}_r{r}"] = mem
            wp = mem.write_port()
            m.d.comb += [wp.addr.eq(c[w].set), wp.data.eq(row_word(*new[w])), wp.en.eq(wr[w])]
            mems.append(mem)
        r_lvt, r_written = Signal(2, name=f"r_lvt{r}"), Signal(name=f"r_written{r}")
        # the entry for the set this read port holds from the next clock on, with this clock's write to it
        # forwarded, for both sets it may hold (the next one, loaded, and the one held); ``load`` selects last
        nxt = (Signal(2, name=f"n_lvt{r}"), Signal(name=f"n_written{r}"))
        hold = (Signal(2, name=f"h_lvt{r}"), Signal(name=f"h_written{r}"))
        m.d.comb += [nxt[0].eq(Array(lvt)[next_sets[r]]), nxt[1].eq(Array(written)[next_sets[r]]),
                     hold[0].eq(r_lvt), hold[1].eq(r_written)]
        for w in range(4):
            for entry, s in ((nxt, next_sets[r]), (hold, rset)):
                with m.If(wr[w] & (c[w].set == s)):
                    m.d.comb += [entry[0].eq(w), entry[1].eq(1)]
        m.d.sync += [r_lvt.eq(Mux(load, nxt[0], hold[0])), r_written.eq(Mux(load, nxt[1], hold[1]))]
        row = live_row(mems, rset, r_written, r_lvt, f"stored{r}")
        if platform == "formal":
            for j in range(S):
                live_row(mems, Const(j, len(rset)), written[j], lvt[j], f"store{j}_r{r}")
        out.append(row_fields(row, W, lb, n, wb))
    return out


def step_decision(m, hits, live, same, kk, name):
    """LRU: the step of a lookup whose live corners are ``live`` and next corner ``kk``, from its outcomes
    ``hits``: ``(allin, step_miss)``. All remaining corners in one step (``allin``) when they fall in distinct
    sets and at most one of them misses, else corner ``kk`` alone; ``step_miss``: the step misses. In gates, not
    a count of the misses (an adder and a compare, a carry chain on an ECP5, on the path from the compares)."""
    clash = Signal(name=f"{name}clash")
    for q in range(4):
        for j in range(q):
            with m.If(live[q] & live[j] & same[q, j]):
                m.d.comb += clash.eq(1)
    miss = [live[q] & ~hits[q] for q in range(4)]
    two = Signal(name=f"{name}two_misses")
    m.d.comb += two.eq(Cat(*(miss[q] & miss[j] for q in range(4) for j in range(q))).any())
    allin, step_miss = Signal(name=f"{name}allin"), Signal(name=f"{name}step_miss")
    m.d.comb += [allin.eq(~clash & ~two), step_miss.eq(Mux(allin, Cat(*miss).any(), Array(miss)[kk]))]
    return allin, step_miss
