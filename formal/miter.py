"""The independence miter: rule 3 of the streams (``valid`` never waits for ``ready``) and the stream versions'
promise that ``i.ready`` comes from registers only, as a property with a counterexample.

Two copies of a design get the same free inputs from reset, so their states are equal, until one cycle (the
probe, chosen by the solver) in which the second copy sees one input flipped: ``i.valid`` (then ``i.ready``
must be equal in both copies in that cycle) or ``o.ready`` (then ``o.valid`` and ``o.payload`` must be). After the
first probe the copies differ and nothing more is checked. A bounded check: its depth is the number of cycles
from reset in which the probe may fall.
"""

from __future__ import annotations

from amaranth.hdl import Signal

from .props import Harness

__all__ = ["independence"]


def independence(h: Harness, make, in_payload_shape, payload: bool = True):
    """Add the miter of two copies of ``make()`` (a component with stream ports ``i`` and ``o``) to ``h``;
    ``payload=False`` compares ``o.valid`` only (for a run whose datapath is cut: the copies' cut values
    differ)."""
    m = h.m
    a, b = make(), make()
    m.submodules.copy_a, m.submodules.copy_b = a, b
    i_valid = h.free(1, "i_valid")
    i_payload = h.free(in_payload_shape, "i_payload")
    o_ready = h.free(1, "o_ready")
    flip_v, flip_r = h.free(1, "probe_valid"), h.free(1, "probe_ready")
    probed = Signal(name="f_probed")
    with m.If(flip_v | flip_r):
        m.d.sync += probed.eq(1)
    h.check(~(flip_v & flip_r) & ~(probed & (flip_v | flip_r)), "one_probe", assume=True)
    for copy, fv, fr in ((a, 0, 0), (b, flip_v, flip_r)):
        m.d.comb += [copy.i.valid.eq(i_valid ^ fv), copy.i.payload.eq(i_payload), copy.o.ready.eq(o_ready ^ fr)]
    h.check(~flip_v | (a.i.ready == b.i.ready), "ready_indep_of_valid")
    # the payload counts only while valid (a free-running datapath's output is undefined otherwise: a
    # memory's read register has no initial value, so the copies may differ there)
    same_payload = (a.o.payload.as_value() == b.o.payload.as_value()) if payload else 1
    h.check(~flip_r | ((a.o.valid == b.o.valid) & (~a.o.valid | same_payload)), "valid_indep_of_ready")
    h.cover(flip_v & ~probed & a.i.ready, "probe_valid_reach")
    h.cover(flip_r & ~probed & a.o.valid, "probe_ready_reach")
