"""RTL of the scan converter and attribute interpolators (paper, section 4 and Fig. 5), from
:class:`fxmodel.raster.RasterParams`: triangle records in, one fragment per clock out, bit-exact with
:func:`fxmodel.raster.scan`, clock count included.

Structure (see the model's docstring for the arithmetic and its proof):

- **Row function** (the Scan Line Initializer): from the edge state of a row (``p_e``, ``r_e``) and each
  attribute's value at ``(x0, y)``: the span ``L = max(x0, -p_left)``, ``R = min(x1, p_right)``, whether it is
  empty, and each attribute at ``(L, y)``: ``a(x0, y) + (L - x0) a_x`` (one small multiplier per attribute,
  modulo ``2**N``). Beside it the **row step** to ``y + 1``: ``r += m; p += q`` and the Bresenham carry
  (``r >= |a|``: ``r -= |a|; p += 1``), ``a(x0, y + 1) = a(x0, y) + a_y``. Its input is either the record being
  accepted or the registered state of the current triangle.
- **Pixel Calculator**: ``x += 1``, ``a += a_x`` per pixel of the current span.
- **Per-triangle constants** (``params.consts``, the bump engine's block exponent ``Ae``): a register loaded with
  the record, copied into every fragment of the triangle.
- **Output**: one registered fragment (``x``, ``y``, each attribute rounded half-up and saturated to its output
  format, ``flags``) under ``advance = ~o.valid | o.ready``: every register holds while the consumer does not
  take the fragment, so nothing is lost or repeated.

A row costs ``max(1, span)`` clocks; the next record is accepted in the last clock of the previous triangle, so
``busy`` is high for exactly the model's ``clocks`` when the source never waits and the sink is always ready.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.raster import EDGE_LEFT, EDGE_RIGHT, RasterParams
from fxmodel.rounding import Overflow, Rounding

from .fixed import narrow, shape
from .streams import payload_layout
from .unit import register

__all__ = ["Raster", "record_layout", "fragment_layout"]


def record_layout(params: RasterParams) -> data.StructLayout:
    """The input payload: one field per :attr:`RasterParams.record` entry (first field in the low bits)."""
    return payload_layout(params.record)


def fragment_layout(params: RasterParams) -> data.StructLayout:
    """The output payload: one field per :attr:`RasterParams.fragment` entry."""
    return payload_layout(params.fragment)


@register(RasterParams)
class Raster(wiring.Component):
    """Scan converter and interpolators.

    Ports
    -----
    i : In(stream.Signature(record_layout(params))) -- triangle records (:attr:`RasterParams.record`)
    o : Out(stream.Signature(fragment_layout(params))) -- fragments (:attr:`RasterParams.fragment`): ``x``, ``y``
        (``pixel_fmt``), every attribute in its output format, the triangle's constants (``consts``, e.g. ``Ae``
        in ``bump.e_fmt``), ``flags`` (bit 0: an attribute saturated)
    busy : Out(1) -- a row of a triangle is being traversed (count it for the clock figure)
    """

    def __init__(self, params: RasterParams):
        self.params = params
        super().__init__({"i": In(stream.Signature(record_layout(params))),
                          "o": Out(stream.Signature(fragment_layout(params))),
                          "busy": Out(1)})

    def elaborate(self, platform):
        P = self.params
        m = Module()
        rec = self.i.payload
        ef = P.edge_fmts
        pf = P.pixel_fmt

        def sig(fmt, name):
            return Signal(shape(fmt), name=name)

        # -- per-triangle constants ------------------------------------------------------------------------
        k_x0, k_x1 = sig(pf, "k_x0"), sig(pf, "k_x1")
        k_edge = [{k: sig(ef[k], f"k_e{e}_{k}") for k in ("kind", "q", "m", "d")} for e in range(3)]
        k_dx = {n: sig(P.acc_fmt(n), f"k_{n}_dx") for n in P.names}
        k_dy = {n: sig(P.acc_fmt(n), f"k_{n}_dy") for n in P.names}
        k_c = {n: sig(f, f"k_{n}") for n, f in P.consts}
        # -- the next row's state ----------------------------------------------------------------------------
        s_p = [sig(ef["p"], f"s_e{e}_p") for e in range(3)]
        s_r = [sig(ef["r"], f"s_e{e}_r") for e in range(3)]
        s_a = {n: sig(P.acc_fmt(n), f"s_{n}_row") for n in P.names}
        s_y = sig(pf, "s_y")
        s_rem = sig(pf, "s_rem")
        # -- the current row ---------------------------------------------------------------------------------
        busy = Signal(name="busy_r")
        nonempty = Signal(name="nonempty")
        more = Signal(name="more")
        cx, cr, cy = sig(pf, "cx"), sig(pf, "cr"), sig(pf, "cy")
        acc = {n: sig(P.acc_fmt(n), f"acc_{n}") for n in P.names}

        # -- the source of the row function: the record being accepted, or the current triangle's state ---
        accept = Signal()
        src = {
            "x0": Mux(accept, rec.x0, k_x0), "x1": Mux(accept, rec.x1, k_x1),
            "y": Mux(accept, rec.y0, s_y), "rem": Mux(accept, rec.rows, s_rem),
        }
        edges = []
        for e in range(3):
            edges.append({k: Mux(accept, rec[f"e{e}_{k}"], k_edge[e][k]) for k in ("kind", "q", "m", "d")}
                         | {"p": Mux(accept, rec[f"e{e}_p"], s_p[e]), "r": Mux(accept, rec[f"e{e}_r"], s_r[e])})
        arow = {n: Mux(accept, rec[f"{n}_0"], s_a[n]) for n in P.names}
        dx = {n: Mux(accept, rec[f"{n}_dx"], k_dx[n]) for n in P.names}
        dy = {n: Mux(accept, rec[f"{n}_dy"], k_dy[n]) for n in P.names}

        # row function: the span
        wide = ef["p"].width + 1
        L = Signal(range(-(1 << (wide - 1)), 1 << (wide - 1)), name="L")
        R = Signal(range(-(1 << (wide - 1)), 1 << (wide - 1)), name="R")
        lv, rv = src["x0"], src["x1"]
        for e, ed in enumerate(edges):
            neg = Signal.like(L, name=f"neg_p{e}")
            m.d.comb += neg.eq(-ed["p"])
            lv_n = Signal.like(L, name=f"lmax{e}")
            rv_n = Signal.like(R, name=f"rmin{e}")
            m.d.comb += [lv_n.eq(Mux((ed["kind"] == EDGE_LEFT) & (neg > lv), neg, lv)),
                         rv_n.eq(Mux((ed["kind"] == EDGE_RIGHT) & (ed["p"] < rv), ed["p"], rv))]
            lv, rv = lv_n, rv_n
        m.d.comb += [L.eq(lv), R.eq(rv)]
        row_nonempty = L <= R
        offset = Signal(unsigned(pf.width), name="offset")
        m.d.comb += offset.eq((L - src["x0"])[:pf.width])
        start = {}
        for n in P.names:
            w = P.acc_fmt(n).width
            start[n] = Signal(shape(P.acc_fmt(n)), name=f"start_{n}")
            m.d.comb += start[n].eq((arow[n] + dx[n] * offset)[:w])
        # row step
        step_p, step_r = [], []
        for e, ed in enumerate(edges):
            t = Signal(ef["r"].width + 1, name=f"rm{e}")
            m.d.comb += t.eq(ed["r"] + ed["m"])
            carry = t >= ed["d"]
            step_r.append(Mux(carry, t - ed["d"], t))
            step_p.append(ed["p"] + ed["q"] + carry)

        # -- control ---------------------------------------------------------------------------------------
        advance = ~self.o.valid | self.o.ready
        last_px = ~nonempty | (cx == cr)
        done_row = ~busy | last_px
        next_row = advance & done_row & busy & more
        can_accept = advance & done_row & ~(busy & more)
        m.d.comb += [self.i.ready.eq(can_accept), accept.eq(can_accept & self.i.valid), self.busy.eq(busy)]

        with m.If(advance):
            m.d.sync += self.o.valid.eq(busy & nonempty)
            m.d.sync += [self.o.payload.x.eq(cx), self.o.payload.y.eq(cy)]
            flags = []
            for n in P.names:
                fa, fo = P.acc_fmt(n), P.out_fmt(n)
                code, sat = narrow(acc[n], fa.frac_bits, fo, Rounding.HALF_UP, Overflow.SATURATE)
                m.d.sync += self.o.payload[n].eq(code)
                flags.append(sat)
            m.d.sync += self.o.payload.flags.eq(Cat(*flags).any())
            m.d.sync += [self.o.payload[n].eq(k_c[n]) for n in k_c]
            with m.If(~done_row):
                m.d.sync += cx.eq(cx + 1)
                m.d.sync += [acc[n].eq((acc[n] + k_dx[n])[:P.acc_fmt(n).width]) for n in P.names]
            with m.Elif(next_row | accept):
                m.d.sync += [busy.eq(1), nonempty.eq(row_nonempty), more.eq(src["rem"] != 0),
                             cx.eq(L[:pf.width]), cr.eq(R[:pf.width]), cy.eq(src["y"]),
                             s_y.eq(src["y"] + 1), s_rem.eq(src["rem"] - 1)]
                m.d.sync += [acc[n].eq(start[n]) for n in P.names]
                m.d.sync += [s_a[n].eq((arow[n] + dy[n])[:P.acc_fmt(n).width]) for n in P.names]
                for e in range(3):
                    m.d.sync += [s_p[e].eq(step_p[e]), s_r[e].eq(step_r[e])]
                with m.If(accept):
                    m.d.sync += [k_x0.eq(rec.x0), k_x1.eq(rec.x1)]
                    for e in range(3):
                        m.d.sync += [k_edge[e][k].eq(rec[f"e{e}_{k}"]) for k in ("kind", "q", "m", "d")]
                    m.d.sync += [k_dx[n].eq(rec[f"{n}_dx"]) for n in P.names]
                    m.d.sync += [k_dy[n].eq(rec[f"{n}_dy"]) for n in P.names]
                    m.d.sync += [k_c[n].eq(rec[n]) for n in k_c]
            with m.Else():
                m.d.sync += busy.eq(0)
        return m
