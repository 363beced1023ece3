"""RTL of the scan converter and attribute interpolators (paper, section 4 and Fig. 5), from
:class:`fxmodel.units.raster.RasterParams`: triangle records in, one fragment per clock out, bit-exact with
:func:`fxmodel.units.raster.scan`, clock count included.

Structure (see the model's docstring for the arithmetic and its proof). Every pipeline stage holds at most one
carry chain or one product (the house rule of the pixel pipeline); only the row step feeds back.

- **Input**: whenever the row generator can take a record (``ready``: no triangle loaded, or the last row of
  the one loaded leaving this clock) its registers load ``i.payload``, whether or not ``i.valid`` offers one,
  and ``gen_valid`` takes ``i.valid``: a record loaded without it is never issued. So the load enables come from
  the control copy's own flip-flops, and ``i.valid`` reaches one flip-flop per copy. When the enables were
  ``ready & i.valid``, the source's valid register drove every copy's enables through its logic, and that net,
  spread over the device, was the board's last failing path at 100 MHz (``docs/board/engine-misses.json``).
- **Row generator** (the loop-carried part of the Scan Line Initializer): the state of the next row, ``p_e``
  (kept as the bound ``v_e``: ``-p_e`` for a left edge, ``p_e`` for a right one), the Bresenham remainder
  ``r_e``, each attribute at ``(x0, y)``, ``y`` and the rows left. It issues one row per clock and steps:
  ``v += Q`` or ``v += Q'`` (``Q = ±q``, ``Q' = Q ± 1``, chosen by the carry ``r + m - |a| >= 0``, the two sums
  side by side), ``r += m`` or ``r += m - |a|``, ``a(x0, y + 1) = a(x0, y) + a_y``. Loading a record computes
  the per-triangle constants these sums need (``-p``, ``-q``, ``q + 1``, ``m - |a|``, ``x1 - x0``), one carry
  chain from the input; the next record is taken in the clock the last row of the previous triangle is issued.
  Its control is registered (``last``: this row is the triangle's last; ``room``: the FIFO has a place), so
  the enables of its registers are one logic level from flip-flops.
- **Span pipeline** (the rest of the Scan Line Initializer; :attr:`~fxmodel.units.raster.RasterParams.SPAN_STAGES`
  stages, nothing fed back): (1) each edge's bound relative to ``x0``, clamped to ``[0, x1 - x0]``, and whether
  it empties the row (``v - x0`` and ``v - x1 - 1`` side by side); (2) the span ``[L, R]`` (offsets from
  ``x0``) as the largest left and smallest right bound, from the three pairwise comparisons at once; (3)
  ``x0 + L``, ``R - L``, ``L <= R``, and ``L`` fanned out to a copy per attribute ("Fan-out"); (4) for every
  attribute, the partial products of ``a_x`` cut into :meth:`~fxmodel.units.raster.RasterParams.dx_pieces` times
  its copy of ``L`` (one multiplier block each, the product registered in the block); (5, 6) the span start
  ``a(x0, y) + L a_x`` as two adder levels over the partial products, modulo ``2**N``.
- **Row FIFO** (``amaranth.lib.fifo.SyncFIFO``, :attr:`~fxmodel.units.raster.RasterParams.ROW_FIFO_DEPTH` rows, LUT
  RAM, :func:`row_layout`): ``y``, ``x0 + L``, ``R - L``, whether the row is empty or one clock, every
  attribute's span start and ``a_x``, the triangle's constants. A credit counter (rows issued and not yet
  taken) lets the generator issue a row only when the FIFO has its place, so the span pipeline runs free, with
  no stage enable.
- **Pixel Calculator**: takes a row from the FIFO in the last clock of the previous one; ``x += 1``,
  ``a += a_x`` per pixel of the span, ``max(1, span)`` clocks a row; a down-counter of the pixels left gives
  the row's last clock as a register.
- **Per-triangle constants** (``params.carried``: the ``consts``, the bump engine's block exponent ``Ae``, and the
  ``slopes``, the increments the level of detail of MIP mapping reads): carried with every row, copied into every
  fragment of the triangle.
- **Output**: each attribute rounded half-up (one register stage) and saturated to its output format, into
  an output FIFO (:attr:`~fxmodel.units.raster.RasterParams.OUT_FIFO_DEPTH` fragments, LUT RAM, a
  :class:`~rtl.streams.CreditFIFO`: its writes are not checked against its level) whose head is ``o``.
  The consumer's ``ready`` reaches only the FIFO's read side: the Pixel Calculator and the rounding stage move
  under ``advance``, a flip-flop that is high while the FIFO has a place for every fragment in flight, so
  nothing is lost or repeated and no long enable path runs from the consumer into the interpolators (on the
  engine that path, the pixel pipeline's ``ready`` to every accumulator, held the design at 77 MHz). Each
  control copy counts the places in use itself (``out_used``): a read reaches the counts through
  :attr:`~fxmodel.units.raster.RasterParams.POP_STAGES` registers (``pop_seen`` beside the FIFO, then a kept
  copy beside each control copy), not from the consumer's ``ready`` through logic into every copy (the board's
  slowest path at 100 MHz, ``bumpmap bitstream --misses``); the FIFO is deeper by as many places, so one
  fragment a clock still flows.

**Fan-out.** The row generator's load and step enables reach some 2 000 register bits, the Pixel Calculator's
some 1 300; one net from one control flip-flop to all of them was the engine's critical path on ECP5 (12.3 ns, the
last hop 7.0 ns of routing). So each keeps its control state (the generator's ``gen_valid``, ``last_row``, rows
in flight and ``room``; the Pixel Calculator's ``busy``, ``nonempty``, pixels left, ``last_px``, output places
used, ``advance`` and the rows in the row FIFO with whether there is one) in identical copies, one per group of at most
:attr:`~fxmodel.units.raster.RasterParams.ENABLE_FANOUT` register bits (the edges, the per-triangle values, three or
four attributes a group): each copy is a few flip-flops with its own feedback, which synthesis does not merge
(two flip-flops with one input would be merged into one), and the placer puts each near its group. Copy 0 also
drives the ports, the FIFOs and the span pipeline's valid. The rows the Pixel Calculator takes reach the
generator's copies from the Pixel Calculator's copies in turn (generator copy ``j`` from copy ``j mod n``), not
from copy 0 alone: that one net to every generator copy was the board's critical path once the products were in
their multiplier blocks' registers. The rows written into the row FIFO reach the Pixel Calculator's copies
through a register beside each (:attr:`~fxmodel.units.raster.RasterParams.ROW_SEEN_STAGES`, a kept copy), and
the output FIFO's reads likewise (``POP_STAGES``, "Output"): each such event is one net from one register to a
register beside every copy, with no logic on the long route. Likewise the span's ``L`` reaches each
attribute's partial products from a copy of its own, in a stage of its own (the route from one register to the
multiplier blocks of every attribute, spread over the device, was the board's critical path; a copy computed
from the comparisons, in the same stage as ``L``, made the comparisons' route to every copy the next): the
multiplier blocks then take ``L`` and ``a_x`` without their input registers (both operands or neither,
``rtl/dsp.py``).

``busy`` is high while the Pixel Calculator works on a row: a row costs ``max(1, span)`` busy clocks, so when
the sink is always ready the busy clocks are the model's ``clocks``. The generator runs ahead of the Pixel
Calculator (by up to the FIFO's depth), so when the source never waits the rows follow one another with no
clock between them, within and across triangles: after the fill latency
(:attr:`~fxmodel.units.raster.RasterParams.latency` clocks from the first record to the first fragment) ``busy`` stays
high until the last row.
"""

