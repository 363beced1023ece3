"""RTL of the cube-map address unit (paper, sections 2 and 4): face by the major axis, ``s, t`` by division.

Built from :class:`fxmodel.units.cube.CubeParams`; the datapath is the model's (see ``fxmodel/units/cube.py`` for the
algorithm, the OpenGL / Vulkan face table, the tie and zero-vector rules and the error bound). Fully pipelined,
one result per clock.

The two quotients ``a / ma`` and ``b / ma`` share one reciprocal of the signed major component: one
:class:`~rtl.recip.Recip` (one ROM, ``t`` small multipliers) followed by two copies of the last two stages of
:class:`~rtl.recip.Divide` (``n * mant``, then :func:`~rtl.recip.scale`: the barrel shift with half-up rounding),
built from the same :class:`~fxmodel.units.recip.DivideParams`. Two ``Divide`` instances would give the same bits
for twice the ROM and the reciprocal's multipliers. The divider's saturation and ``d = 0`` muxes are left out: ``|q|
<= 1`` is proven, and ``d = 0`` comes only with ``n = 0`` (the zero vector), where the plain path already yields ``q =
0``.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux

from fxmodel.core.rounding import Overflow
from fxmodel.units.cube import FLIP_S, FLIP_T, CubeParams

from .fixed import saturate
from .recip import scale_stages, times_reciprocal
from .unit import Pipe, UnitComponent, register

__all__ = ["Cube"]


@register(CubeParams)
class Cube(UnitComponent):
    """Cube-map face and ``(s, t)`` of a signed 3-vector.

    Ports (formats from :class:`~fxmodel.units.cube.CubeParams`)
    -----------------------------------------------------
    i_valid : Signal(1), in
    x, y, z : Signal(signed(n)), in -- ``in_fmt`` (``divide.recip.in_fmt``)
    o_valid : Signal(1), out
    face : Signal(unsigned(3)), out -- ``face_fmt``, 0..5 = +X, -X, +Y, -Y, +Z, -Z
    s, t : Signal(unsigned(fq + 2)), out -- ``st_fmt = u1.(fq+1)``, in ``[0, 1]``
    degenerate : Signal(1), out -- the zero vector (then face +Z, ``s = t = 1/2``)

    Latency: ``params.latency`` = 3 + ``divide.latency`` = ``recip.latency + 6`` (two more when ``a * mant``
    is split into partial products). Stages: magnitudes | three comparators and the face/numerator muxes | the
    reciprocal of the signed major (``recip.latency``) | ``a * mant``, ``b * mant`` | barrel shift | rounding
    (:func:`~rtl.recip.scale`) | ``(1 +- q) / 2`` and the face's sign flips (output registers).
    """

    def elaborate(self, platform):
        P = self.params
        D = P.divide
        R = D.recip
        n = P.in_fmt.width
        m = Module()
        pipe = Pipe(m, platform=platform)

        # 1: magnitudes (n-bit unsigned: |min_code| = 2**(n-1) fits)
        s0 = pipe.stage(x=self.x, y=self.y, z=self.z,
                        **{f"a{c}": Mux(v < 0, -v, v)[:n] for c, v in zip("xyz", (self.x, self.y, self.z))})
        # 2: tie rule, face and numerators
        x, y, z, ax, ay, az = s0.x, s0.y, s0.z, s0.ax, s0.ay, s0.az
        zsel = (az >= ax) & (az >= ay)
        ysel = ~zsel & (ay >= ax)
        ma = Mux(zsel, z, Mux(ysel, y, x))
        axis = Mux(zsel, 2, Mux(ysel, 1, 0))
        s1 = pipe.stage(face=Cat(ma < 0, axis[:2]), ma=ma,
                        a=Mux(zsel | ysel, x, z), b=Mux(zsel, y, Mux(ysel, z, y)))

        # one reciprocal of the signed major component for both quotients: n * mant, then the barrel shift
        # with half-up rounding, twice
        shift = (D.prod_fmt.frac_bits, D.out_fmt.frac_bits)
        s = times_reciprocal(m, pipe, R, s1.ma, 1, {"a": s1.a, "b": s1.b}, carry={"face": s1.face}, shift=shift)
        y, s = scale_stages(pipe, {"a": s.p_a, "b": s.p_b}, s.amount, R, shift,
                            carry={"dbz": s.dbz, "face": s.face})
        qs, _ = saturate(y["a"], D.out_fmt, Overflow.PROVEN)
        qt, _ = saturate(y["b"], D.out_fmt, Overflow.PROVEN)
        s = pipe.stage(qs=qs, qt=qt, dbz=s.dbz, face=s.face)
        qs, qt = s.qs, s.qt

        # s, t = (1 +- q) / 2, exact: st code = 2**fq +- q
        one = 1 << D.out_fmt.frac_bits
        flip_s = 0
        flip_t = 0
        for f in range(6):
            if FLIP_S[f]:
                flip_s = flip_s | (s.face == f)
            if FLIP_T[f]:
                flip_t = flip_t | (s.face == f)
        width = P.st_fmt.width
        self.finish(m, pipe, {
            "face": s.face,
            "s": (one + Mux(flip_s, -qs, qs))[:width],
            "t": (one + Mux(flip_t, -qt, qt))[:width],
            "degenerate": s.dbz,
        })
        return m
