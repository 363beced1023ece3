"""RTL of the level-of-detail unit (MIP mapping, the next step the paper names in section 6), built from
``fxmodel.units.lod.LodParams``: the model's datapath stage for stage, bit for bit (``fxmodel/units/lod.py`` gives
the algorithm and its error bound). Fully pipelined, one result per clock.

Stages (``LodParams.latency``):

1. the leading-zero count of each operand group's top bits (``LodParams.GROUPS``: the magnitudes ``x ^ sign``
   OR-ed, the bits above the ``op_bits - 1`` lowest);
2. each group's shift ``max(0, L - (op_bits - 1))`` and the operands shifted (arithmetic: FLOOR) to ``op_bits``:
   left by the leading-zero count, then a constant slice (no subtraction in front of the shifter);
3. the eight products ``U_x W``, ``U W_x`` ... (one multiplier block each), the exponents summed;
4. each product shifted into place (``d_frac`` fraction bits), sliced to ``d_bits`` (proven: ``LodParams.d_bound``);
5. ``D = U_x W - U W_x`` (and for ``V`` and ``y``), exact;
6. the leading-zero count of the four ``D``'s top bits (magnitudes OR-ed), the flag ``Q = 0`` (every ``D`` zero);
7. the shared shift ``s_D`` and the four ``D`` shifted (FLOOR) to ``sq_bits``, as in stage 2;
8. the squares ``D^2`` (one block each);
9. ``Q_x = D_sx^2 w^2 + D_tx^2 h^2`` and ``Q_y`` (the map's size a constant: shifts, or shift-and-add);
10. ``Q_x > Q_y``, the flag ``W <= 0``;
11. ``Q = max(Q_x, Q_y)``, narrowed to ``q_bits`` (proven);
12. leading-zero counts of ``Q`` and ``W`` (balanced trees, ``rtl.recip.leading_zeros``);
13. normalizing shifts: the ``table_bits`` bits after each leading one index the table;
14. the ``log2`` table read for ``Q`` and ``W`` (one ROM, two synchronous read ports);
15. ``2 lambda = log2 Q + 2 s_D - 4 log2 W + const`` (``table_frac`` fraction bits);
16. round half-up to ``lod_frac`` fraction bits, add the bias, saturate, the flags (the output register).

Each stage holds one carry chain, one barrel shifter or one product (the ~120-bit comparison and choice of ``max``
in one stage ran an earlier, exact version of this unit at 69 MHz on ECP5, routing most of it).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Value
from amaranth.lib.memory import Memory

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.lod import FLAG_BAD_W, FLAG_SATURATED, FLAG_ZERO, LodParams

from .fixed import const_mul, saturate, shift_round
from .recip import leading_zeros
from .unit import Pipe, UnitComponent, named, register

__all__ = ["Lod", "log2_index", "magnitude", "group_shift", "top_part", "shift_into"]

#: ``(D name, numerator increment, numerator, W increment)`` of the four ``D`` terms.
_TERMS = (("sx", "Ux", "U", "Wx"), ("tx", "Vx", "V", "Wx"), ("sy", "Uy", "U", "Wy"), ("ty", "Vy", "V", "Wy"))


def magnitude(x: Value) -> Value:
    """``x ^ sign`` of the signed ``x`` (``~x`` for a negative one) as an unsigned value of ``len(x)`` bits: its bit
    length is the model's ``L`` (``fxmodel.units.lod._norm_shift``)."""
    x = Value.cast(x)
    return x.as_unsigned() ^ x[-1].replicate(len(x))


def group_shift(width: int, lz: Value, bits: int) -> Value:
    """``max(0, L - (bits - 1))`` with ``L`` the bit length of a ``width``-bit unsigned value whose top
    ``width - (bits - 1)`` bits (:func:`top_part`) have the leading-zero count ``lz``: ``top - lz`` (``lz <= top``)."""
    top = width - (bits - 1)
    if top <= 0:
        return Const(0, 1)
    return (Const(top, top.bit_length() + 1) - lz)[:top.bit_length()]


def top_part(mag: Value, bits: int) -> Value:
    """The bits of the unsigned ``mag`` above its ``bits - 1`` lowest: their bit length is the shift
    ``max(0, L - (bits - 1))`` that brings every value of magnitude up to ``mag`` into ``bits`` signed bits."""
    return Value.cast(mag)[bits - 1:]