from __future__ import annotations

from types import SimpleNamespace

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, signed
from amaranth.lib import data, stream, wiring
from amaranth.lib.fifo import SyncFIFO
from amaranth.lib.wiring import In, Out

from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.raster import EDGE_LEFT, EDGE_RIGHT, RasterParams

from .fixed import saturate, shape, shift_round
from .streams import CreditFIFO, less_one_if, payload_layout
from .unit import Pipe, kept_copy, named, register

__all__ = ["Raster", "record_layout", "fragment_layout", "row_layout"]


def record_layout(params: RasterParams) -> data.StructLayout:
    """The input payload: one field per :attr:`RasterParams.record` entry (first field in the low bits)."""
    return payload_layout(params.record)


def fragment_layout(params: RasterParams) -> data.StructLayout:
    """The output payload: one field per :attr:`RasterParams.fragment` entry."""
    return payload_layout(params.fragment)


def row_layout(params: RasterParams) -> data.StructLayout:
    """A row FIFO entry: ``y``, the span's first column ``xl`` and length less one ``n``, ``nonempty``,
    ``single`` (the row takes one clock: empty or one pixel), per attribute its span start ``<name>_start`` and
    increment ``<name>_dx`` (``acc_fmt``), the triangle's constants."""
    pf = shape(params.pixel_fmt)
    fields = {"y": pf, "xl": pf, "n": pf, "nonempty": 1, "single": 1}
    for n in params.names:
        fields |= {f"{n}_start": shape(params.acc_fmt(n)), f"{n}_dx": shape(params.acc_fmt(n))}
    return data.StructLayout(fields | {n: shape(f) for n, f in params.carried})


