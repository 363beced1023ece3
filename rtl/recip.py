"""RTL of the reciprocal unit and the divider (paper section 4.1), built from ``fxmodel.recip``'s parameters.

The datapath is the model's, stage for stage (see ``fxmodel/recip.py`` for the algorithm and error bound); the
table ROM contents come from ``RecipParams.rom``. Fully pipelined, one result per clock.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib.memory import Memory

from fxmodel.recip import DivideParams, RecipParams
from fxmodel.rounding import Overflow, Rounding

from .fixed import narrow, saturate, shift_round
from .unit import Pipe, UnitComponent, register

__all__ = ["Recip", "Divide", "scale"]


def scale(prod, prod_frac: int, exp, recip: RecipParams, out_frac: int, rounding: Rounding):
    """Twin of :meth:`fxmodel.recip.RecipParams.scale`: ``prod * 2**exp`` rounded to ``out_frac`` fraction bits
    (pre-shift left, then a data-dependent right shift with rounding: a barrel shifter)."""
    pre, shift_min = recip.shift_plan(prod_frac, out_frac)
    amount = (shift_min + pre + recip.exp_fmt.max_code - exp).as_unsigned()
    return shift_round(prod << pre, amount, rounding)


@register(RecipParams)
class Recip(UnitComponent):
    """Reciprocal ``1/w = mant * 2**exp``.

    Ports (formats from :class:`~fxmodel.recip.RecipParams`)
    -------------------------------------------------------
    i_valid : Signal(1), in
    w : Signal(signed(n)), in -- ``in_fmt``, e.g. ``s8.16`` for ``default``
    o_valid : Signal(1), out
    mant : Signal(signed(p + 1)), out -- ``s2.(p-1)``, magnitude in ``[1, 2)``
    exp : Signal(signed(E)), out -- integer in ``[F - n, F]``
    dbz : Signal(1), out -- ``w`` was zero (``mant``, ``exp`` then the largest magnitude)

    Latency: ``params.latency`` = 4 + t cycles (t >= 2), 4 for t = 1. Stages: magnitude | leading-zero count and
    normalizing shift | table ROM read (BRAM) and ``d`` | ``q = B d`` | t - 2 Horner steps | ``B g`` |
    add, round, renormalize, sign.
    """

    def elaborate(self, platform):
        P = self.params
        n, F, low = P.n, P.in_fmt.frac_bits, P.n - P.m
        m = Module()
        pipe = Pipe(m)

        # 1: sign and magnitude (-(most negative) = 2**(n-1) fits the n-bit unsigned word)
        w = self.w
        s1 = pipe.stage(neg=w < 0, X=Mux(w < 0, -w, w)[:n])

        # 2: leading-zero count (priority encoder; the last true If wins) and normalizing shift
        lz = Signal(range(n + 1))
        m.d.comb += lz.eq(n)
        for i in range(n):
            with m.If(s1.X[i]):
                m.d.comb += lz.eq(n - 1 - i)
        s2 = pipe.stage(neg=s1.neg, xn=(s1.X << lz)[:n], lz=lz)

        # 3: table read (synchronous ROM: its data register is this stage) and d = ~low bits, truncated to fd
        m.submodules.rom = rom = Memory(shape=P.rom_bits, depth=P.entries, init=P.rom)
        rd = rom.read_port(domain="sync")
        m.d.comb += rd.addr.eq(s2.xn[low:n - 1])
        stage3 = dict(neg=s2.neg, lz=s2.lz, zero=s2.lz == n, half=s2.xn == (1 << (n - 1)))
        if P.t >= 2:
            stage3["d"] = (~s2.xn[:low])[n - P.fd:]
        s3 = pipe.stage(**stage3)
        B = Cat(rd.data, Const(1, 1))                                   # hidden leading 1: u1.(b-1)
        flags = dict(neg=s3.neg, lz=s3.lz, zero=s3.zero, half=s3.half)

        acc = B << (P.fr - (P.b - 1))
        if P.t >= 2:
            # 4: q = B d (B truncated to bq bits)
            Bh = B[P.b - P.bq:]
            q, _ = narrow(Bh * s3.d, P.bq - 1 + P.fd, P.q_fmt, Rounding.TRUNC, Overflow.PROVEN)
            s = pipe.stage(q=q, B=B, **flags)
            g = s.q
            # t - 2 Horner steps: g = q + trunc(q g)
            for _ in range(P.t - 2):
                qg, _ = narrow(s.q * g, 2 * P.fq, P.g_fmt, Rounding.TRUNC, Overflow.PROVEN)
                g_next, _ = saturate(s.q + qg, P.g_fmt, Overflow.PROVEN)
                s = pipe.stage(q=s.q, g=g_next, B=s.B, **{k: getattr(s, k) for k in flags})
                g = s.g
            # B g
            bg, _ = narrow(s.B[P.b - P.bq:] * g, P.bq - 1 + P.fq, P.bg_fmt, Rounding.TRUNC, Overflow.PROVEN)
            s = pipe.stage(bg=bg, B=s.B, **{k: getattr(s, k) for k in flags})
            acc = (s.B << (P.fr - (P.b - 1))) + (s.bg << (P.fr - P.fq))
            flags = {k: getattr(s, k) for k in flags}

        # last: add the centring bias, round half-up, renormalize, restore the sign
        r = shift_round(acc + P.bias_code, P.fr - P.fo, Rounding.HALF_UP)
        one = 1 << P.fo
        carry = (r >= 2 * one) | flags["half"]
        mag = Mux(carry, one, r)
        mant = Mux(flags["neg"], -mag, mag)
        exp = (F - n) + flags["lz"] + carry
        self.finish(m, pipe, {
            "mant": Mux(flags["zero"], P.mant_fmt.max_code, mant),
            "exp": Mux(flags["zero"], F, exp),
            "dbz": flags["zero"],
        })
        return m


@register(DivideParams)
class Divide(UnitComponent):
    """Divider ``q = n / d`` on the reciprocal unit.

    Ports (formats from :class:`~fxmodel.recip.DivideParams`)
    --------------------------------------------------------
    i_valid : Signal(1), in
    n : Signal(signed), in -- ``num_fmt``
    d : Signal(signed), in -- ``recip.in_fmt``
    o_valid : Signal(1), out
    q : Signal(signed), out -- ``out_fmt``, rounded half-up, saturated
    dbz : Signal(1), out -- ``d`` was zero
    ovf : Signal(1), out -- ``q`` saturated

    Latency: ``recip.latency + 2``: the reciprocal, ``n * mant``, then shift, round and saturate.
    """

    def elaborate(self, platform):
        P = self.params
        R = P.recip
        m = Module()
        m.submodules.recip = rcp = Recip(R)
        m.d.comb += [rcp.w.eq(self.d), rcp.i_valid.eq(self.i_valid)]
        pipe = Pipe(m)
        n_late = pipe.delay(self.n, R.latency, "num")
        pipe.depth = R.latency
        s = pipe.stage(prod=n_late * rcp.mant, exp=rcp.exp, dbz=rcp.dbz, n=n_late)
        y = scale(s.prod, P.prod_fmt.frac_bits, s.exp, R, P.out_fmt.frac_bits, Rounding.HALF_UP)
        q, ovf = saturate(y, P.out_fmt, Overflow.SATURATE)
        fmt = P.out_fmt
        q_dbz = Mux(s.n > 0, fmt.max_code, Mux(s.n < 0, fmt.min_code, 0))
        self.finish(m, pipe, {
            "q": Mux(s.dbz, q_dbz, q),
            "dbz": s.dbz,
            "ovf": Mux(s.dbz, s.n != 0, ovf),
        })
        return m
