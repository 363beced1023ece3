"""RTL of the trilinear (MIP-mapped) texture sampler, the ``trilinear`` filter of
``fxmodel.units.sampler.SamplerParams`` (step 5 of its algorithm; paper section 6, "artifact reduced MIP mapping").

Two level memories: the even levels in one and the odd in the other (``parity_words``, each level row-major at its
``level_bases`` entry), four read ports each (replicated block RAM). Levels ``L`` and ``L + 1`` always differ in
parity, so the two bilinear lookups of a pixel read both memories in the same clock: one pixel per clock. Memory
``p`` looks up the level of parity ``p`` among ``L, L + 1`` (at the last level, where ``L + 1`` does not exist and the
blend weight is 0, ``L - 1``: any level of that parity, never used).

Stages (latency ``params.latency`` = 16; one carry chain or one product a stage, as ``rtl/sampler.py``): level,
blend weight and each memory's level | scaled positions (each level's size a constant product, selected) | indices,
wraps, weights | addresses | memory read | words registered | texel differences | ``fx`` products | row blends | row
difference | ``fy`` product | column blend (both lookups, before narrowing) | level difference | ``g`` product |
level blend | rounding. The words are registered as they leave the block RAMs (whose output Yosys leaves
unregistered): the MIP engine's routed clock was held by the level memories' words through the texel differences'
carry chains into the ``fx`` products' multiplier blocks (``docs/fpga/placement.json``, its missed endpoints).
With ``blend_frac`` the row and column blends are rounded in their own stages (:func:`_blend_sum`: no extra carry
chain, no extra stage), so the differences after them fit one multiplier block each.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Mux
from amaranth.lib.memory import Memory

from fxmodel.core.rounding import Overflow, Rounding

from .fixed import const_mul, narrow, saturate
from .recip import product_stage

__all__ = ["trilinear", "level_indices", "blends", "TEXEL_STAGES"]

#: Stages before the blends: level, scaled positions, indices, addresses, memory read, words registered (the corner
#: words of both lookups are there after them; the texture fetch of ``rtl/pixel_fetch.py`` splits the sampler at
#: this point).
TEXEL_STAGES = 6


def _pick(k, values):
    """``values[k]`` as a chain of multiplexers (``k`` a small index)."""
    out = values[-1]
    for i in reversed(range(len(values) - 1)):
        out = Mux(k == i, values[i], out)
    return out


def trilinear(c, m, pipe) -> dict:
    """Build the datapath of component ``c`` (a ``Sampler`` of a trilinear ``SamplerParams``) into module ``m``
    and ``pipe``; returns the outputs by name."""
    P = c.params
    s3 = level_indices(c, pipe)
    levels = [list(range(par, P.levels, 2)) for par in (0, 1)]           # global levels of each memory

    def sizes(p, axis):
        return [P.level_sizes[lv][axis] for lv in levels[p]]

    # 4: addresses base_l + j W_l + i
    corners = (("i0", "i0"), ("i1", "i0"), ("i0", "i1"), ("i1", "i1"))      # (x, y) of a, b, c, d
    addr, wts = {}, {}
    for p in (0, 1):
        k = getattr(s3, f"k{p}")
        hb = max(1, (max(sizes(p, 0)) - 1).bit_length())
        wb = max(1, (max(sizes(p, 1)) - 1).bit_length())
        for n, (xi, yi) in enumerate(corners):
            row = getattr(s3, f"y{p}_{yi}")[:hb]
            col = getattr(s3, f"x{p}_{xi}")[:wb]
            addr[f"a{p}{n}"] = _pick(k, [P.level_bases[lv] + const_mul(row, P.level_sizes[lv][1])
                                         for lv in levels[p]]) + col
        wts |= {f"fx{p}": getattr(s3, f"x{p}_f"), f"fy{p}": getattr(s3, f"y{p}_f")}
    s4 = pipe.stage(**addr, **wts, g=s3.g, odd=s3.odd)

    # 5: the memory read (blank memories when the board uploads them: the even levels' words, then the odd's)
    data, mems = {}, []
    blank = c.writes is not None and c.writes.blank
    for p in (0, 1):
        mem = Memory(shape=P.word_bits, depth=len(P.parity_words[p]), init=[] if blank else P.parity_words[p])
        m.submodules[f"levels{p}"] = mem
        mems.append(mem)
        for n in range(4):
            port = mem.read_port(domain="sync")
            m.d.comb += port.addr.eq(getattr(s4, f"a{p}{n}"))
            data[(p, n)] = port.data
    if c.writes is not None:
        c._writes(m, mems)
    late = pipe.stage(**wts_of(s4), g=s4.g, odd=s4.odd)
    # 6: the words registered (in the fabric, a route from the blocks), the weights beside them
    words = pipe.stage(**wts_of(late), g=late.g, odd=late.odd, **{f"d{p}{n}": v for (p, n), v in data.items()})
    return blends(c, pipe, {(p, n): getattr(words, f"d{p}{n}") for (p, n) in data}, words)


def level_indices(c, pipe):
    """Stages 1-3 of the trilinear sampler from ``c.s, c.t, c.lod`` (``c`` a ``Sampler`` of a trilinear
    ``SamplerParams``, or anything with those signals and ``params``): the last stage, with per memory ``p``
    (even levels 0, odd 1) its level's index ``k{p}`` within the memory (level ``2 k + p``), the texel indices
    ``x{p}_i0, x{p}_i1, y{p}_i0, y{p}_i1`` and weights ``x{p}_f, y{p}_f`` at that level, the level blend weight
    ``g`` and ``odd`` (the parity of level ``L``)."""
    P = c.params
    T, B, C, F = P.coord_fmt.frac_bits, P.weight_bits, P.level_bits, P.lod_fmt.frac_bits
    top = P.levels - 1
    one = 1 << T
    levels = [list(range(par, P.levels, 2)) for par in (0, 1)]           # global levels of each memory

    # 1: the level L (clamped), the blend weight g, each memory's level (its index k within the memory)
    lod = c.lod
    raw = lod >> F
    low = (lod < 0) | (raw >= top)
    L = Mux(lod < 0, 0, Mux(raw >= top, top, raw))[:max(1, top.bit_length())]
    mine = [Mux(L[0] == par, L, Mux(L < top, L + 1, L - 1)) for par in (0, 1)]
    s1 = pipe.stage(s=c.s, t=c.t, g=Mux(low, 0, lod[F - C:F]), odd=L[0], k0=mine[0] >> 1, k1=mine[1] >> 1)

    def edge(v):
        return v[:T] if P.edge == "repeat" else Mux(v < 0, 0, Mux(v > one, one, v))[:T + 1]

    def sizes(p, axis):
        return [P.level_sizes[lv][axis] for lv in levels[p]]

    # 2: scaled positions s W_l - 1/2 (T + 1 fraction bits) at each memory's level
    pos = {}
    for p in (0, 1):
        k = getattr(s1, f"k{p}")
        for ax, v, axis in (("x", s1.s, 1), ("y", s1.t, 0)):
            pos[f"{ax}{p}"] = _pick(k, [const_mul(edge(v), 2 * n) - one for n in sizes(p, axis)])
    s2 = pipe.stage(**pos, g=s1.g, odd=s1.odd, k0=s1.k0, k1=s1.k1)

    # 3: indices, wraps or clamps, weights
    idx = {}
    for p in (0, 1):
        k = getattr(s2, f"k{p}")
        for ax, axis in (("x", 1), ("y", 0)):
            x = getattr(s2, f"{ax}{p}")
            n = _pick(k, [Const(v, range(max(sizes(p, axis)) + 1)) for v in sizes(p, axis)])
            i0, i1 = x >> (T + 1), (x >> (T + 1)) + 1
            if P.edge == "repeat":
                i0, i1 = Mux(i0 < 0, n - 1, i0), Mux(i1 >= n, 0, i1)
            else:
                i0 = Mux(i0 < 0, 0, Mux(i0 > n - 1, n - 1, i0))
                i1 = Mux(i1 > n - 1, n - 1, i1)
            idx |= {f"{ax}{p}_i0": i0, f"{ax}{p}_i1": i1, f"{ax}{p}_f": x[T + 1 - B:T + 1]}
    return pipe.stage(**idx, g=s2.g, odd=s2.odd, k0=s2.k0, k1=s2.k1)


def wts_of(s) -> dict:
    return {f"f{ax}{p}": getattr(s, f"f{ax}{p}") for p in (0, 1) for ax in "xy"}


def blends(c, pipe, data, late) -> dict:
    """The two bilinear blends (exact, before narrowing), then the blend between the levels and the rounding."""
    P = c.params
    B, C = P.weight_bits, P.level_bits
    ch = range(len(P.channels))
    keys = [(p, k) for p in (0, 1) for k in ch]
    tex = {(p, k): [c._channel(data[(p, n)], k) for n in range(4)] for p, k in keys}
    keep = {"g": late.g, "odd": late.odd}
    s = pipe.stage(**wts_of(late), **keep, **{f"a{p}{k}": tex[(p, k)][0] for p, k in keys},
                   **{f"c{p}{k}": tex[(p, k)][2] for p, k in keys},
                   **{f"dab{p}{k}": tex[(p, k)][1] - tex[(p, k)][0] for p, k in keys},
                   **{f"dcd{p}{k}": tex[(p, k)][3] - tex[(p, k)][2] for p, k in keys})
    pt, cr = product_stage(pipe, {f"pt{p}{k}": (getattr(s, f"fx{p}"), getattr(s, f"dab{p}{k}")) for p, k in keys}
                       | {f"pb{p}{k}": (getattr(s, f"fx{p}"), getattr(s, f"dcd{p}{k}")) for p, k in keys},
                       {"g": s.g, "odd": s.odd, "fy0": s.fy0, "fy1": s.fy1}
                       | {f"a{p}{k}": getattr(s, f"a{p}{k}") for p, k in keys}
                       | {f"c{p}{k}": getattr(s, f"c{p}{k}") for p, k in keys})
    K = P.blend_frac
    fmts = {(p, k): P.blend_fmt(P.channels[k]) if K else None for p, k in keys}
    s = pipe.stage(g=cr["g"], odd=cr["odd"], fy0=cr["fy0"], fy1=cr["fy1"],
                   **{f"top{p}{k}": _blend_sum(cr[f"a{p}{k}"], pt[f"pt{p}{k}"], B, B - K, fmts[(p, k)])
                      for p, k in keys},
                   **{f"bot{p}{k}": _blend_sum(cr[f"c{p}{k}"], pt[f"pb{p}{k}"], B, B - K, fmts[(p, k)])
                      for p, k in keys})
    s = pipe.stage(g=s.g, odd=s.odd, fy0=s.fy0, fy1=s.fy1, **{f"top{p}{k}": getattr(s, f"top{p}{k}") for p, k in keys},
                   **{f"dtb{p}{k}": getattr(s, f"bot{p}{k}") - getattr(s, f"top{p}{k}") for p, k in keys})
    pv, cr = product_stage(pipe, {f"pv{p}{k}": (getattr(s, f"fy{p}"), getattr(s, f"dtb{p}{k}")) for p, k in keys},
                       {"g": s.g, "odd": s.odd} | {f"top{p}{k}": getattr(s, f"top{p}{k}") for p, k in keys})
    s = pipe.stage(g=cr["g"], odd=cr["odd"], **{f"v{p}{k}": _blend_sum(cr[f"top{p}{k}"], pv[f"pv{p}{k}"], B, B,
                                                                        fmts[(p, k)]) for p, k in keys})
    # level L's lookup is the memory of its parity: v0 from it, v1 from the other
    s = pipe.stage(g=s.g, **{f"v{k}": Mux(s.odd, getattr(s, f"v1{k}"), getattr(s, f"v0{k}")) for k in ch},
                   **{f"dl{k}": Mux(s.odd, getattr(s, f"v0{k}") - getattr(s, f"v1{k}"),
                                    getattr(s, f"v1{k}") - getattr(s, f"v0{k}")) for k in ch})
    pl, cr = product_stage(pipe, {f"pl{k}": (s.g, getattr(s, f"dl{k}")) for k in ch},
                       {f"v{k}": getattr(s, f"v{k}") for k in ch})
    s = pipe.stage(**{f"w{k}": (cr[f"v{k}"] << C) + pl[f"pl{k}"] for k in ch})
    outs = {}
    for k, (n, fmt) in enumerate(zip(P.out_names, P.channels)):
        outs[n], _ = narrow(getattr(s, f"w{k}"), P.level_frac + C + fmt.frac_bits, fmt, Rounding.HALF_UP,
                            Overflow.PROVEN)
    return outs


def _blend_sum(hi, lo, B: int, drop: int, fmt):
    """``(hi << B) + lo``: exact when ``fmt`` is ``None``, else rounded ``Rounding.HALF_UP`` by ``drop`` bits
    (``0 <= drop <= B``) into ``fmt`` with ``Overflow.PROVEN`` (the model's ``SamplerParams.blend_fmt`` narrowing,
    step 5: a convex combination stays within its texels' range). One carry chain: the rounding's half sits in
    ``hi << B``'s zero low bits, so it costs no second adder."""
    if fmt is None:
        return (hi << B) + lo
    if not drop:
        return saturate((hi << B) + lo, fmt, Overflow.PROVEN)[0]
    half = Cat(Const(1 << (drop - 1), B), hi)
    x = (half.as_signed() if hi.shape().signed else half) + lo
    return saturate(x >> drop, fmt, Overflow.PROVEN)[0]
