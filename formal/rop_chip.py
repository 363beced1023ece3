"""Property set of the depth test on chip (``rtl/rop.py``, :class:`~rtl.rop.Rop` with ``on_chip=True``): the unit
both board builds carry (the frame on chip, and each tile of the frame in SDRAM).

Its handshake is short (``i.ready`` is ``~fb.read``: a fragment is refused only while the frame is read out);
what can go wrong is behind it: eight stages between a fragment's acceptance and its write, a read port that does
not see the writes of the six fragments ahead, five of them forwarded, and a read-out that holds the first two
stages and may clear the frame behind it. The set proves, against a reference frame written in the order the
fragments arrive (``ref``: the depth test of ``fxmodel/units/rop.py`` one fragment at a time):

- rule 2 assumed on ``i``; ``i.ready`` is ``~fb.read``;
- the read-out's contract (:class:`board.frame.TileCopy` keeps it, waiting for ``busy`` to stay low): a clearing
  read-out (``fb.clear``, only with ``fb.read``) begins while ``busy`` is low;
- fragments conserved: accepted = dropped outside the frame + compared + in the stages (``in_valid``,
  ``acc_valid``, ``rd1..3_valid``, ``cmp_valid``); ``busy`` is low only with no fragment accepted and not written;
- **the write decision**: each write the unit issues is the reference's (a fragment written exactly when its depth
  is strictly nearer than the reference's stored depth of its pixel, with its depth and color; a clearing read-out
  writes the clear word): the forwarding network is right for every pattern of pixels in flight;
- the read-out returns the reference's word (``readout_latency`` cycles later) when read with ``busy`` low;
- the sticky flags: ``outside`` and ``z_saturated`` rise two clocks after their fragment, and only then; a clearing
  read-out clears them.

The frame's memory (Amaranth ``Memory`` slices, ``RopParams.slice_bits`` each, one read port not transparent) is
modelled by :class:`ArrayFrameRop` as one array of registers with that read port's behaviour (the word of the
address registered the cycle before, as it was before that cycle's write): the slices share their address and
write registers, so one slice of the whole word is the same design; the array's words are what the invariant
relating the memory to the reference reads, which makes k-induction close (a memory the solver sees only as an
opaque array would leave an unread word disagreeing with the reference forever).
"""

from __future__ import annotations

from amaranth.hdl import Array, Cat, Mux, Signal

from fxmodel.units.rop import STATUS_BITS, Z_OVERFLOW, Z_ROUNDING, RopParams, clear_word
from rtl.fixed import narrow
from rtl.rop import Rop, pixel_index
from rtl.streams import payload_layout
from rtl.unit import COPY_SUFFIX

from . import whitebox
from .props import Harness, bits_for
from .readers import drive_inputs
from .rop import small_rop

__all__ = ["ArrayFrameRop", "small_rop_chip", "rop_chip_set", "ROP_CHIP_DEPTH"]

#: k of the k-induction: the stages between a fragment's read and its write (the reference relates only the
#: memory and the two write stages to the frame; the stages in flight follow from the last k steps)
ROP_CHIP_DEPTH = 9


def small_rop_chip(**kw) -> RopParams:
    """The on-chip ROP of the proof: a 4 x 4 frame in an 8-pixel viewport (fragments outside the frame arrive),
    3-bit depths, one flag bit (the control is that of any size; the size sets only the index's width)."""
    return small_rop(**({"on_chip": True, "max_size": 8, "flag_bits": 1} | kw))


class ArrayFrameRop(Rop):
    """:class:`~rtl.rop.Rop` on chip with its frame as registers (``words``): the read port's address registered,
    its word the memory's before that cycle's write, registered again (the word beside the block RAM); the write
    from registers (enable ``we``, address ``wa``, data ``wd``), as ``Rop._frame`` builds each slice."""

    def _frame(self, m, clear, raddr, w_en, w_index, wdata):
        P = self.params
        self.words = [Signal(P.word_bits, init=clear, name=f"f_word{a}") for a in range(P.pixels)]
        ra = Signal.like(w_index, name="f_raddr")
        self.we, self.wa = Signal(name="f_we"), Signal.like(w_index, name="f_wa")
        self.wd = Signal(P.word_bits, name="f_wd")
        port, word = Signal(P.word_bits, name="f_port"), Signal(P.word_bits, name="f_read")
        m.d.sync += [ra.eq(raddr), self.we.eq(w_en), self.wa.eq(w_index), self.wd.eq(wdata),
                     port.eq(Array(self.words)[ra]), word.eq(port)]
        for a, w in enumerate(self.words):
            with m.If(self.we & (self.wa == a)):
                m.d.sync += w.eq(self.wd)
        return word


