"""RTL of the bump engine ``N' = N 2^-e + du A[:,0] + dv A[:,1]`` (paper section 3.2, Fig. 6), from ``BumpParams``."""

from __future__ import annotations

from amaranth.hdl import Module

from fxmodel.core.rounding import Overflow
from fxmodel.units.bump import AXES, BumpParams

from .fixed import narrow
from .unit import Pipe, UnitComponent, register

__all__ = ["Bump"]


@register(BumpParams)
class Bump(UnitComponent):
    """Bump engine: six multipliers, three three-input adders, one narrowing per component.

    Ports (formats from :class:`~fxmodel.units.bump.BumpParams`)
    -----------------------------------------------------
    i_valid : Signal(1), in
    Nx, Ny, Nz : Signal(signed), in -- ``n_fmt``
    du, dv : Signal(signed), in -- ``d_fmt``
    A00, A10, A20, A01, A11, A21 : Signal(signed), in -- ``a_fmt``: ``A 2^-e``
    Ae : Signal(unsigned), in -- ``e_fmt``, the triangle's block exponent; absent if ``exp_bits = 0``
    o_valid : Signal(1), out
    Npx, Npy, Npz : Signal(signed), out -- ``out_fmt``, rounded by ``rounding``, saturated
    saturated : Signal(1), out -- some component was clamped

    ``N 2^-e`` is an arithmetic right shift of ``N`` aligned to the sum's ``frac`` bits: exact.

    Latency: 3 (products and the shift of N | exact sum | round, saturate).
    """

    def elaborate(self, platform):
        P = self.params
        m = Module()
        pipe = Pipe(m, platform=platform)
        terms = {}
        sn = P.frac - P.n_fmt.frac_bits
        for i, c in enumerate(AXES):
            aligned = getattr(self, f"N{c}") << sn
            terms[f"n{c}"] = aligned >> self.Ae if P.exp_bits else aligned
            terms[f"pu{c}"] = self.du * getattr(self, f"A{i}0")
            terms[f"pv{c}"] = self.dv * getattr(self, f"A{i}1")
        s = pipe.stage(**terms)
        sp = P.frac - P.prod_fmt.frac_bits
        # the exact sum in a stage of its own: the sum and the narrowing in one stage were the fitted
        # pipeline's critical path on ECP5 (19 logic levels, 8.1 ns, into the reflection unit)
        s = pipe.stage(**{f"x{c}": getattr(s, f"n{c}") + ((getattr(s, f"pu{c}") + getattr(s, f"pv{c}")) << sp)
                          for c in AXES})
        outs, flags = {}, []
        for c in AXES:
            value, flag = narrow(getattr(s, f"x{c}"), P.frac, P.out_fmt, P.rounding, Overflow.SATURATE)
            outs[f"Np{c}"] = value
            flags.append(flag)
        outs["saturated"] = flags[0] | flags[1] | flags[2]
        self.finish(m, pipe, outs)
        return m
