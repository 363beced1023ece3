"""RTL of the shading unit ``o = b D + S`` per channel, saturated to a byte (``fxmodel.units.shade.ShadeParams``)."""

from __future__ import annotations

from amaranth.hdl import Module

from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.units.shade import RGB, ShadeParams

from .fixed import narrow
from .unit import Pipe, UnitComponent, register

__all__ = ["Shade"]


@register(ShadeParams)
class Shade(UnitComponent):
    """Shading.

    Ports (formats from :class:`~fxmodel.units.shade.ShadeParams`)
    -------------------------------------------------------
    i_valid : Signal(1), in
    tr, tg, tb : Signal(unsigned(8)), in -- ``tex_fmt``
    dr, dg, db : Signal(unsigned), in -- ``diffuse_fmt``
    sr, sg, sb : Signal(unsigned), in -- ``specular_fmt``
    o_valid : Signal(1), out
    r, g, b : Signal(unsigned(8)), out -- bytes, rounded half-up, saturated
    saturated : Signal(1), out

    Latency: 2.
    """

    def elaborate(self, platform):
        P = self.params
        m = Module()
        pipe = Pipe(m, platform=platform)
        a = P.frac - P.tex_fmt.frac_bits - P.diffuse_fmt.frac_bits
        b = P.frac - P.specular_fmt.frac_bits
        s = pipe.stage(**{f"p{c}": getattr(self, f"t{c}") * getattr(self, f"d{c}") for c in RGB},
                       **{f"s{c}": getattr(self, f"s{c}") for c in RGB})
        outs, flags = {}, []
        for c in RGB:
            exact = (getattr(s, f"p{c}") << a) + (getattr(s, f"s{c}") << b)
            outs[c], flag = narrow(exact, P.frac, P.out_fmt, Rounding.HALF_UP, Overflow.SATURATE)
            flags.append(flag)
        outs["saturated"] = flags[0] | flags[1] | flags[2]
        self.finish(m, pipe, outs)
        return m