def _tree(pipe: Pipe, terms: dict, levels: int, carry: dict) -> tuple[dict, dict]:
    """Sums of ``terms`` (``{key: [(value, width)]}``, each sum modulo ``2**width``) in ``levels`` registered
    stages, one adder level (one carry chain) each: adjacent terms paired per level; ``carry`` registered beside.
    Returns the sums (the last level's expressions, not registered) and the last registers of ``carry``."""
    for level in range(levels):
        nxt = {}
        for key, ts in terms.items():
            nxt[key] = [((ts[i][0] + ts[i + 1][0])[:ts[i][1]] if i + 1 < len(ts) else ts[i][0], ts[i][1])
                        for i in range(0, len(ts), 2)]
        terms = nxt
        if level < levels - 1:
            regs = pipe.stage(**{f"{k}_{i}": v for k, ts in terms.items() for i, (v, _) in enumerate(ts)}, **carry)
            terms = {k: [(getattr(regs, f"{k}_{i}"), w) for i, (_, w) in enumerate(ts)] for k, ts in terms.items()}
            carry = {k: getattr(regs, k) for k in carry}
    if any(len(ts) > 1 for ts in terms.values()):
        raise ValueError("_tree: more terms than the levels can add")
    return {k: ts[0][0] for k, ts in terms.items()}, carry


def _carry_save(m, terms: list, width: int, name: str) -> list:
    """Two values whose sum equals the sum of ``terms`` modulo ``2**width`` (3:2 compressors, one LUT level each:
    no carry chain; the span start's products in logic, ``RasterParams.span_dsp`` off). Each compressor's sum and
    carry is a signal (``{name}_{level}_s{i}``, ``_c{i}``; :func:`rtl.unit.named`): each is read three times by
    the next level."""
    terms = [Value.cast(t)[:width] for t in terms]
    level = 0
    while len(terms) > 2:
        nxt = []
        for i in range(0, len(terms) - 2, 3):
            a, b, c = terms[i:i + 3]
            nxt += [named(m, a ^ b ^ c, f"{name}_{level}_s{i // 3}"),
                    named(m, (((a & b) | (a & c) | (b & c)) << 1)[:width], f"{name}_{level}_c{i // 3}")]
        nxt += terms[len(terms) - len(terms) % 3:] if len(terms) % 3 else []
        terms, level = nxt, level + 1
    return terms + [Const(0, width)] * (2 - len(terms))


def _bits(*regs) -> int:
    """Register bits of ``regs`` (a block's size for :func:`_groups`)."""
    return sum(len(r) for r in regs)


def _groups(blocks: list, limit: int) -> list[list]:
    """``blocks`` (tuples whose first item is a register bit count) packed in order into groups of at most
    ``limit`` bits (a larger block alone): each group gets its own copy of the control state."""
    groups, bits = [], limit + 1
    for block in blocks:
        if bits + block[0] > limit:
            groups.append([])
            bits = 0
        groups[-1].append(block)
        bits += block[0]
    return groups