def rop_chip_set(params: RopParams | None = None, *, kind: str = "proof", wrap=None) -> Harness:
    P = params or small_rop_chip()
    h = Harness(kind)
    m = h.m
    inner = ArrayFrameRop(P)
    dut, _, top = whitebox.attach(h, inner, wrap)
    sig = lambda name: whitebox.signal(top, name)        # noqa: E731
    drive_inputs(h, dut)            # free inputs: the fragment stream and the read-out
    fb_read, fb_clear, fb_addr = dut.fb.read, dut.fb.clear, dut.fb.addr
    h.stream_hold(dut.i.valid, dut.i.ready, dut.i.payload.as_value(), "i", assume=True)
    clearing = fb_read & fb_clear
    h.check(~fb_clear | fb_read, "clear_with_read", assume=True)
    h.check(~h.started | ~clearing | h.past(clearing, "clearing") | ~dut.busy, "clear_begins_quiet", assume=True)
    h.check(fb_addr < P.pixels, "readout_in_frame", assume=True)
    h.check(dut.i.ready == ~fb_read, "ready_is_not_readout")

    zb, words = P.z_fmt.width, inner.words
    clear = clear_word(P)
    # stage I and the compare (names in rtl/rop.py)
    in_valid, in_frag = sig("in_valid"), payload_layout(P.inputs)(sig("in_frag"))
    c_valid, c_z, c_color, c_index = sig("cmp_valid"), sig("cmp_z"), sig("cmp_color"), sig("cmp_index")
    w_en, w_z, w_color, w_index = sig("write"), sig("write_z"), sig("write_color"), sig("write_index")
    stages = [in_valid, sig("acc_valid"), sig("rd1_valid"), sig("rd2_valid"), sig("rd3_valid"), c_valid]

    # the reference frame: each compared fragment against the reference's stored depth, in arrival order; a
    # clearing read-out writes the clear word
    ref = [Signal(P.word_bits, init=clear, name=f"f_ref{a}") for a in range(P.pixels)]
    ref_word = Array(ref)[c_index]
    passes = c_valid & (c_z > ref_word[:zb])
    with m.If(clearing):
        m.d.sync += Array(ref)[fb_addr].eq(clear)
    with m.Elif(passes):
        m.d.sync += Array(ref)[c_index].eq(Cat(c_z, c_color))
    # the write decision: the unit writes what the reference wrote, a clock later
    was_clear, was_pass = h.past(clearing, "clear"), h.past(passes, "pass")
    h.check(~h.started | (w_en == (was_clear | was_pass)), "write_decision")
    h.check(~h.started | ~was_pass | ((w_index == h.past(c_index, "c_index"))
                                      & (Cat(w_z, w_color) == h.past(Cat(c_z, c_color), "c_word"))), "write_word")
    h.check(~h.started | ~was_clear | ((w_index == h.past(fb_addr, "fb_addr"))
                                       & (Cat(w_z, w_color) == clear)), "write_clear_word")
    # the invariant that closes the induction: the reference is the memory with the two writes in flight over it
    # (the write's central registers, newer, then the registers beside the memory)
    for a in range(P.pixels):
        held = Mux(w_en & (w_index == a), Cat(w_z, w_color), Mux(inner.we & (inner.wa == a), inner.wd, words[a]))
        h.check(ref[a] == held, f"frame_is_reference_{a}")
    h.check(inner.we == sig("wrote1" + COPY_SUFFIX), "write_copy_agrees")
    h.check(~clearing | ~c_valid, "no_fragment_under_clear")
    # fragments conserved; busy
    take = dut.i.valid & dut.i.ready
    inside, _ = pixel_index(P, in_frag.x, in_frag.y)
    drop = in_valid & ~fb_read & ~inside
    w = bits_for(2 * len(stages) + 2)
    in_flight = Signal(w, name="f_in_flight")
    m.d.sync += in_flight.eq(in_flight + take - drop - c_valid)
    h.check(in_flight == sum(stages), "fragments_conserved")
    h.check(dut.busy | ~(Cat(*stages).any() | w_en | inner.we), "busy_while_held")
    # the read-out: the reference's word, readout_latency clocks after a read with busy low
    quiet_read = h.pasts(fb_read & ~dut.busy, P.readout_latency, "read")[-1]
    expect = h.pasts(Array(ref)[fb_addr], P.readout_latency, "expect")[-1]
    h.check(~quiet_read | (dut.fb.data == expect), "readout_word")
    # the sticky flags: raised two clocks after their fragment (stage I's), and only then; cleared by a clear
    _, zsat = narrow(in_frag.z, P.z_in.frac_bits, P.z_fmt, Z_ROUNDING, Z_OVERFLOW)
    for name, cond in (("outside", drop), ("z_saturated", in_valid & ~fb_read & inside & zsat)):
        bit = dut.status[STATUS_BITS[name]]
        two = h.pasts(cond, 2, name)[-1]
        h.check(~two | bit, f"{name}_raised")
        cleared = h.pasts(clearing, 2, f"{name}_c")[-1]
        h.check(~h.started | ~bit | two | (h.past(bit, f"{name}_was") & ~cleared), f"{name}_only_by_fragment")
    # reachability: each forwarding distance taken by a passing fragment, a failed test, the read-out's word,
    # a fragment behind a clear, a fragment held by the read-out
    same = [sig(f"same{k}") for k in (1, 2, 3, 4, 5)]
    h.cover(sig("cmp_same1") & w_en & c_valid & passes, "forward_1_reach")
    wrote = (w_en, inner.we, sig("wrote2"), sig("wrote3"))          # (inner.we: wrote1, proven above)
    for k, (s, en) in enumerate(zip(same[1:], wrote), start=2):
        h.cover(s & en & sig("rd3_valid"), f"forward_{k}_reach")
    h.cover(c_valid & ~passes, "failed_test_reach")
    h.cover(quiet_read & (dut.fb.data != clear), "readout_drawn_reach")
    recent = h.pasts(clearing, P.latency + 1, "clear_ago")
    h.cover(c_valid & Cat(*recent).any(), "fragment_behind_clear_reach")
    h.cover(fb_read & in_valid & sig("acc_valid"), "held_by_readout_reach")
    h.cover(Cat(*stages).all(), "all_stages_reach")
    return h

