"""Broken variants: small wrappers that put one realistic bug around a correct design, to show that each
property can fail (the proof must fail on them with a counterexample, written as a waveform).

Each wrapper has the design's own ports and holds the design as submodule ``dut``; the property sets find the
white-box signals under ``dut/``. ``hazard_off`` needs no wrapper: ``RopParams(hazard=False)`` exists for it.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring

__all__ = ["Wrap", "PayloadWhileStalled", "ReadyFromValid", "DroppedToken", "ValidWaitsForReady", "WlastEarly",
           "ArChangesWhileStalled", "MemArChangesWhileStalled", "RlastEarly", "ArlenShort", "ExtraBurst",
           "texfetch_wrong_owner"]


class Wrap(wiring.Component):
    """Passes every port of ``inner`` through, except what :meth:`change` drives itself."""

    #: port members (``(interface, member)``) that :meth:`change` drives
    CHANGED: tuple = ()

    def __init__(self, inner):
        self.inner = inner
        super().__init__(dict(inner.signature.members))

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut = self.inner
        for name, member in self.signature.members.items():
            outer, inner = getattr(self, name), getattr(self.inner, name)
            if member.is_port:
                pairs = [((), outer, inner, member.flow)]
            else:
                # an In member's signature is already flipped: each sub-member's flow is the component's view
                pairs = [((name, sub), getattr(outer, sub), getattr(inner, sub), m2.flow)
                         for sub, m2 in member.signature.members.items()]
            for key, o, i, flow in pairs:
                if key in self.CHANGED:
                    continue
                m.d.comb += (o.eq(i) if flow == wiring.Out else i.eq(o))
        self.change(m)
        return m

    def change(self, m: Module):
        raise NotImplementedError


class PayloadWhileStalled(Wrap):
    """``o.payload``'s lowest bit flips in the cycle after a stall (an output register reloaded while held)."""
    CHANGED = (("o", "payload"),)

    def change(self, m):
        stalled = Signal()
        m.d.sync += stalled.eq(self.o.valid & ~self.o.ready)
        m.d.comb += self.o.payload.eq(self.inner.o.payload.as_value() ^ stalled)


class ReadyFromValid(Wrap):
    """``i.ready`` combinationally from ``i.valid`` (the stream version promises registers only)."""
    CHANGED = (("i", "ready"),)

    def change(self, m):
        m.d.comb += self.i.ready.eq(self.inner.i.ready & self.i.valid)


class DroppedToken(Wrap):
    """The third result is taken from the unit and never offered (a token lost)."""
    CHANGED = (("o", "valid"), ("o", "ready"))

    def change(self, m):
        seen = Signal(2)
        drop = self.inner.o.valid & (seen == 2)
        with m.If(self.inner.o.valid & self.inner.o.ready & (seen != 3)):
            m.d.sync += seen.eq(seen + 1)
        m.d.comb += [self.o.valid.eq(self.inner.o.valid & ~drop), self.inner.o.ready.eq(self.o.ready | drop)]


class ValidWaitsForReady(Wrap):
    """``o.valid`` only while ``o.ready`` (rule 3 broken: a consumer that waits for valid deadlocks)."""
    CHANGED = (("o", "valid"),)

    def change(self, m):
        m.d.comb += self.o.valid.eq(self.inner.o.valid & self.o.ready)


class WlastEarly(Wrap):
    """Every write announced as a 2-beat burst (``AWLEN = 1``) while its one beat carries ``WLAST``: the last
    beat flagged one beat early."""
    CHANGED = (("axi", "awlen"),)

    def change(self, m):
        m.d.comb += self.axi.awlen.eq(1)


class ArChangesWhileStalled(Wrap):
    """``ARADDR`` moves to the next word while ``AR`` waits for ready."""
    PORT = "axi"
    CHANGED = (("axi", "araddr"),)

    def change(self, m):
        outer, inner = getattr(self, self.PORT), getattr(self.inner, self.PORT)
        stalled = Signal()
        m.d.sync += stalled.eq(outer.arvalid & ~outer.arready)
        m.d.comb += outer.araddr.eq(inner.araddr + (stalled << 3))


class MemArChangesWhileStalled(ArChangesWhileStalled):
    """As :class:`ArChangesWhileStalled`, on a port named ``mem`` (the texel caches)."""
    PORT = "mem"
    CHANGED = (("mem", "araddr"),)


class RlastEarly(Wrap):
    """The manager takes ``RLAST`` one beat early: it sees ``RLAST`` on the next-to-last beat of each burst of
    ``ARLEN + 1`` beats (a beat counter off by one), ends the burst there and leaves the last beat owed."""
    CHANGED = (("mem", "rlast"),)

    def change(self, m):
        a = self.mem
        beat = Signal(9)
        with m.If(a.rvalid & a.rready):
            m.d.sync += beat.eq(Mux(a.rlast, 0, beat + 1))
        m.d.comb += self.inner.mem.rlast.eq(a.rlast | (beat + 2 == self.inner.mem.arlen + 1))


class ArlenShort(Wrap):
    """``ARLEN`` one less than the line's beats (the burst length off by one)."""
    CHANGED = (("mem", "arlen"),)

    def change(self, m):
        m.d.comb += self.mem.arlen.eq(self.inner.mem.arlen - 1)


class ExtraBurst(Wrap):
    """A read manager that, with its whole budget (``misses``) outstanding, issues one more ``AR`` (a copy of its
    last burst), as a cache would that compared its owed lines against ``misses`` one too late. It starts the extra
    burst in a clock in which no burst ends, so that its ``AR`` makes ``misses + 1`` outstanding at once (and
    ``ar_outstanding`` fails in the next clock, whatever the solver picks)."""
    CHANGED = (("mem", "arvalid"), ("mem", "arready"), ("mem", "araddr"))

    def change(self, m):
        outer, inner = self.mem, self.inner.mem
        pend, sent, held, addr = Signal(8), Signal(), Signal(), Signal.like(inner.araddr)
        extra = Signal()
        ends = outer.rvalid & outer.rready & outer.rlast
        m.d.comb += extra.eq(((pend == self.inner.params.misses) & ~sent & ~ends) | held)
        m.d.sync += held.eq(extra & ~outer.arready)
        fire = outer.arvalid & outer.arready
        m.d.sync += pend.eq(pend + fire - ends)
        with m.If(fire):
            m.d.sync += [addr.eq(outer.araddr), sent.eq(sent | extra)]
        m.d.comb += [outer.arvalid.eq(inner.arvalid | extra), outer.araddr.eq(Mux(extra, addr, inner.araddr)),
                     inner.arready.eq(outer.arready & ~extra)]


def texfetch_wrong_owner(caches, layout, **kw):
    """A :class:`rtl.texfetch.TexFetch` whose owner FIFO records the other cache for each burst (the ``R`` beats
    of a burst routed to the cache that did not ask for them)."""
    from rtl.texfetch import TexFetch

    class WrongOwner(TexFetch):
        def _read_port(self, m, caches):
            super()._read_port(m, caches)
            owners = m.submodules.owners
            grant = Signal()
            m.d.comb += grant.eq(caches[1].mem.arvalid & caches[1].mem.arready)
            m.d.comb += owners.w_data.eq(~grant)

    return WrongOwner(caches, layout, **kw)