@register(RasterParams)
class Raster(wiring.Component):
    """Scan converter and interpolators.

    Ports
    -----
    i : In(stream.Signature(record_layout(params))) -- triangle records (:attr:`RasterParams.record`)
    o : Out(stream.Signature(fragment_layout(params))) -- fragments (:attr:`RasterParams.fragment`): ``x``, ``y``
        (``pixel_fmt``), every attribute in its output format, the triangle's constants (``consts``, e.g. ``Ae``
        in ``bump.e_fmt``), ``flags`` (bit 0: an attribute saturated)
    busy : Out(1) -- the Pixel Calculator is on a row (count it for the clock figure)
    """

    def __init__(self, params: RasterParams):
        self.params = params
        super().__init__({"i": In(stream.Signature(record_layout(params))),
                          "o": Out(stream.Signature(fragment_layout(params))),
                          "busy": Out(1)})

    def elaborate(self, platform):
        m = Module()
        gen = self._row_generator(m)
        self._span_pipeline(m, gen, platform)
        self._pixel_calculator(m, gen)
        return m

    # -- row generator: per-triangle constants and the next row's state ------------------------------------------
    def _row_generator(self, m) -> SimpleNamespace:
        """The row generator's registers and control (module docstring); returns its state for the span
        pipeline: the registers, ``issue`` (a row leaves this clock), the row FIFO ``fifo`` and ``takes`` (the
        Pixel Calculator takes a row from it)."""
        P = self.params
        rec = self.i.payload
        ef = P.edge_fmts
        pf = P.pixel_fmt
        acc_w = {n: P.acc_fmt(n).width for n in P.names}
        g = SimpleNamespace()
        g.k_x0, g.k_x1, g.k_w = _sig(pf, "k_x0"), _sig(pf, "k_x1"), _sig(pf, "k_w")
        g.k_kind = [Signal(2, name=f"k_e{e}_kind") for e in range(3)]
        qw = shape(ef["q"]).width + 1
        k_q = [Signal(signed(qw), name=f"k_e{e}_Q") for e in range(3)]          # v += Q   (no carry)
        k_q1 = [Signal(signed(qw), name=f"k_e{e}_Q1") for e in range(3)]        # v += Q'  (carry)
        k_m = [_sig(ef["m"], f"k_e{e}_m") for e in range(3)]
        k_md = [Signal(signed(shape(ef["d"]).width + 1), name=f"k_e{e}_md") for e in range(3)]
        g.k_dx = {n: _sig(P.acc_fmt(n), f"k_{n}_dx") for n in P.names}
        k_dy = {n: _sig(P.acc_fmt(n), f"k_{n}_dy") for n in P.names}
        g.k_c = {n: _sig(f, f"k_{n}") for n, f in P.carried}
        g.s_v = [_sig(ef["p"], f"s_e{e}_v") for e in range(3)]
        s_r = [_sig(ef["r"], f"s_e{e}_r") for e in range(3)]
        g.s_a = {n: _sig(P.acc_fmt(n), f"s_{n}_row") for n in P.names}
        g.s_y, s_rem = _sig(pf, "s_y"), _sig(pf, "s_rem")

        m.submodules.rows = g.fifo = SyncFIFO(width=row_layout(P).size, depth=P.ROW_FIFO_DEPTH)
        g.takes = []                    # per control copy: the Pixel Calculator takes a row (``_pixel_calculator``)

        # the registers in blocks: (bits, load statements, step statements)
        blocks = [(_bits(g.k_x0, g.k_x1, g.k_w, g.s_y, s_rem, *g.k_c.values()),
                   [g.k_x0.eq(rec.x0), g.k_x1.eq(rec.x1), g.k_w.eq(rec.x1 - rec.x0), g.s_y.eq(rec.y0),
                    s_rem.eq(rec.rows), *(g.k_c[n].eq(rec[n]) for n in g.k_c)],
                   [g.s_y.eq(g.s_y + 1), s_rem.eq(s_rem - 1)])]
        for e in range(3):
            left = rec[f"e{e}_kind"] == EDGE_LEFT
            p, q = rec[f"e{e}_p"], rec[f"e{e}_q"]
            t = Signal(signed(len(k_md[e]) + 1), name=f"rmd{e}")
            m.d.comb += t.eq(s_r[e] + k_md[e])
            carry = ~t[-1]                                               # r + m >= |a|
            blocks.append((_bits(g.k_kind[e], k_m[e], k_md[e], s_r[e], g.s_v[e], k_q[e], k_q1[e]),
                           [g.k_kind[e].eq(rec[f"e{e}_kind"]), k_m[e].eq(rec[f"e{e}_m"]),
                            k_md[e].eq(rec[f"e{e}_m"] - rec[f"e{e}_d"]), s_r[e].eq(rec[f"e{e}_r"]),
                            g.s_v[e].eq(Mux(left, -p, p)), k_q[e].eq(Mux(left, -q, q)),
                            k_q1[e].eq(Mux(left, ~q, q + 1))],
                           [s_r[e].eq(Mux(carry, t, s_r[e] + k_m[e])),
                            g.s_v[e].eq(Mux(carry, g.s_v[e] + k_q1[e], g.s_v[e] + k_q[e]))]))
        for n in P.names:
            blocks.append((_bits(g.s_a[n], g.k_dx[n], k_dy[n]),
                           [g.s_a[n].eq(rec[f"{n}_0"]), g.k_dx[n].eq(rec[f"{n}_dx"]), k_dy[n].eq(rec[f"{n}_dy"])],
                           [g.s_a[n].eq((g.s_a[n] + k_dy[n])[:acc_w[n]])]))
        g.issue = None
        for k, group in enumerate(_groups(blocks, P.ENABLE_FANOUT)):
            g.takes.append(Signal(name=f"take_row_{k}"))
            issue_k, ready_k = self._gen_control(m, k, s_rem, g.takes[k])
            g.issue = issue_k if g.issue is None else g.issue
            with m.If(ready_k):
                m.d.sync += [st for _, load, _ in group for st in load]
            with m.Elif(issue_k):
                m.d.sync += [st for _, _, step in group for st in step]
        return g

    def _gen_control(self, m, k: int, s_rem, take):
        """Copy ``k`` of the generator's control (module docstring, "Fan-out"): whether a triangle is loaded,
        whether its next row is the last, the rows issued and not yet taken from the FIFO and whether the FIFO
        has room for one more, all registered. Returns ``(issue, ready)``: ``ready``, the generator can take a
        record, is the load enable of the copy's registers, whether or not one is offered ("Input" in the module
        docstring)."""
        rec, depth = self.i.payload, self.params.ROW_FIFO_DEPTH
        gv = Signal(name=f"gen_valid_{k}")
        inflight = Signal(range(depth + 1), name=f"rows_in_flight_{k}")
        room = Signal(name=f"room_{k}", init=1)                     # inflight != depth
        last = Signal(name=f"last_row_{k}")                         # s_rem == 0
        issue, ready = Signal(name=f"issue_{k}"), Signal(name=f"ready_{k}")
        m.d.comb += [issue.eq(gv & room), ready.eq(~gv | (issue & last))]
        m.d.sync += [inflight.eq(less_one_if(take, inflight + issue)),          # ``take``: from the Pixel Calculator
                     room.eq(less_one_if(take, inflight + issue, lambda v: v != depth))]
        with m.If(ready):                   # a record taken if offered (the registers load it either way)
            m.d.sync += [gv.eq(self.i.valid), last.eq(rec.rows == 0)]
        with m.Elif(issue):
            m.d.sync += last.eq(s_rem == 1)
        if k == 0:
            m.d.comb += self.i.ready.eq(ready)
        return issue, ready

    # -- span pipeline (free running: the credits keep a FIFO place for every row issued) ------------------------
    def _span_pipeline(self, m, g: SimpleNamespace, platform=None):
        """The span pipeline from the generator's state ``g`` into the row FIFO (module docstring)."""
        P = self.params
        w = P.pixel_fmt.width
        acc_w = {n: P.acc_fmt(n).width for n in P.names}
        pipe = Pipe(m, "span_", platform)
        # (1) each edge's bound relative to x0, clamped to [0, x1 - x0], and whether it empties the row
        nx1 = (~Cat(g.k_x1, Const(0, 1))).as_signed()                    # -x1 - 1
        bounds = {}
        for e in range(3):
            a = Signal(signed(len(g.s_v[e]) + 2), name=f"v_x0_{e}")
            b = Signal(signed(len(g.s_v[e]) + 2), name=f"v_x1_{e}")
            m.d.comb += [a.eq(g.s_v[e] - g.k_x0), b.eq(g.s_v[e] + nx1)]
            is_l, is_r = g.k_kind[e] == EDGE_LEFT, g.k_kind[e] == EDGE_RIGHT
            bounds[f"lo{e}"] = Mux(is_l & ~a[-1], a[:w], 0)                 # left: x >= v
            bounds[f"hi{e}"] = Mux(is_r & b[-1], a[:w], g.k_w)              # right: x <= v
            bounds[f"empty{e}"] = (is_l & ~b[-1]) | (is_r & a[-1])          # v > x1, v < x0
        per_tri = {"x0": g.k_x0, **{f"dx_{n}": g.k_dx[n] for n in P.names}, **{f"c_{n}": g.k_c[n] for n in g.k_c}}
        s1 = pipe.stage(valid=g.issue, y=g.s_y, **bounds, **per_tri, **{f"a_{n}": g.s_a[n] for n in P.names})
        keep = ["valid", "y", *per_tri, *(f"a_{n}" for n in P.names)]

        # (2) the span: the largest left bound, the smallest right bound (pairwise comparisons side by side)
        lo = [getattr(s1, f"lo{e}") for e in range(3)]
        hi = [getattr(s1, f"hi{e}") for e in range(3)]
        s2 = pipe.stage(L=_pick(lo, lambda x, y: x >= y), R=_pick(hi, lambda x, y: x <= y),
                        empty=Cat(*(getattr(s1, f"empty{e}") for e in range(3))).any(), **_passing(s1, keep))

        # (3) the span's first column and length, whether it is empty or one clock; L fanned out: a copy for each
        # attribute's partial products, beside that attribute's multiplier blocks (module docstring, "Fan-out")
        keep3 = ["valid", "y", *(f"dx_{n}" for n in P.names), *(f"c_{n}" for n in g.k_c),
                 *(f"a_{n}" for n in P.names)]
        nonempty = ~s2.empty & (s2.L <= s2.R)
        s3 = pipe.stage(xl=(s2.x0 + s2.L)[:w], n=(s2.R - s2.L)[:w], nonempty=nonempty,
                        single=~nonempty | (s2.L == s2.R), **_passing(s2, keep3))
        # a copy per attribute in logic too: each bit of L selects a copy of every bit of a_x, a fan-out of
        # hundreds of LUTs from one register ahead of the carry-save levels (the fitted MIP engine's raster
        # endpoints, ``docs/fpga/placement.json``)
        offset = {n: kept_copy(m, s2.L, f"span_L_{n}") for n in P.names}

        # (4) the partial products a_x L
        parts, shifts = {}, {}
        for n in P.names:
            dx = getattr(s3, f"dx_{n}")
            if not P.span_dsp:               # in logic: a_x's copies shifted by L's bits, carry-saved to two terms
                parts |= {f"pp_{n}_{k}": t for k, t in enumerate(_carry_save(
                    m, [Mux(offset[n][i], dx << i, 0)[:acc_w[n]] for i in range(len(offset[n]))], acc_w[n],
                    f"csa_{n}"))}
                shifts[n] = [0, 0]
                continue
            cut = [(dx[lo:lo + bits].as_signed() if signed else dx[lo:lo + bits], lo)
                   for lo, bits, signed in P.dx_pieces(n)]
            parts |= {f"pp_{n}_{k}": piece * offset[n] for k, (piece, _) in enumerate(cut)}
            shifts[n] = [shift for _, shift in cut]
        s4 = pipe.stage(**parts, **_passing(s3, ["xl", "n", "nonempty", "single", *keep3]))
        terms = {n: [(getattr(s4, f"a_{n}"), acc_w[n])]
                 + [((getattr(s4, f"pp_{n}_{k}") << sh)[:acc_w[n]], acc_w[n]) for k, sh in enumerate(shifts[n])]
                 for n in P.names}
        # (5, 6) the span start a(x0, y) + L a_x, modulo 2**N, two adder levels
        carry = _passing(s4, ["valid", "y", "xl", "n", "nonempty", "single", *(f"dx_{n}" for n in P.names),
                              *(f"c_{n}" for n in g.k_c)])
        start, carry = _tree(pipe, terms, P.SPAN_STAGES - 4, carry)
        assert pipe.depth == P.SPAN_STAGES - 1                            # the last level writes the FIFO

        row_in = data.View(row_layout(P), g.fifo.w_data)
        m.d.comb += [g.fifo.w_en.eq(carry["valid"])]
        m.d.comb += [row_in[k].eq(carry[k]) for k in ("y", "xl", "n", "nonempty", "single")]
        m.d.comb += [row_in[f"{n}_start"].eq(start[n]) for n in P.names]
        m.d.comb += [row_in[f"{n}_dx"].eq(carry[f"dx_{n}"]) for n in P.names]
        m.d.comb += [row_in[n].eq(carry[f"c_{n}"]) for n in g.k_c]

    # -- Pixel Calculator, rounding, saturation into the output FIFO ---------------------------------------------
    def _pixel_calculator(self, m, g: SimpleNamespace):
        """The Pixel Calculator: rows from the row FIFO ``g.fifo`` (taken under ``g.takes``), one fragment a
        clock through the rounding stage and the saturation into the output FIFO (module docstring)."""
        P = self.params
        pf = P.pixel_fmt
        acc_w = {n: P.acc_fmt(n).width for n in P.names}
        row = data.View(row_layout(P), g.fifo.r_data)
        cx, cy = _sig(pf, "cx"), _sig(pf, "cy")
        acc = {n: _sig(P.acc_fmt(n), f"acc_{n}") for n in P.names}
        pdx = {n: _sig(P.acc_fmt(n), f"pc_{n}_dx") for n in P.names}
        pc_c = {n: _sig(f, f"pc_{n}") for n, f in P.carried}

        # the output FIFO: the consumer's ready reaches only its read side; the Pixel Calculator and the rounding
        # stage move under ``advance``, a flip-flop: fragments in the rounding stage and the FIFO leave a place
        m.submodules.out = ofifo = CreditFIFO(fragment_layout(P).size, P.OUT_FIFO_DEPTH)   # ``advance``: credits
        m.d.comb += [self.o.valid.eq(ofifo.r_rdy), self.o.payload.eq(ofifo.r_data), ofifo.r_en.eq(self.o.ready)]
        pop_seen = Signal(name="pop_seen")             # the consumer read a fragment (the copies hear it a clock on)
        m.d.sync += pop_seen.eq(ofifo.r_rdy & self.o.ready)
        r_valid, r_x, r_y, r_a, r_c = self._output_stage(m, ofifo, acc)

        # the registers in blocks: (bits, statements under ``advance``, along the row, on taking a row); the
        # first block's control copy also drives the FIFOs and ``busy``
        rounded = self._rounded
        blocks = [(_bits(cx, cy, r_x, r_y, r_valid, *pc_c.values(), *r_c.values()),
                   lambda busy, nonempty: [r_valid.eq(busy & nonempty), r_x.eq(cx), r_y.eq(cy),
                                           *(r_c[n].eq(pc_c[n]) for n in pc_c)],
                   [cx.eq(cx + 1)],
                   [cx.eq(row.xl), cy.eq(row.y), *(pc_c[n].eq(row[n]) for n in pc_c)])]
        for n in P.names:
            blocks.append((_bits(acc[n], pdx[n], *r_a[n]),
                           lambda busy, nonempty, n=n: [r.eq(v) for r, v in zip(r_a[n], rounded[n])],
                           [acc[n].eq((acc[n] + pdx[n])[:acc_w[n]])],
                           [acc[n].eq(row[f"{n}_start"]), pdx[n].eq(row[f"{n}_dx"])]))
        takes = []
        for k, group in enumerate(_groups(blocks, P.ENABLE_FANOUT)):
            advance, step, take_k, busy, nonempty = self._pc_control(m, k, g.fifo, pop_seen, row)
            takes.append(take_k)
            if k == 0:
                m.d.comb += [g.fifo.r_en.eq(take_k), self.busy.eq(busy), ofifo.w_en.eq(advance & r_valid)]
            with m.If(advance):
                m.d.sync += [st for _, always, _, _ in group for st in always(busy, nonempty)]
                with m.If(step):
                    m.d.sync += [st for _, _, along, _ in group for st in along]
                with m.Elif(take_k):
                    m.d.sync += [st for _, _, _, load in group for st in load]
        # each generator copy hears ``take`` from one Pixel Calculator copy (all equal): no one net to every copy
        m.d.comb += [t.eq(takes[j % len(takes)]) for j, t in enumerate(g.takes)]

    def _output_stage(self, m, ofifo, acc: dict):
        """The output narrowing in two steps: rounding (a register stage under ``advance``), saturation into the
        output FIFO's write port. Returns the rounding stage's registers ``(valid, x, y, attributes,
        constants)``, each attribute's as ``(rounded, saturation flag)``; the values they load, the rounded
        accumulators with their flags, are ``self._rounded``."""
        P = self.params
        pf = P.pixel_fmt
        rounded = {n: shift_round(acc[n], P.acc_fmt(n).frac_bits - P.out_fmt(n).frac_bits, Rounding.HALF_UP)
                   for n in P.names}
        # each attribute's saturation flag is registered beside its rounded value (the same flag, one stage
        # earlier): the fragment's flag is then one OR of registers, not each attribute's compare and an OR
        # across all of them on one path to the FIFO (a routed run's worst engine path)
        self._rounded = {n: (rounded[n], saturate(rounded[n], P.out_fmt(n), Overflow.SATURATE)[1])
                         for n in P.names}
        r_valid, r_x, r_y = Signal(name="rnd_valid"), _sig(pf, "rnd_x"), _sig(pf, "rnd_y")
        r_a = {n: (Signal(rounded[n].shape(), name=f"rnd_{n}"), Signal(name=f"rnd_{n}_sat")) for n in P.names}
        r_c = {n: _sig(f, f"rnd_{n}") for n, f in P.carried}
        frag = data.View(fragment_layout(P), ofifo.w_data)
        m.d.comb += [frag.x.eq(r_x), frag.y.eq(r_y)]
        m.d.comb += [frag[n].eq(saturate(r_a[n][0], P.out_fmt(n), Overflow.SATURATE)[0]) for n in P.names]
        m.d.comb += frag.flags.eq(Cat(*(sat for _, sat in r_a.values())).any())
        m.d.comb += [frag[n].eq(r_c[n]) for n in r_c]
        return r_valid, r_x, r_y, r_a, r_c

    def _pc_control(self, m, k: int, fifo, pop_seen, row):
        """Copy ``k`` of the Pixel Calculator's control (module docstring, "Fan-out"): on a row, the row not
        empty, its pixels left and whether this is its last clock, the output FIFO's places in use and
        ``advance``, all registered, and the rows in the row FIFO (``row_count``, the FIFO's own level kept by
        every copy, and ``has_row``, whether it is not zero: a register, so the FIFO's level, one net, does not
        reach every copy's ``take`` and through it every register the copies load; a write counts
        ``ROW_SEEN_STAGES`` clocks late, through a register beside the copy). Returns ``(advance, step,
        take, busy, nonempty)``: ``step`` moves along the row, ``take`` loads the next row from the FIFO (both only
        under ``advance``)."""
        out_depth = self.params.OUT_FIFO_DEPTH
        count = Signal(range(self.params.ROW_FIFO_DEPTH + 1), name=f"row_count_{k}")
        has_row = Signal(name=f"has_row_{k}")                          # count != 0
        busy, nonempty = Signal(name=f"busy_{k}"), Signal(name=f"nonempty_{k}")
        last_px = Signal(name=f"last_px_{k}")          # the row's last clock (its last pixel, or it is empty)
        npx = _sig(self.params.pixel_fmt, f"px_left_{k}")
        out_used = Signal(range(out_depth + 1), name=f"out_used_{k}")
        advance = Signal(name=f"advance_{k}", init=1)                  # out_used <= out_depth - 2
        produce = advance & busy & nonempty
        popped = _relay(m, pop_seen, f"pop_seen_{k}", range(1, self.params.POP_STAGES))   # a read, POP_STAGES ago
        m.d.sync += [out_used.eq(less_one_if(popped, out_used + produce)),
                     advance.eq(less_one_if(popped, out_used + produce, lambda v: v <= out_depth - 2))]
        done_row = ~busy | last_px
        step, take_k = Signal(name=f"step_{k}"), Signal(name=f"take_{k}")
        m.d.comb += [step.eq(~done_row), take_k.eq(advance & done_row & has_row)]
        wrote = _relay(m, fifo.w_en, f"row_seen_{k}", range(self.params.ROW_SEEN_STAGES))  # a write, as many ago
        m.d.sync += [count.eq(less_one_if(take_k, count + wrote)),
                     has_row.eq(less_one_if(take_k, count + wrote, lambda v: v != 0))]
        with m.If(advance):
            with m.If(step):
                m.d.sync += [npx.eq(npx - 1), last_px.eq(npx == 1)]
            with m.Elif(take_k):
                m.d.sync += [busy.eq(1), nonempty.eq(row.nonempty), npx.eq(row.n), last_px.eq(row.single)]
            with m.Else():
                m.d.sync += busy.eq(0)
        return advance, step, take_k, busy, nonempty


def _relay(m, event, stem: str, stages: range):
    """``event`` through a kept register copy (:func:`rtl.unit.kept_copy`) per stage number in ``stages``, named
    ``{stem}_{s}`` (:data:`rtl.unit.COPY_SUFFIX` after it): an event one control copy must hear, brought beside
    it with no logic on the long route (module docstring, "Fan-out"). ``formal/raster.py`` finds them by name."""
    for s in stages:
        event = kept_copy(m, event, f"{stem}_{s}")
    return event


def _sig(fmt, name: str) -> Signal:
    """A register of format ``fmt`` named ``name``."""
    return Signal(shape(fmt), name=name)


def _passing(s, names) -> dict:
    """The fields ``names`` of pipeline stage ``s``, passed on to the next stage."""
    return {k: getattr(s, k) for k in names}


def _pick(v, better):
    """Of three values the one ``better`` than the other two (pairwise comparisons side by side)."""
    b01, b02, b12 = better(v[0], v[1]), better(v[0], v[2]), better(v[1], v[2])
    return Mux(b01 & b02, v[0], Mux(b12, v[1], v[2]))
