"""RTL of the level-of-detail unit (MIP mapping, the next step the paper names in section 6), built from
``fxmodel.units.lod.LodParams``: the model's datapath stage for stage, bit for bit (``fxmodel/units/lod.py`` gives
the algorithm and its error bound). Fully pipelined, one result per clock.

Stages (``LodParams.latency``):

1. the eight ``D`` products' partial products, registered (only when an operand is wider than one multiplier block:
   ``rtl.recip.split_products``);
2. the products ``U_x W`` and ``U W_x`` (and for ``V`` and ``y``), exact;
3. ``D = (U_x W << su) - (U W_x << sw)``, narrowed to ``d_bits`` (proven: ``|D| <= LodParams.d_bound``);
4. the piece products of each square ``D^2`` (:meth:`LodParams.square_pieces`: ``D`` cut into 17-bit pieces, a
   cross product once and doubled by a shift; one multiplier block each), the flag ``Q = 0`` (every ``D`` zero);
5. 6. ``D^2``: the pieces' adder tree, half its levels a stage;
7. ``Q_x = D_sx^2 w^2 + D_tx^2 h^2`` and ``Q_y`` (the map's size a constant: shifts, or shift-and-add);
8. ``Q_x > Q_y``, the flag ``W <= 0``;
9. ``Q = max(Q_x, Q_y)``, narrowed to ``q_bits`` (proven);
10. leading-zero counts of ``Q`` and ``W`` (balanced trees, ``rtl.recip.leading_zeros``);
11. normalizing shifts: the ``table_bits`` bits after each leading one index the table;
12. the ``log2`` table read for ``Q`` and ``W`` (one ROM, two synchronous read ports);
13. ``2 lambda = log2 Q - 4 log2 W + const`` (``table_frac`` fraction bits);
14. round half-up to ``lod_frac`` fraction bits, add the bias, saturate, the flags (the output register).

Each stage holds one carry chain or one product (the ~120-bit comparison and choice of ``max`` in one stage ran the
unit at 69 MHz on ECP5, routing most of it).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Value
from amaranth.lib.memory import Memory

from fxmodel.core.cost import pieces as cut_pieces
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.lod import FLAG_BAD_W, FLAG_SATURATED, FLAG_ZERO, LodParams

from .fixed import const_mul, saturate, shift_round
from .recip import leading_zeros, split_products
from .unit import Pipe, UnitComponent, register

__all__ = ["Lod", "square_parts", "log2_index"]

#: ``(D name, numerator increment, numerator, W increment)`` of the four ``D`` terms.
_TERMS = (("sx", "Ux", "U", "Wx"), ("tx", "Vx", "V", "Wx"), ("sy", "Uy", "U", "Wy"), ("ty", "Vy", "V", "Wy"))


def square_parts(P: LodParams, d) -> dict:
    """The piece products of ``d * d`` (``d`` a ``P.d_bits``-bit signed value) by name, and their shifts:
    ``{name: (product, shift)}`` with ``d^2 = sum(product << shift)`` (:meth:`LodParams.square_pieces`)."""
    cut = cut_pieces(P.d_bits, True)
    sl = [d[lo:lo + bits].as_signed() if signed else d[lo:lo + bits] for lo, bits, signed in cut]
    return {f"{i}{j}": (sl[i] * sl[j], cut[i][0] + cut[j][0] + (i != j))
            for i, j, *_ in P.square_pieces()}


def square_terms(P: LodParams, regs, name: str) -> list:
    """The shifted piece products of ``D^2`` (registered as ``regs.<name>_<ij>`` by :func:`square_parts`)."""
    cut = cut_pieces(P.d_bits, True)
    return [getattr(regs, f"{name}_{i}{j}") << (cut[i][0] + cut[j][0] + (i != j)) for i, j, *_ in P.square_pieces()]


def add_levels(terms: list, levels: int) -> list:
    """``levels`` levels of a balanced adder tree over ``terms`` (pairs summed, an odd one passed on)."""
    for _ in range(levels):
        terms = [terms[k] + terms[k + 1] if k + 1 < len(terms) else terms[k] for k in range(0, len(terms), 2)]
    return terms


def tree_levels(n: int) -> int:
    """Levels of a balanced adder tree over ``n`` terms."""
    return max(0, (n - 1).bit_length())


def log2_index(x: Value, lz: Value, table_bits: int) -> tuple[Value, Value]:
    """``(p, index)`` of the unsigned ``x`` with leading-zero count ``lz``: ``p = len(x) - 1 - lz`` (the leading
    one's position, :meth:`LodParams._log2`'s integer part) and the ``table_bits`` bits after the leading one
    (truncated; zeros below a short ``x``)."""
    n = len(x)
    xn = (x << lz)[:n]                                     # the leading one at bit n - 1
    below = xn[:n - 1]
    if n - 1 >= table_bits:
        index = below[n - 1 - table_bits:]
    else:
        index = Cat(Const(0, table_bits - (n - 1)), below)
    return (n - 1) - lz, index


@register(LodParams)
class Lod(UnitComponent):
    """Level of detail per pixel.

    Ports (formats from :class:`~fxmodel.units.lod.LodParams`)
    ---------------------------------------------------------
    i_valid : Signal(1), in
    U, V : Signal(signed), in -- ``uv_fmt``
    W : Signal(signed), in -- ``w_fmt``
    Ux, Uy, Vx, Vy : Signal(signed), in -- ``duv_fmt``, the triangle's increments
    Wx, Wy : Signal(signed), in -- ``dw_fmt``
    o_valid : Signal(1), out
    level : Signal(signed), out -- ``out_fmt``: the level plus the bias, rounded half-up, saturated
    flags : Signal(3), out -- bit 0 ``Q = 0``, bit 1 ``W <= 0``, bit 2 saturated

    Latency: ``params.latency`` (module docstring).
    """

    def elaborate(self, platform):
        P = self.params
        m = Module()
        pipe = Pipe(m)
        F = P.d_frac
        su = F - P.duv_fmt.frac_bits - P.w_fmt.frac_bits
        sw = F - P.uv_fmt.frac_bits - P.dw_fmt.frac_bits
        wn = P.w_fmt.width - 1                             # a positive W in its magnitude bits

        # 1-2: the eight products, exact (partial products registered first when wider than a block)
        prods = {}
        for d, inc, num, winc in _TERMS:
            prods[f"a{d}"] = (getattr(self, inc), self.W)
            prods[f"b{d}"] = (getattr(self, num), getattr(self, winc))
        totals, c = split_products(pipe, prods, {"W": self.W}, "pd")
        s = pipe.stage(**totals, **c)

        # 3: D at d_frac fraction bits, narrowed to d_bits (proven by the formats' bounds)
        dfmt = Fmt(True, P.d_bits, 0)
        ds = {}
        for d, *_ in _TERMS:
            ds[d], _ = saturate((getattr(s, f"a{d}") << su) - (getattr(s, f"b{d}") << sw), dfmt, Overflow.PROVEN)
        s = pipe.stage(**ds, W=s.W)

        # 4-6: the squares' piece products, then D^2 over two stages (half the adder tree's levels each: the
        # whole tree of ~120-bit carry chains in one stage ran at 69 MHz on ECP5)
        parts = {}
        for d, *_ in _TERMS:
            for k, (prod, _) in square_parts(P, getattr(s, d)).items():
                parts[f"{d}_{k}"] = prod
        # Q = 0 exactly when every D is 0 (Q_x = D_sx^2 w^2 + D_tx^2 h^2 with w, h >= 1)
        s = pipe.stage(**parts, W=s.W, zero=Cat(*(getattr(s, d) == 0 for d, *_ in _TERMS)).all())
        first = (tree_levels(len(P.square_pieces())) + 1) // 2
        halves = {d: add_levels(square_terms(P, s, d), first) for d, *_ in _TERMS}
        s = pipe.stage(**{f"{d}_{k}": t for d, ts in halves.items() for k, t in enumerate(ts)}, W=s.W, zero=s.zero)
        s = pipe.stage(**{d: add_levels([getattr(s, f"{d}_{k}") for k in range(len(ts))], tree_levels(len(ts)))[0]
                          for d, ts in halves.items()}, W=s.W, zero=s.zero)

        # 7: Q_x, Q_y (the map's size squared: a constant)
        w2, h2 = P.size[0] ** 2, P.size[1] ** 2
        s = pipe.stage(qx=const_mul(s.sx, w2) + const_mul(s.tx, h2), qy=const_mul(s.sy, w2) + const_mul(s.ty, h2),
                       W=s.W, zero=s.zero)

        # 8-9: Q = max(Q_x, Q_y) in q_bits (proven): the comparison, then the choice; the flag W <= 0
        s = pipe.stage(gt=s.qx > s.qy, qx=s.qx, qy=s.qy, zero=s.zero, bad=s.W <= 0, w=s.W[:wn])
        q, _ = saturate(Mux(s.gt, s.qx, s.qy), Fmt(False, P.q_bits, 0), Overflow.PROVEN)
        s = pipe.stage(q=q, w=s.w, zero=s.zero, bad=s.bad)

        # 10: leading-zero counts
        s = pipe.stage(q=s.q, w=s.w, lzq=leading_zeros(s.q), lzw=leading_zeros(s.w), zero=s.zero, bad=s.bad)

        # 11: normalizing shifts -> table indices, and the leading ones' positions
        pq, iq = log2_index(s.q, s.lzq, P.table_bits)
        pw, iw = log2_index(s.w, s.lzw, P.table_bits)
        s = pipe.stage(pq=pq, pw=pw, iq=iq, iw=iw, zero=s.zero, bad=s.bad)

        # 12: the log2 table (synchronous read: its data register is this stage)
        m.submodules.table = table = Memory(shape=P.table_word_bits, depth=1 << P.table_bits,
                                            init=[int(v) for v in P.table()])
        rq, rw = table.read_port(domain="sync"), table.read_port(domain="sync")
        m.d.comb += [rq.addr.eq(s.iq), rw.addr.eq(s.iw)]
        s = pipe.stage(pq=s.pq, pw=s.pw, zero=s.zero, bad=s.bad)

        # 13: 2 lambda = log2 Q - 4 log2 W + const, table_frac fraction bits
        g = P.table_frac
        log_q = (s.pq << g) + rq.data
        log_w = (s.pw << g) + rw.data
        const = (4 * P.w_fmt.frac_bits - 2 * F) << g
        s = pipe.stage(two=log_q - (log_w << 2) + const, zero=s.zero, bad=s.bad)

        # 14: round half-up to lod_frac bits, bias, saturate; zero -> the format's minimum, W <= 0 -> 0
        fmt = P.out_fmt
        lam, sat = saturate(shift_round(s.two, g + 1 - P.lod_frac, Rounding.HALF_UP) + P.bias, fmt,
                            Overflow.SATURATE)
        ok = ~s.zero & ~s.bad
        lod = Mux(s.bad, 0, Mux(s.zero, fmt.min_code, lam))
        flags = Mux(s.zero, FLAG_ZERO, 0) | Mux(s.bad, FLAG_BAD_W, 0) | Mux(sat & ok, FLAG_SATURATED, 0)
        self.finish(m, pipe, {"level": lod, "flags": flags})
        return m