def shift_into(x: Value, lz: Value, width: int, bits: int) -> Value:
    """``x >> group_shift(width, lz, bits)`` (arithmetic: FLOOR) in ``bits`` signed bits, as ``(x << lz) >> top``:
    a left shift by the leading-zero count and a constant slice, so no carry chain (``top - lz``) sits in front of
    the barrel shifter. Exact: the left shift loses no bit and ``top - lz`` is the shift."""
    top = width - (bits - 1)
    if top <= 0:
        return Value.cast(x)
    return (Value.cast(x).as_signed() << lz)[top:top + bits].as_signed()


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

    def _d_terms(self, pipe: Pipe):
        """Stages 1-5: the four ``D`` terms (registers ``sx, tx, sy, ty``) and ``W`` (``w``)."""
        P = self.params
        su, sw = P._scales()
        names = ("U", "V", "W", "Ux", "Uy", "Vx", "Vy", "Wx", "Wy")
        ins = {n: getattr(self, n) for n in names}

        # 1: each group's leading-zero count (a group already within op_bits needs none)
        lzs = {}
        for k, (group, fmt) in enumerate(zip(P.GROUPS, P.group_fmts())):
            if fmt.width > P.op_bits:
                mag = magnitude(ins[group[0]])
                for n in group[1:]:
                    mag = mag | magnitude(ins[n])
                lzs[f"lz{k}"] = leading_zeros(named(pipe.m, top_part(mag, P.op_bits), f"mag{k}"))
        s = pipe.stage(**ins, **lzs)

        # 2: the shifts and the shifted operands (arithmetic shift: FLOOR; they fit op_bits by the shift's choice)
        ops, sh = {}, {}
        for k, (group, fmt) in enumerate(zip(P.GROUPS, P.group_fmts())):
            if fmt.width > P.op_bits:
                lz = getattr(s, f"lz{k}")
                sh[f"e{k}"] = group_shift(fmt.width, lz, P.op_bits)
                for n in group:
                    ops[n] = shift_into(getattr(s, n), lz, fmt.width, P.op_bits)
            else:
                for n in group:
                    ops[n] = getattr(s, n)
        zero_e = Const(0, 1)
        s = pipe.stage(**ops, **sh, w=s.W)
        e = [getattr(s, f"e{k}", zero_e) for k in range(4)]          # exponents of (U, V), W, increments, W_x

        # 3: the eight products (one block each), the exponents of the two kinds summed
        prods = {}
        for d, inc, num, winc in _TERMS:
            prods[f"a{d}"] = getattr(s, inc) * s.W
            prods[f"b{d}"] = getattr(s, num) * getattr(s, winc)
        s = pipe.stage(**prods, ea=e[2] + e[1], eb=e[0] + e[3], w=s.w)

        # 4: each product at d_frac fraction bits, sliced to d_bits (proven: |value| <= d_bound)
        dfmt = Fmt(True, P.d_bits, 0)
        placed = {}
        for d, *_ in _TERMS:
            placed[f"a{d}"], _ = saturate((getattr(s, f"a{d}") << su) << s.ea, dfmt, Overflow.PROVEN)
            placed[f"b{d}"], _ = saturate((getattr(s, f"b{d}") << sw) << s.eb, dfmt, Overflow.PROVEN)
        s = pipe.stage(**placed, w=s.w)

        # 5: D, exact (|D| <= d_bound: proven)
        ds = {}
        for d, *_ in _TERMS:
            ds[d], _ = saturate(getattr(s, f"a{d}") - getattr(s, f"b{d}"), dfmt, Overflow.PROVEN)
        return pipe.stage(**ds, w=s.w)

    def elaborate(self, platform):
        P = self.params
        m = Module()
        pipe = Pipe(m, platform=platform)
        wn = P.w_fmt.width - 1                             # a positive W in its magnitude bits
        s = self._d_terms(pipe)

        # 6: the four D's leading-zero count; Q = 0 exactly when every D is 0 (Q_x = D_sx^2 w^2 + D_tx^2 h^2)
        mag = magnitude(s.sx) | magnitude(s.tx) | magnitude(s.sy) | magnitude(s.ty)
        lzd = leading_zeros(named(m, top_part(mag, P.sq_bits), "mag_d")) if P.d_bits > P.sq_bits else Const(0, 1)
        s = pipe.stage(**{d: getattr(s, d) for d, *_ in _TERMS}, lzd=lzd, w=s.w,
                       zero=Cat(*(getattr(s, d) == 0 for d, *_ in _TERMS)).all())

        # 7: the shared shift s_D and the four D at sq_bits (FLOOR)
        if P.d_bits > P.sq_bits:
            sd = group_shift(P.d_bits, s.lzd, P.sq_bits)
            short = {d: shift_into(getattr(s, d), s.lzd, P.d_bits, P.sq_bits) for d, *_ in _TERMS}
        else:
            sd, short = Const(0, 1), {d: getattr(s, d) for d, *_ in _TERMS}
        s = pipe.stage(**short, sd=sd, w=s.w, zero=s.zero)

        # 8: the squares (one block each)
        s = pipe.stage(**{d: getattr(s, d) * getattr(s, d) for d, *_ in _TERMS}, sd=s.sd, w=s.w, zero=s.zero)

        # 9: Q_x, Q_y (the map's size squared: a constant)
        w2, h2 = P.size[0] ** 2, P.size[1] ** 2
        s = pipe.stage(qx=const_mul(s.sx, w2) + const_mul(s.tx, h2), qy=const_mul(s.sy, w2) + const_mul(s.ty, h2),
                       sd=s.sd, w=s.w, zero=s.zero)

        # 10-11: Q = max(Q_x, Q_y) in q_bits (proven): the comparison, then the choice; the flag W <= 0
        s = pipe.stage(gt=s.qx > s.qy, qx=s.qx, qy=s.qy, sd=s.sd, zero=s.zero, bad=s.w <= 0, w=s.w[:wn])
        q, _ = saturate(Mux(s.gt, s.qx, s.qy), Fmt(False, P.q_bits, 0), Overflow.PROVEN)
        s = pipe.stage(q=q, w=s.w, sd=s.sd, zero=s.zero, bad=s.bad)

        # 12: leading-zero counts
        s = pipe.stage(q=s.q, w=s.w, lzq=leading_zeros(s.q), lzw=leading_zeros(s.w), sd=s.sd, zero=s.zero,
                       bad=s.bad)

        # 13: normalizing shifts -> table indices, and the leading ones' positions
        pq, iq = log2_index(s.q, s.lzq, P.table_bits)
        pw, iw = log2_index(s.w, s.lzw, P.table_bits)
        s = pipe.stage(pq=pq, pw=pw, iq=iq, iw=iw, sd=s.sd, zero=s.zero, bad=s.bad)

        # 14: the log2 table (synchronous read: its data register is this stage)
        m.submodules.table = table = Memory(shape=P.table_word_bits, depth=1 << P.table_bits,
                                            init=[int(v) for v in P.table()])
        rq, rw = table.read_port(domain="sync"), table.read_port(domain="sync")
        m.d.comb += [rq.addr.eq(s.iq), rw.addr.eq(s.iw)]
        s = pipe.stage(pq=s.pq, pw=s.pw, sd=s.sd, zero=s.zero, bad=s.bad)

        # 15: 2 lambda = log2 Q + 2 s_D - 4 log2 W + const, table_frac fraction bits
        g = P.table_frac
        log_q = (s.pq << g) + rq.data + (s.sd << (g + 1))
        log_w = (s.pw << g) + rw.data
        const = (4 * P.w_fmt.frac_bits - 2 * P.d_frac) << g
        s = pipe.stage(two=log_q - (log_w << 2) + const, zero=s.zero, bad=s.bad)

        # 16: round half-up to lod_frac bits, bias, saturate; zero -> the format's minimum, W <= 0 -> 0
        fmt = P.out_fmt
        lam, sat = saturate(shift_round(s.two, g + 1 - P.lod_frac, Rounding.HALF_UP) + P.bias, fmt,
                            Overflow.SATURATE)
        ok = ~s.zero & ~s.bad
        lod = Mux(s.bad, 0, Mux(s.zero, fmt.min_code, lam))
        flags = Mux(s.zero, FLAG_ZERO, 0) | Mux(s.bad, FLAG_BAD_W, 0) | Mux(sat & ok, FLAG_SATURATED, 0)
        self.finish(m, pipe, {"level": lod, "flags": flags})
        return m
