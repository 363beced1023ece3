"""RTL of the perspective texture-coordinate unit ``s = U/W``, ``t = V/W`` (repeat-wrapped), from
``fxmodel.units.persp.PerspParams``: one reciprocal, two products, two barrel shifts (``rtl.recip.scale``)."""

from __future__ import annotations

from amaranth.hdl import Module, Mux

from fxmodel.units.persp import PerspParams

from .recip import scale_stages, times_reciprocal
from .unit import Pipe, UnitComponent, register

__all__ = ["Persp"]


@register(PerspParams)
class Persp(UnitComponent):
    """Perspective-correct texture coordinates.

    Ports (formats from :class:`~fxmodel.units.persp.PerspParams`)
    -------------------------------------------------------
    i_valid : Signal(1), in
    U, V : Signal(signed), in -- ``uv_fmt``
    Uc, Vc : Signal(signed), in -- only with ``color``: the color texture's numerators
    W : Signal(signed), in -- ``recip.in_fmt``
    o_valid : Signal(1), out
    s, t : Signal(unsigned(coord_bits)), out -- ``u0.coord_bits``: ``U/W`` and ``V/W`` modulo 1
    sc, tc : Signal(unsigned(coord_bits)), out -- only with ``color``: ``Uc/W``, ``Vc/W`` modulo 1
    dbz : Signal(1), out -- ``W`` was zero (``s = t = 0``)

    Latency: ``params.latency`` = ``recip.latency + 3``, two more when ``U mant`` is split into partial
    products (``recip.times_split``).
    """

    def elaborate(self, platform):
        P = self.params
        R = P.recip
        m = Module()
        pipe = Pipe(m, platform=platform)
        shift = (P.prod_frac, P.coord_bits)
        s = times_reciprocal(m, pipe, R, self.W, self.i_valid, {i: getattr(self, i) for i, _ in P.numerators},
                             shift=shift)
        y, s = scale_stages(pipe, {o: getattr(s, f"p_{i}") for i, o in P.numerators}, s.amount, R, shift,
                            carry={"dbz": s.dbz})
        outs = {}
        for _, name in P.numerators:
            outs[name] = Mux(s.dbz, 0, y[name][:P.coord_bits])            # repeat rule: the fraction bits
        outs["dbz"] = s.dbz
        self.finish(m, pipe, outs)
        return m
