"""Property set of :class:`rtl.streams.CreditFIFO`, the FIFO whose writes are not checked against its level (the
scan converter's row and output FIFOs): its contract, proven, so that the sets that read it (``formal/raster.py``)
may assume it where they read it, as they assume Amaranth's ``SyncFIFO``'s.

The writer is assumed to hold credits (it writes only while ``w_rdy``) and to number its words 0, 1, 2, ...
(modulo ``2**t``, above the depth); the reader is free. Proven by k-induction with white-box invariants (the
FIFO's own assertions on the formal platform: its level, ``r_rdy`` and pointers agree; and every word held, read
through the ports the FIFO adds on that platform, is the number it must be): every word read is the next number
(nothing lost, repeated or reordered), ``level`` is the words written less those read, ``r_rdy`` is ``level != 0``,
``overflow`` never rises. Covers: a full FIFO, a read from a full FIFO, a write and a read in the same cycle.
"""

from __future__ import annotations

from amaranth.hdl import Signal

from fxmodel.units.raster import RasterParams
from rtl.streams import CreditFIFO

from . import whitebox
from .props import Harness, bits_for

__all__ = ["credit_fifo_set", "DEPTH"]

#: The depth the proof runs: the scan converter's output FIFO's (not a power of two since its reads reach the
#: control copies through registers, ``RasterParams.POP_STAGES``: the pointers wrap by compare, not by width).
DEPTH = RasterParams.OUT_FIFO_DEPTH


def credit_fifo_set(depth: int = DEPTH, *, kind: str = "proof", wrap=None) -> Harness:
    h = Harness(kind)
    m = h.m
    t = bits_for(2 * depth + 1)
    inner = CreditFIFO(t, depth)
    dut = wrap(inner) if wrap else inner
    m.submodules.dut = whitebox.elaborate(dut)
    w_en, r_en, w_data = h.free(1, "w_en"), h.free(1, "r_en"), h.free(t, "w_data")
    m.d.comb += [dut.w_en.eq(w_en), dut.r_en.eq(r_en), dut.w_data.eq(w_data)]
    n_in, n_out = Signal(t, name="f_n_in"), Signal(t, name="f_n_out")
    took = dut.r_en & dut.r_rdy
    m.d.sync += [n_in.eq(n_in + w_en), n_out.eq(n_out + took)]
    h.check(~w_en | dut.w_rdy, "w_credit", assume=True)
    h.check(~w_en | (w_data == n_in), "w_seq", assume=True)
    h.check(~dut.r_rdy | (dut.r_data == n_out), "r_seq")
    h.check(dut.level == (n_in - n_out)[:t], "level_counts")
    h.check(~dut.overflow, "no_overflow")
    # white-box: each word held is the number it must be (the FIFO asserts its pointers and level itself)
    frag = m.submodules.dut
    rptr = whitebox.signal(frag, "head")
    for k in range(depth):
        age = (k - rptr) % depth                  # place of slot k from the head
        h.check((age >= dut.level) | (whitebox.signal(frag, f"slot{k}") == (n_out + age)[:t]), f"slot{k}_word")
    h.cover(dut.level == depth, "full_reach")
    h.cover((dut.level == depth) & took, "full_read_reach")
    h.cover(w_en & took & (dut.level == 1), "one_in_one_out_reach")
    return h
