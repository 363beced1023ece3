"""RTL of the divider ``q = n / d`` (paper section 4.1), built from ``fxmodel.units.divide``'s parameters: the
reciprocal unit's datapath (``rtl/recip.py``), ``n * mant``, a barrel shift, rounding and saturation, stage for stage
as the model (``fxmodel/units/divide.py``). Fully pipelined, one result per clock.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux

from fxmodel.core.rounding import Overflow
from fxmodel.units.divide import DivideParams

from .fixed import saturate
from .recip import scale_stages, times_reciprocal
from .unit import Pipe, UnitComponent, register

__all__ = ["Divide"]


@register(DivideParams)
class Divide(UnitComponent):
    """Divider ``q = n / d`` on the reciprocal unit.

    Ports (formats from :class:`~fxmodel.units.divide.DivideParams`)
    --------------------------------------------------------
    i_valid : Signal(1), in
    n : Signal(signed), in -- ``num_fmt``
    d : Signal(signed), in -- ``recip.in_fmt``
    o_valid : Signal(1), out
    q : Signal(signed), out -- ``out_fmt``, rounded half-up, saturated
    dbz : Signal(1), out -- ``d`` was zero
    ovf : Signal(1), out -- ``q`` saturated

    Latency: ``params.latency`` = ``recip.latency + 3``: the reciprocal, ``n * mant`` (three stages when split
    into partial products), the shift, then round and saturate.
    """

    def elaborate(self, platform):
        P = self.params
        R = P.recip
        m = Module()
        pipe = Pipe(m, platform=platform)
        shift = (P.prod_fmt.frac_bits, P.out_fmt.frac_bits)
        s = times_reciprocal(m, pipe, R, self.d, self.i_valid, {"n": self.n}, shift=shift)
        y, s = scale_stages(pipe, {"q": s.p_n}, s.amount, R, shift,
                            carry={"dbz": s.dbz, "n": s.n})
        q, ovf = saturate(y["q"], P.out_fmt, Overflow.SATURATE)
        fmt = P.out_fmt
        q_dbz = Mux(s.n > 0, fmt.max_code, Mux(s.n < 0, fmt.min_code, 0))
        self.finish(m, pipe, {
            "q": Mux(s.dbz, q_dbz, q),
            "dbz": s.dbz,
            "ovf": Mux(s.dbz, s.n != 0, ovf),
        })
        return m
