"""RTL of the reciprocal unit (paper section 4.1), built from ``fxmodel.units.recip``'s parameters; its helpers
(:func:`times_reciprocal`, :func:`scale_stages`) also serve the divider (``rtl/divide.py``) and the perspective
and cube units.

The datapath is the model's, stage for stage (see ``fxmodel/units/recip.py`` for the algorithm and error bound); the
table ROM contents come from ``RecipParams.rom``. Fully pipelined, one result per clock.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Value
from amaranth.lib.memory import Memory

from fxmodel.core import cost
from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.recip import RecipParams

from .fixed import narrow, saturate, shift_round
from .unit import Pipe, UnitComponent, register

__all__ = ["Recip", "scale", "scale_stages", "shift_amount", "times_reciprocal", "leading_zeros",
           "leading_zero_groups", "leading_zeros_of_groups", "pieces",
           "split_product", "split_products", "product_stage"]


def pieces(x, limit: int = RecipParams.DSP_BITS) -> list[tuple[Value, int]]:
    """``x`` as ``[(piece, shift)]`` with ``x = sum(piece << shift)``, cut where :func:`fxmodel.core.cost.pieces`
    says (the cost model counts the same pieces): unchanged if ``len(x) <= limit``, else ``limit - 1``-bit
    unsigned pieces from the bottom and a top piece of at most ``limit`` bits that keeps the sign. Every product
    of two pieces fits one ``limit x limit`` multiplier block."""
    x = Value.cast(x)
    cut = cost.pieces(len(x), x.shape().signed, limit)
    if len(cut) == 1:
        return [(x, 0)]
    return [(x[lo:lo + bits].as_signed() if signed else x[lo:lo + bits], lo) for lo, bits, signed in cut]


def split_products(pipe: Pipe, products: dict, carry: dict, name: str = "pp", settle: bool = False):
    """``({k: a * b}, carry)`` for ``products = {k: (a, b)}``. All within one multiplier block: the products,
    ``carry`` unchanged. Any wider (an operand above ``RecipParams.DSP_BITS`` bits): the partial products of
    :func:`pieces` of every product are registered together as one stage of their own (with the signals of
    ``carry``) and the expressions returned are their exact sums, for the next stage. With ``settle`` the
    partial products are registered once more before their sum (a second stage: on an ECP5 the first is the
    blocks' output registers, the second a fabric register the placer can put between a block and the sum's
    carry chain, which the route between them otherwise crosses in one clock)."""
    cut = {k: (pieces(a), pieces(b)) for k, (a, b) in products.items()}
    if all(len(pa) == 1 and len(pb) == 1 for pa, pb in cut.values()):
        return {k: a * b for k, (a, b) in products.items()}, carry
    parts, shifts = {}, {}
    for k, (pa, pb) in cut.items():
        for i, (xa, sa) in enumerate(pa):
            for j, (xb, sb) in enumerate(pb):
                parts[f"{name}{k}{i}_{j}"] = xa * xb
                shifts[f"{name}{k}{i}_{j}"] = (k, sa + sb)
    s = pipe.stage(**parts, **carry)
    if settle:
        s = pipe.stage(**{k: getattr(s, k) for k in (*parts, *carry)})
    totals = {k: sum(getattr(s, p) << sh for p, (kk, sh) in shifts.items() if kk == k) for k in products}
    return totals, {k: getattr(s, k) for k in carry}


def product_stage(pipe: Pipe, products: dict, carry: dict, name: str = "pp"):
    """One product stage: :func:`split_products`, and when every product fits one multiplier block (no partial-product
    stage was added) the products registered as a stage of their own with the signals of ``carry``. Returns the
    products' values for the next stage (exact: the partials' sum) and the carried registers."""
    before = pipe.depth
    values, regs = split_products(pipe, products, carry, name)
    if pipe.depth == before:
        r = pipe.stage(**values, **carry)
        values, regs = {k: getattr(r, k) for k in values}, {k: getattr(r, k) for k in carry}
    return values, regs


def split_product(pipe: Pipe, a, b, carry: dict, name: str = "pp", settle: bool = False):
    """``(a * b, carry)``: :func:`split_products` of one product."""
    totals, carry = split_products(pipe, {"": (a, b)}, carry, name, settle)
    return totals[""], carry


def leading_zeros(x) -> Value:
    """Leading-zero count of the unsigned ``x`` (``len(x)`` for ``x = 0``), as a balanced tree of
    ``ceil(log2(len(x)))`` levels of 2:1 multiplexers (a priority ``If`` chain would be ``len(x)`` levels deep).

    ``x`` is padded at the bottom with ones to a power-of-two width: the padded count equals the count of ``x``,
    zero included whenever there is padding (else the all-zero flag of the tree gives ``len(x)``).
    """
    x = Value.cast(x)
    return leading_zeros_of_groups(leading_zero_groups(x, _pow2(len(x))), len(x))


def _pow2(width: int) -> int:
    """The least power of two at least ``width`` (``width`` >= 1)."""
    return 1 << (width - 1).bit_length()


def leading_zero_groups(x, group: int) -> list:
    """The first levels of :func:`leading_zeros` of ``x``: ``x`` padded as there, cut into groups of ``group``
    bits (a power of two), lowest first, each as ``(all zero, count)`` (``count`` valid when not all zero;
    ``None`` for one-bit groups), for
    :func:`leading_zeros_of_groups` to finish, possibly a register stage later (the tree split between stages)."""
    if group < 1 or group & (group - 1):
        raise ValueError(f"leading_zero_groups: group {group} must be a power of two")
    x = Value.cast(x)
    width = len(x)
    size = _pow2(width)
    group = min(group, size)
    padded = Cat(Const((1 << (size - width)) - 1, size - width), x) if size > width else x

    def tree(v):
        """``(all zero, count)`` of ``v`` (power-of-two width); ``count`` is valid when not all zero (``None``,
        no bits, for one bit)."""
        if len(v) == 1:
            return ~v[0], None
        half = len(v) // 2
        return _merge(tree(v[:half]), tree(v[half:]))

    return [tree(padded[i:i + group]) for i in range(0, size, group)]


def _merge(low, high):
    """``(all zero, count)`` of two equal halves from theirs (``high`` the upper half; a count ``None`` has no
    bits: a half of one bit)."""
    (zl, cl), (zh, ch) = low, high
    return zh & zl, (zh if cl is None else Cat(Mux(zh, cl, ch), zh))


def leading_zeros_of_groups(groups: list, width: int) -> Value:
    """:func:`leading_zeros` of a ``width``-bit value from its :func:`leading_zero_groups` (lowest first; a
    power-of-two count of them)."""
    level = list(groups)
    while len(level) > 1:
        level = [_merge(level[i], level[i + 1]) for i in range(0, len(level), 2)]
    zero, count = level[0]
    return Mux(zero, width, 0 if count is None else count)


def times_reciprocal(m: Module, pipe: Pipe, recip: RecipParams, w, valid, numerators: dict, carry: dict | None = None,
                     shift: tuple[int, int] | None = None):
    """The front half every user of ``1/w`` shares (divider, perspective coordinates, cube address).

    A :class:`Recip` of ``w``; the ``numerators`` and ``carry`` signals delayed by its latency; then one register
    stage holding ``p_<name> = numerator * mant`` for each numerator, ``exp``, ``dbz``, and every delayed signal
    under its own name -- preceded by two stages of partial products when an operand is wider than one multiplier
    block (:meth:`RecipParams.times_split`, :func:`split_products` settled). Follow with :func:`scale` on each product
    (the model's :meth:`RecipParams.scale`), or with :func:`scale_stages` when ``shift`` gives the products' and
    the result's fraction bits: the stage then also holds the barrel shift's ``amount`` (:func:`shift_amount`,
    one small carry chain beside the products, kept out of the shift's stage).
    """
    m.submodules.recip = rcp = Recip(recip)
    m.d.comb += [rcp.w.eq(w), rcp.i_valid.eq(valid)]
    late = {k: pipe.delay(v, recip.latency, k) for k, v in {**numerators, **(carry or {})}.items()}
    pipe.depth += recip.latency
    before = pipe.depth
    prods, late = split_products(pipe, {k: (late[k], rcp.mant) for k in numerators},
                                 dict(late, exp=rcp.exp, dbz=rcp.dbz), "pm", settle=True)
    expected = max((recip.times_split(len(Value.cast(v))) for v in numerators.values()), default=0)
    if pipe.depth - before != expected:
        raise AssertionError(f"times_reciprocal: {pipe.depth - before} partial-product stages, "
                             f"RecipParams.times_split says {expected}")
    if shift is not None:
        late["amount"] = shift_amount(late["exp"], recip, *shift)
    return pipe.stage(**{f"p_{k}": v for k, v in prods.items()}, **late)


def shift_amount(exp, recip: RecipParams, prod_frac: int, out_frac: int) -> Value:
    """The right shift :func:`scale` applies to a product with ``prod_frac`` fraction bits for ``out_frac``
    (``exp`` the reciprocal's exponent; never negative: :meth:`RecipParams.shift_plan`)."""
    pre, shift_min = recip.shift_plan(prod_frac, out_frac)
    return (shift_min + pre + recip.exp_fmt.max_code - exp).as_unsigned()


#: Low bits of a barrel shift's amount that :func:`scale_stages` leaves to the rounding stage.
FINE_SHIFT_BITS = 1


def scale_stages(pipe: Pipe, prods: dict, amount, recip: RecipParams, shift: tuple[int, int], carry: dict):
    """:func:`scale` with half-up rounding over two register stages, for timing (the one-stage barrel shift,
    rounding and saturation ran the divider at 81 MHz on ECP5): the shift by the amount's upper bits, truncating
    with one extra fraction bit, is registered (with the ``carry`` signals and the amount's
    :data:`FINE_SHIFT_BITS` low bits); the shift by those low bits (one multiplexer level: the barrel shift's last
    level, taken out of a stage six LUTs deep on the board's perspective unit) and the rounding by the extra bit
    follow. Same bits as :meth:`RecipParams.scale` with ``Rounding.HALF_UP``: ``floor(floor(x / 2**c) / 2**f) =
    floor(x / 2**(c+f))``, and ``floor((floor(x / 2**(a-1)) + 1) / 2) = floor((x + 2**(a-1)) / 2**a)``; ``x`` is
    shifted left by one first, so ``a = 0`` is exact too.

    ``shift`` is ``(prod_frac, out_frac)``, the products' and the result's fraction bits, and ``amount`` the
    :func:`shift_amount` for them, registered with the products (``times_reciprocal(..., shift=shift)``).
    Returns ``(values, regs)``: the rounded value of each product by name, and the stage's registers.
    """
    pre, _ = recip.shift_plan(*shift)
    amount = Value.cast(amount)
    fine = min(FINE_SHIFT_BITS, len(amount))
    coarse = Cat(Const(0, fine), amount[fine:])
    regs = pipe.stage(**{f"h_{k}": shift_round(v << (pre + 1), coarse, Rounding.TRUNC) for k, v in prods.items()},
                      h_fine=amount[:fine], **carry)
    return {k: ((getattr(regs, f"h_{k}") >> regs.h_fine) + 1) >> 1 for k in prods}, regs


def scale(prod, prod_frac: int, exp, recip: RecipParams, out_frac: int, rounding: Rounding):
    """Twin of :meth:`fxmodel.units.recip.RecipParams.scale`: ``prod * 2**exp`` rounded to ``out_frac`` fraction bits
    (pre-shift left, then a data-dependent right shift with rounding: a barrel shifter)."""
    pre, _ = recip.shift_plan(prod_frac, out_frac)
    return shift_round(prod << pre, shift_amount(exp, recip, prod_frac, out_frac), rounding)


@register(RecipParams)
class Recip(UnitComponent):
    """Reciprocal ``1/w = mant * 2**exp``.

    Ports (formats from :class:`~fxmodel.units.recip.RecipParams`)
    -------------------------------------------------------
    i_valid : Signal(1), in
    w : Signal(signed(n)), in -- ``in_fmt``
    o_valid : Signal(1), out
    mant : Signal(signed(p + 1)), out -- ``s2.(p-1)``, magnitude in ``[1, 2)``
    exp : Signal(signed(E)), out -- integer in ``[F - n, F]``
    dbz : Signal(1), out -- ``w`` was zero (``mant``, ``exp`` then the largest magnitude)

    Latency: ``params.latency`` = 2 t + 4 cycles (t >= 2) plus one per product wider than one DSP block
    (``split_products``: its partial products get a stage of their own) and one more for a split ``B d``
    (``settled_products``: its partials registered twice, as its sum feeds the next product), 6 for t = 1.
    Stages: magnitude | leading-zero count | normalizing shift | table ROM read and ``d`` | ``q = B d`` | t - 2
    Horner steps, each a product stage then an add stage | ``B g`` | add and round | renormalize and sign. Each
    stage holds at most one carry chain or one product (ECP5 speed grade 8: about 150 MHz for ``default``, see
    ``bumpmap fpga``).
    """

    def elaborate(self, platform):
        P = self.params
        n, F, low = P.n, P.in_fmt.frac_bits, P.n - P.m
        m = Module()
        pipe = Pipe(m, platform=platform)

        # 1: sign and magnitude (-(most negative) = 2**(n-1) fits the n-bit unsigned word)
        w = self.w
        s1 = pipe.stage(neg=w < 0, X=Mux(w < 0, -w, w)[:n])

        # 2: leading-zero count (a balanced tree, log2(n) levels)
        s2 = pipe.stage(neg=s1.neg, X=s1.X, lz=leading_zeros(s1.X))

        # 3: normalizing shift (a barrel shifter)
        s3 = pipe.stage(neg=s2.neg, xn=(s2.X << s2.lz)[:n], lz=s2.lz)

        # 4: table read (synchronous ROM: its data register is this stage) and d = ~low bits, truncated to fd
        m.submodules.rom = rom = Memory(shape=P.rom_bits, depth=P.entries, init=P.rom)
        rd = rom.read_port(domain="sync")
        m.d.comb += rd.addr.eq(s3.xn[low:n - 1])
        stage4 = dict(neg=s3.neg, lz=s3.lz, zero=s3.lz == n, half=s3.xn == (1 << (n - 1)))
        if P.t >= 2:
            d = (~s3.xn[:low])[n - P.fd:]
            # midpoint modes: d - 2**-(m+1), exact: the top bit inverted, read as two's complement
            stage4["d"] = Cat(d[:-1], ~d[-1]).as_signed() if P.signed_d else d
        s4 = pipe.stage(**stage4)
        B = Cat(rd.data, Const(1, 1))                                   # hidden leading 1: u1.(b-1)
        flags = dict(neg=s4.neg, lz=s4.lz, zero=s4.zero, half=s4.half)

        Bb = (B << (P.fr - (P.b - 1))) + P.bias_code                    # B (+ the centring bias) at fr bits
        if P.t >= 2:
            # Each product below gets one more stage when split_product cuts it into partial products
            # (an operand wider than one DSP block; RecipParams.split_products counts them).
            # q = B d (B truncated to bq bits)
            prod, c = split_product(pipe, B[P.b - P.bq:], s4.d, dict(B=B, **flags), "pd",
                                    settle=bool(P.settled_products))
            q, _ = narrow(prod, P.bq - 1 + P.fd, P.q_fmt, Rounding.TRUNC, Overflow.PROVEN)
            s = pipe.stage(q=q, **c)
            g = s.q
            # t - 2 Horner steps g = q + trunc(q g), two stages each: the product (DSP), then the adder
            for _ in range(P.t - 2):
                prod, c = split_product(pipe, s.q, g, dict(q=s.q, B=s.B, **{k: getattr(s, k) for k in flags}),
                                        "pg")
                qg, _ = narrow(prod, 2 * P.fq, P.g_fmt, Rounding.TRUNC, Overflow.PROVEN)
                s = pipe.stage(qg=qg, **c)
                g_next, _ = saturate(s.q + s.qg, P.g_fmt, Overflow.PROVEN)
                s = pipe.stage(q=s.q, g=g_next, B=s.B, **{k: getattr(s, k) for k in flags})
                g = s.g
            # B g, and B plus the bias beside it (a constant adder in parallel with the product)
            prod, c = split_product(pipe, s.B[P.b - P.bq:], g, dict(B=s.B, **{k: getattr(s, k) for k in flags}),
                                    "pb")
            bg, _ = narrow(prod, P.bq - 1 + P.fq, P.bg_fmt, Rounding.TRUNC, Overflow.PROVEN)
            Bb = (c["B"] << (P.fr - (P.b - 1))) + P.bias_code
            s = pipe.stage(bg=bg, Bb=Bb, **{k: c[k] for k in flags})
            acc = s.Bb + (s.bg << (P.fr - P.fq))
            flags = {k: getattr(s, k) for k in flags}
        else:
            acc = Bb

        # next to last: sum, round half-up; the carry out of [1, 2) (or x = 0.5 exactly) is one bit of r
        r = shift_round(acc, P.fr - P.fo, Rounding.HALF_UP)
        one = 1 << P.fo
        carry = r[P.fo + 1:].any() | flags["half"]                         # r >= 2 * one (r >= 0)
        s = pipe.stage(r=r, carry=carry, **flags)

        # last: renormalize, restore the sign, flag zero
        mag = Mux(s.carry, one, s.r)
        mant = Mux(s.neg, -mag, mag)
        exp = (F - n) + s.lz + s.carry
        flags = {k: getattr(s, k) for k in flags}
        self.finish(m, pipe, {
            "mant": Mux(flags["zero"], P.mant_fmt.max_code, mant),
            "exp": Mux(flags["zero"], F, exp),
            "dbz": flags["zero"],
        })
        return m
