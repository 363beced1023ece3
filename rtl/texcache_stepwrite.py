"""The step-write stage of the decoupled texel cache (``rtl/texcache_decoupled.py``, the RTL of
:mod:`fxmodel.units.texcache`, for the texture lookups of the pixel pipeline: paper, sections 3.2 and 4): the tag
stage's step writes its new rows into registers, and from them, a clock later, into the tag store and every held
row of their sets; meanwhile the held rows are read with that pending write over them (``docs/texcache.md``).
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Mux, Signal

from fxmodel.units.texcache import TexCacheParams

from .texcache_tags import age_bits, compare, row_states, state_bits

__all__ = ["step_write", "one_hot_pick", "overlay", "compare_over", "held_rows"]


def one_hot_pick(sel, values):
    """The value whose select is set, of one-hot selects ``sel``: an AND-OR of the terms, not a chain of
    multiplexers (zero when none is set)."""
    out = 0
    for t, v in enumerate(values):
        out = out | Mux(sel[t], v, 0)
    return out


def overlay(m, held, wp, sel, name: str) -> SimpleNamespace:
    """A held row (``tags``, ``valids``, ``states``) with the pending write ``wp`` over it: the row of the pending
    corner ``j`` that ``sel[j]`` names, else (``sel[4]``) the held row; the selects are one-hot (formal invariants
    ``fw*`` for the registered ones), so this is :func:`one_hot_pick` of five terms."""
    out = SimpleNamespace()
    for field in ("tags", "valids", "states"):
        sigs = []
        for v, x in enumerate(getattr(held, field)):
            y = Signal.like(x, name=f"{name}{field[:-1]}{v}")
            m.d.comb += y.eq(one_hot_pick(sel, [getattr(wp[j], field)[v] for j in range(4)] + [x]))
            sigs.append(y)
        setattr(out, field, sigs)
    return out


def compare_over(m, held, wp, sel, line, name: str) -> tuple:
    """``(hit, way)`` of :func:`rtl.texcache_tags.compare` on the held row with the pending write over it
    (:func:`overlay` with the one-hot selects ``sel``), taken term by term: each pending row and the held row are
    compared with ``line`` from their registers, and the selects pick the outcome at the last level instead of
    the row at the first. Equal whenever the selects are one-hot (formal invariants ``fw*``); the selects, from
    across the cache, then meet the compare's end, not its start (the prefetch stage's compares lead into the
    step's decision a clock ahead and its firing: ``docs/texcache.md``)."""
    outs = [compare(m, w.tags, w.valids, line, f"{name}w{j}_") for j, w in enumerate(wp)]
    outs.append(compare(m, held.tags, held.valids, line, f"{name}h_"))
    hit, way = Signal(name=f"{name}hit"), Signal(age_bits(len(held.tags)), name=f"{name}hit_way")
    m.d.comb += [hit.eq(one_hot_pick(sel, [h for h, _ in outs])), way.eq(one_hot_pick(sel, [w for _, w in outs]))]
    return hit, way


def step_write(m, params: TexCacheParams, line_bits: int, c, pre, nc) -> SimpleNamespace:
    """The step's write, pending a clock (``wp``: per corner whether it writes, ``en``; its set, ``set``, one-hot
    ``hot``; the row it writes, ``row``: tags, valid bits, replacement state, also as ``tags``, ``valids``,
    ``states``), the registers that select which pending row each held row takes (``fw`` for the tag stage's corners
    ``c``, ``pfw`` for the prefetch stage's ``pre.c``; the last select: none), and the held rows with the pending
    write over them (``eff``, ``peff``: :func:`overlay`)."""
    P = params
    wp = []
    for j in range(4):
        w = SimpleNamespace(en=Signal(name=f"wp_en{j}"), set=Signal.like(nc[j].set, name=f"wp_set{j}"),
                            hot=Signal(P.sets, name=f"wp_hot{j}"))
        w.tags = [Signal(line_bits, name=f"wp_tag{j}_{v}") for v in range(P.ways)]
        w.valids = [Signal(name=f"wp_valid{j}_{v}") for v in range(P.ways)]
        w.states = [Signal(state_bits(P), name=f"wp_state{j}_{v}") for v in range(row_states(P))]
        w.row = (w.tags, w.valids, w.states)
        wp.append(w)
    fw = [[Signal(name=f"fw{q}_{j}") for j in range(5)] for q in range(4)]
    pfw = [[Signal(name=f"p_fw{q}_{j}") for j in range(5)] for q in range(4)]
    return SimpleNamespace(wp=wp, fw=fw, pfw=pfw, eff=[overlay(m, c[q], wp, fw[q], f"e{q}_") for q in range(4)],
                           peff=[overlay(m, pre.c[q], wp, pfw[q], f"pe{q}_") for q in range(4)])


def held_rows(m, params: TexCacheParams, sw, c, pre, nc, same, wr, new, p_load, accept, stored):
    """This clock's step's write (``wr``, ``new``) into the pending registers of ``sw`` (:func:`step_write`), and
    the held rows, a clock behind the step: each takes the pending write (the previous clock's step) to its set in
    this clock, as the store does, and the step and the compares read them with it over them (``sw.eff``,
    ``sw.peff``). The prefetch stage's: loaded with a lookup (each corner's set's row read from the tag store,
    ``stored``, the pending write to that set over it), else the pending write to their set. The tag stage's:
    loaded from the prefetch stage's with the pending write, else the pending write to their set. The selects of
    the overlays for the next clock (``sw.fw``, ``sw.pfw``: which corner of this clock's step writes the set the
    row holds then) are registers, decided from this clock's writes and sets."""
    W = params.ways
    wp = sw.wp
    for j in range(4):                                       # the step's write, applied in the next clock
        m.d.sync += [wp[j].en.eq(wr[j]), wp[j].set.eq(c[j].set), wp[j].hot.eq(c[j].hot)]
        m.d.sync += [x.eq(y) for field in range(3) for x, y in zip(wp[j].row[field], new[j][field])]

    def assign(dst, row):
        m.d.sync += [dst.tags[v].eq(row.tags[v]) for v in range(W)]
        m.d.sync += [dst.valids[v].eq(row.valids[v]) for v in range(W)]
        m.d.sync += [dst.states[v].eq(row.states[v]) for v in range(len(row.states))]

    def selects(regs, hits):                                 # registers of one-hot selects from this clock's writes
        for j in range(4):
            m.d.sync += regs[j].eq(hits[j])
        m.d.sync += regs[4].eq(~sum(hits[j] for j in range(4)).bool())

    for q in range(4):
        pc = pre.c[q]
        # this clock's write to the set each row holds in the next clock
        selects(sw.fw[q], [wr[j] & Mux(accept, c[j].set == pc.set, 1 if j == q else same[max(q, j), min(q, j)])
                           for j in range(4)])
        selects(sw.pfw[q], [wr[j] & Mux(p_load, c[j].set == nc[q].set, c[j].set == pc.set)   # p_load selects last
                            for j in range(4)])
        to_next = [wp[j].en & (wp[j].set == nc[q].set) for j in range(4)]   # the pending write to the next set
        loaded = overlay(m, SimpleNamespace(tags=stored[q][0], valids=stored[q][1], states=stored[q][2]), wp,
                         to_next + [~sum(to_next).bool()], f"ld{q}_")
        with m.If(p_load):
            assign(pc, loaded)
        with m.Else():
            assign(pc, sw.peff[q])
        with m.If(accept):
            assign(c[q], sw.peff[q])
        with m.Else():
            assign(c[q], sw.eff[q])
