"""RTL of the texture sampler (repeat/clamp, nearest/bilinear) from ``fxmodel.sampler.SamplerParams``.

The texel memory is an Amaranth ``Memory`` initialised with ``SamplerParams.words`` (the model's packed texels);
bilinear filtering reads four texels a clock through four read ports (replicated block RAM on an FPGA).
"""

from __future__ import annotations

from amaranth.hdl import Const, Module, Mux

from fxmodel.rounding import Overflow, Rounding
from fxmodel.sampler import SamplerParams
from amaranth.lib.memory import Memory

from .fixed import narrow
from .unit import Pipe, UnitComponent, register

__all__ = ["Sampler"]


@register(SamplerParams)
class Sampler(UnitComponent):
    """Texture sampler.

    Ports (formats from :class:`~fxmodel.sampler.SamplerParams`)
    -----------------------------------------------------------
    i_valid : Signal(1), in
    face : Signal(unsigned(3)), in -- only for a cube map (6 faces), 0..5
    s, t : Signal(coord_fmt), in -- e.g. ``s8.16`` (repeat) or ``u1.16`` (cube, clamp)
    o_valid : Signal(1), out
    <names> : Signal(channel format), out -- one per channel, e.g. ``du, dv`` (``s1.9``) or ``r, g, b``

    Edge rules ``repeat``, ``clamp`` and ``border`` (see ``fxmodel/sampler.py``).

    Latency: 5 for bilinear (address | read | blend x | blend y | round), 3 for nearest.
    """

    def elaborate(self, platform):
        P = self.params
        T = P.coord_fmt.frac_bits
        B = P.weight_bits
        one = 1 << T
        m = Module()
        pipe = Pipe(m)

        def edge(s):
            if P.edge == "repeat":
                return s[:T]                                           # s - floor(s): the fraction bits
            return Mux(s < 0, 0, Mux(s > one, one, s))[:T + 1]         # clamp and border

        def axis(s, size):
            se = edge(s)
            if not P.bilinear:
                i = (se * size) >> T
                return dict(i0=Mux(i > size - 1, size - 1, i) + P.border)
            x = se * (2 * size) + one * (2 * P.border - 1)              # s W - 1/2 (+ border), T + 1 fraction bits
            i0 = x >> (T + 1)
            i1 = i0 + 1
            if P.edge == "repeat":
                i0 = Mux(i0 < 0, size - 1, i0)
                i1 = Mux(i1 >= size, 0, i1)
            elif P.edge == "clamp":
                i0 = Mux(i0 < 0, 0, Mux(i0 > size - 1, size - 1, i0))
                i1 = Mux(i1 > size - 1, size - 1, i1)
            return dict(i0=i0, i1=i1, f=x[T + 1 - B:T + 1])

        ax, ay = axis(self.s, P.width), axis(self.t, P.height)
        regs = {f"x_{k}": v for k, v in ax.items()} | {f"y_{k}": v for k, v in ay.items()}
        regs["face"] = self.face if P.faces == 6 else Const(0, 3)
        s1 = pipe.stage(**regs)

        m.submodules.texels = mem = Memory(shape=P.word_bits, depth=P.depth, init=P.words)
        corners = [("x_i0", "y_i0")] + ([("x_i1", "y_i0"), ("x_i0", "y_i1"), ("x_i1", "y_i1")] if P.bilinear else [])
        data = []
        for xi, yi in corners:
            port = mem.read_port(domain="sync")
            mh, mw = P.texels.shape[1:3]                               # memory rows and columns of a face
            row = s1.face * mh + getattr(s1, yi)[:max(1, (mh - 1).bit_length())]
            m.d.comb += port.addr.eq(row * mw + getattr(s1, xi)[:max(1, (mw - 1).bit_length())])
            data.append(port.data)
        s2 = pipe.stage(fx=s1.x_f, fy=s1.y_f) if P.bilinear else pipe.stage()

        def channel(word, k):
            lo = sum(f.width for f in P.channels[:k])
            bits = word[lo:lo + P.channels[k].width]
            return bits.as_signed() if P.channels[k].signed else bits

        if not P.bilinear:
            self.finish(m, pipe, {n: channel(data[0], k) for k, n in enumerate(P.out_names)})
            return m
        terms = {}
        for k in range(len(P.channels)):
            a, b, c, d = (channel(w, k) for w in data)
            terms[f"top{k}"] = (a << B) + s2.fx * (b - a)
            terms[f"bot{k}"] = (c << B) + s2.fx * (d - c)
        terms["fy"] = s2.fy
        s3 = pipe.stage(**terms)
        s4 = pipe.stage(**{f"v{k}": (getattr(s3, f"top{k}") << B) + s3.fy * (getattr(s3, f"bot{k}")
                                                                             - getattr(s3, f"top{k}"))
                           for k in range(len(P.channels))})
        outs = {}
        for k, (n, fmt) in enumerate(zip(P.out_names, P.channels)):
            outs[n], _ = narrow(getattr(s4, f"v{k}"), 2 * B + fmt.frac_bits, fmt, Rounding.HALF_UP,
                                Overflow.PROVEN)
        self.finish(m, pipe, outs)
        return m
