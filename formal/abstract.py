"""The control abstraction of a flat unit, for the stream proofs of the pixel pipeline and of the engine.

:class:`rtl.streams.StreamUnit` wraps a flat unit (``rtl.unit.UnitComponent``: ``i_valid`` and the inputs in, the
outputs and ``o_valid`` out exactly ``latency`` cycles later, nothing can stall it). Its handshake (``i.ready``
from the credit counter ``used``, the first-word-fall-through FIFO, the bypass, ``o.valid``/``o.payload``) reads of
the unit only ``o_valid`` -- ``i_valid`` delayed by ``latency`` registers (``UnitComponent.finish`` builds that
delay line and checks the stage count against ``params.latency``) -- and passes the outputs through as data: no
control decision depends on a value the unit computes.

:class:`Abstract` is a parameter object with the unit's ports and latency whose RTL (:class:`AbstractUnit`) is that
delay line of valid bits beside a delay line of an opaque token (the low :data:`TOKEN_BITS` bits of the inputs),
which every output carries. A stream proof of ``StreamUnit(Abstract(p))`` is therefore a proof of the control of
``StreamUnit(p)``: the same wrapper code, the same ``o_valid`` timing, the same FIFO depth and widths of the
control; only the values of the outputs differ, and those are (a) data to the wrapper, (b) checked bit-exact
against the golden model by co-simulation (``cosim/``). The sideband (the sequence numbers of the proof, the
engine's pixel) rides the wrapper's own delay line, which is kept as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.hdl import Cat, Module, Value

from rtl.unit import Pipe, UnitComponent, register

__all__ = ["Abstract", "AbstractUnit", "TOKEN_BITS"]

#: Bits of the opaque token (the low bits of the inputs) that every output carries.
TOKEN_BITS = 4


@dataclass(frozen=True)
class Abstract:
    """A unit's ports and latency with the abstract RTL (:class:`AbstractUnit`)."""

    name: str
    latency: int
    inputs: tuple
    outputs: tuple

    @classmethod
    def of(cls, params) -> Abstract:
        """The abstraction of a unit's parameter object (its ports and latency)."""
        return cls(type(params).__name__, int(params.latency), tuple(params.inputs), tuple(params.outputs))


@register(Abstract)
class AbstractUnit(UnitComponent):
    """A delay line of ``latency`` valid bits (``valid1 .. valid<latency>``, as every unit's) and of an opaque
    token; each output is the token, zero-extended or truncated to its width."""

    def elaborate(self, platform):
        m = Module()
        P = self.params
        pipe = Pipe(m)
        token = Cat(*(getattr(self, p.name) for p in P.inputs))[:TOKEN_BITS]
        token = pipe.delay(token, P.latency - 1, "tok")
        pipe.depth = P.latency - 1
        outs = {}
        for p in P.outputs:
            width = len(getattr(self, p.name))
            outs[p.name] = Value.cast(token)[:width] if width < TOKEN_BITS else token
        self.finish(m, pipe, outs)
        return m
