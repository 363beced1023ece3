"""Property building blocks in Amaranth (``Assert``, ``Assume``, ``Cover``): past values, counters, the four
stream rules of ``amaranth.lib.stream``, and the harness a property set is written in.

Amaranth 0.5 has no ``Past``/``Stable``: :meth:`Harness.past` is a register written every cycle, and
:attr:`Harness.started` is low in the first cycle (no past yet). Each check is ``assert`` on what the design
drives and ``assume`` on what its environment drives, so one rule serves both sides of a port.

The stream rules (``amaranth.lib.stream``, also AXI4-Stream): (1) a transfer happens in a cycle with ``valid``
and ``ready``; (2) once ``valid`` is high, ``valid`` and ``payload`` hold until the transfer; (3) ``valid`` never
waits for ``ready`` (it does not depend on ``ready``); (4) ``ready`` may change at any time. Rule 1 is the
definition the counters use; rule 2 is :meth:`Harness.stream_hold`; rule 3 is checked two ways: a bounded
liveness count (a design that has a result offers it within its latency, whatever ``ready`` does) and the
independence miter of :mod:`formal.miter`; rule 4 means nothing is assumed about ``ready``.
"""

from __future__ import annotations

from contextlib import contextmanager

from amaranth.hdl import Assert, Assume, ClockDomain, Cover, Module, Signal, Value

__all__ = ["Harness", "bits_for", "KINDS"]

#: What a harness checks: see :class:`Harness`.
KINDS = ("proof", "bounded", "cover")


def bits_for(n: int) -> int:
    """Bits of an unsigned counter that holds ``0..n``."""
    return max(1, int(n).bit_length())


class Harness:
    """A property set's top module: free inputs (ports of the RTLIL top, which the solver chooses every cycle),
    past values and checks.

    Parameters
    ----------
    kind : str
        ``proof``: the assertions not marked ``bounded``, for k-induction (or a bounded check of a broken
        variant); ``bounded``: only those marked ``bounded`` (k-induction cannot prove them), checked to a depth;
        ``cover``: only the ``Cover`` statements (reachability), without assertions, so the solver sees only
        their cone. Assumptions are in every kind.
    """

    def __init__(self, kind: str = "proof"):
        if kind not in KINDS:
            raise ValueError(f"kind={kind!r}: must be one of {', '.join(KINDS)}")
        self.kind = kind
        self.m = Module()
        # one clock, no reset: registers start from their initial values (the solver's first step)
        self.m.domains.sync = sync = ClockDomain("sync", reset_less=True)
        self.ports: list[Signal] = [sync.clk]
        self.started = Signal(name="f_started")
        self.m.d.sync += self.started.eq(1)
        self.prefix = ""               # prepended to the names of checks and covers (see :meth:`scope`)
        self.covers_on = True
        self.asserted: list[str] = []
        self.assumed: list[str] = []
        self.covered: list[str] = []

    @contextmanager
    def scope(self, prefix: str, covers: bool = True):
        """Checks and covers added inside are named ``prefix + name`` (one design's properties beside another's
        in a composition); ``covers=False`` leaves the covers added inside out."""
        outer = self.prefix, self.covers_on
        self.prefix, self.covers_on = self.prefix + prefix, self.covers_on and covers
        try:
            yield self
        finally:
            self.prefix, self.covers_on = outer

    def free(self, shape, name: str) -> Signal:
        """A free input (an RTLIL port of the top; of a layout's width for a layout)."""
        sig = Signal(shape, name=name)
        if not isinstance(sig, Signal):                 # a View of a layout: its signal is the port
            sig = sig.as_value()
        self.ports.append(sig)
        return sig

    def past(self, value, name: str) -> Signal:
        """``value`` one cycle ago (its register's initial value in the first cycle: guard with ``started``)."""
        value = Value.cast(value)
        reg = Signal(value.shape(), name=f"f_past_{name}")
        self.m.d.sync += reg.eq(value)
        return reg

    def pasts(self, value, n: int, name: str) -> list:
        """``value`` 1, 2, ..., ``n`` cycles ago (a chain of :meth:`past` registers ``{name}1`` ... ``{name}{n}``)."""
        out = []
        for k in range(1, n + 1):
            value = self.past(value, f"{name}{k}")
            out.append(value)
        return out

    def counter(self, event, width: int, name: str) -> Signal:
        """Counts cycles with ``event`` (wraps modulo ``2**width``)."""
        cnt = Signal(width, name=f"f_n_{name}")
        self.m.d.sync += cnt.eq(cnt + event)
        return cnt

    def check(self, cond, name: str, *, assume: bool = False, bounded: bool = False):
        """``Assert(cond)`` (or ``Assume``), named ``name`` in the solver's report; a ``bounded`` assertion is in
        the bounded run only, any other in the proof only."""
        if not assume and (self.kind == "cover" or bounded != (self.kind == "bounded")):
            return
        name = self.prefix + name
        (self.assumed if assume else self.asserted).append(name)
        self.m.d.comb += (Assume if assume else Assert)(cond, name)

    def cover(self, cond, name: str):
        if self.kind != "cover" or not self.covers_on:
            return
        name = self.prefix + name
        self.covered.append(name)
        self.m.d.comb += Cover(cond, name)

    def stream_hold(self, valid, ready, payload, name: str, *, assume: bool = False):
        """Rule 2 on one stream: after a cycle with ``valid & ~ready``, ``valid`` is still high and ``payload``
        unchanged. ``assume``: the stream's source is the environment."""
        stalled = self.started & self.past(valid & ~ready, f"{name}_stall")
        prev = self.past(payload, f"{name}_payload")
        self.check(~stalled | (valid & (Value.cast(payload) == prev)), f"{name}_hold", assume=assume)

    def stall_bound(self, valid, ready, limit: int, name: str, *, assume: bool = True, counter: str = "stall",
                    check: str = "stall_bound"):
        """``valid & ~ready`` for at most ``limit`` cycles in a row (a bounded stall: assumed of a memory). The
        counter is named ``f_<counter>_<name>`` and the property ``<name>_<check>``; returns the counter."""
        run = Signal(bits_for(limit + 1), name=f"f_{counter}_{name}")
        with self.m.If(valid & ~ready):
            with self.m.If(run <= limit):
                self.m.d.sync += run.eq(run + 1)
        with self.m.Else():
            self.m.d.sync += run.eq(0)
        self.check(~(valid & ~ready) | (run < limit), f"{name}_{check}", assume=assume)
        return run
