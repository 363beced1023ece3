"""RTL of the texture sampler (repeat/clamp, nearest/bilinear) from ``fxmodel.units.sampler.SamplerParams``.

The texels are Amaranth ``Memory`` blocks initialised from the model's packed words: for bilinear filtering
four banks by texel parity with one read port each (``SamplerParams.banked``, ``bank_words``; the map stored
once), or, for ``repeat`` with an odd map size, one memory (``words``) with four read ports (replicated block
RAM on an FPGA). Nearest filtering: one memory, one port. Trilinear (MIP mapping): the even levels in one memory
and the odd levels in another (``SamplerParams.parity_words``), four read ports each, so the two bilinear lookups
of a pixel (levels ``L`` and ``L + 1``, always of different parity) are read in the same clock: one pixel per
clock (``rtl/sampler_mip.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.hdl import Const, Module, Mux, Signal, Value
from amaranth.lib.memory import Memory

from fxmodel.core.rounding import Overflow, Rounding
from fxmodel.pipeline.pixel import TEXEL_MAPS
from fxmodel.units.sampler import SamplerParams

from .bram import RegisteredMemory
from .fixed import const_mul, narrow
from .recip import product_stage
from .unit import Pipe, UnitComponent, register

__all__ = ["Sampler", "TexelPort", "TexelWrites", "texel_stages"]


@dataclass(frozen=True)
class TexelPort:
    """One sampler's view of the texel memories' write bus: ``en`` (this map selected), ``addr`` (the word's index
    in :attr:`~fxmodel.units.sampler.SamplerParams.upload_words`), ``data``; ``blank``: the memories start at zero
    instead of the scene's tables (an upload must fill them)."""

    en: Value
    addr: Value
    data: Value
    blank: bool


class TexelWrites:
    """The texel memories' write bus of a pixel pipeline (the board's uploads, ``board/upload.py``): ``en`` (a word
    this clock), ``sel`` (the map, its index in :data:`~fxmodel.pipeline.pixel.TEXEL_MAPS`), ``addr`` and ``data``
    (wide enough for every map's). Plain signals, shared by the design that drives them and the samplers that
    write (``rtl.pixel.Pipeline(..., writes=)``); no port of the units in between changes."""

    def __init__(self, pipeline, blank: bool = False):
        self.maps = [getattr(pipeline, name) for name in TEXEL_MAPS]      # the maps' parameters, by ``sel``
        self.blank = blank
        self.en = Signal(name="tw_en")
        self.sel = Signal(range(len(TEXEL_MAPS)), name="tw_sel")
        self.addr = Signal(range(max(2, *(len(s.upload_words) for s in self.maps))), name="tw_addr")
        self.data = Signal(max(s.word_bits for s in self.maps), name="tw_data")

    def port(self, name: str) -> TexelPort:
        """The bus as the sampler ``name`` sees it."""
        return TexelPort(self.en & (self.sel == TEXEL_MAPS.index(name)), self.addr, self.data, self.blank)


def texel_stages(params: SamplerParams) -> int:
    """Stages of the sampler ``params`` before its blend: the corner words of a lookup are there after them
    (indices and weights, address, memory read, and the two bank stages when banked; trilinear: both levels'
    words, ``rtl.sampler_mip.TEXEL_STAGES``); the blend and rounding take the other ``params.latency -
    texel_stages(params)``."""
    if params.trilinear:
        from .sampler_mip import TEXEL_STAGES
        return TEXEL_STAGES
    return 4 + 2 * params.banked


@register(SamplerParams)
class Sampler(UnitComponent):
    """Texture sampler.

    Ports (formats from :class:`~fxmodel.units.sampler.SamplerParams`)
    -----------------------------------------------------------
    i_valid : Signal(1), in
    face : Signal(unsigned(3)), in -- only for a cube map (6 faces), 0..5
    s, t : Signal(coord_fmt), in -- ``coord_fmt`` (in the pipeline: ``persp.coord_fmt`` for
        the bump map and the texture, ``cube.st_fmt`` for the reflectance cubes)
    o_valid : Signal(1), out
    <names> : Signal(channel format), out -- one per channel (``channels``), e.g. ``du, dv`` in ``bump.d_fmt`` or
        ``r, g, b``

    Edge rules ``repeat``, ``clamp`` and ``border`` (see ``fxmodel/units/sampler.py``).

    Latency ``params.latency``: 11 for bilinear (13 banked), 5 for nearest. Stages: edge rule and scaled position
    | indices, weights and wraps | texel address | memory read (the block RAM's output register) | [bank words
    registered | bank to corner routing, when ``params.banked``] | [texel
    differences | ``fx`` products | row blends | row difference | ``fy`` product | column blend] | rounding.
    Each stage holds at most one carry chain or one product (a product wider than one 18 x 18 block as
    registered partial products, summed in the next stage's adder), and every multiplier block has a register on each
    side (ECP5: the pixel pipeline uses most of the device's MULT18X18D, so blocks sit far from their logic and
    routing to and from them costs about 4 ns each way; ``bumpmap fpga``). Constant products (map sizes)
    are shift-and-add (:func:`~rtl.fixed.const_mul`), not multiplier blocks.
    """

    def __init__(self, params: SamplerParams, writes: TexelPort | None = None):
        self.writes = writes
        super().__init__(params)

    def elaborate(self, platform):
        m = Module()
        pipe = Pipe(m, platform=platform)
        if self.params.trilinear:
            from .sampler_mip import trilinear
            self.finish(m, pipe, trilinear(self, m, pipe))
            return m
        s2 = self.indices(pipe)
        s3, memories, weights, parity, corners = self._addresses(pipe, s2)
        data, late = self._read(m, pipe, s3, memories, weights, parity, corners)
        if not self.params.bilinear:
            self.finish(m, pipe, {n: self._channel(data[0], k) for k, n in enumerate(self.params.out_names)})
            return m
        self.finish(m, pipe, self.blend(pipe, data, late))
        return m

    def indices(self, pipe: Pipe):
        """Stages 1 and 2: the edge rule and the scaled position, then the texel indices along each axis (wraps
        and clamps) and the bilinear weights."""
        P = self.params
        T = P.coord_fmt.frac_bits
        B = P.weight_bits
        one = 1 << T

        def edge(s):
            if P.edge == "repeat":
                return s[:T]                                           # s - floor(s): the fraction bits
            return Mux(s < 0, 0, Mux(s > one, one, s))[:T + 1]         # clamp and border

        # 1: edge rule, then the scaled position: nearest s W; bilinear s W - 1/2 (+ border), T + 1 fraction bits
        def scaled(s, size):
            if not P.bilinear:
                return const_mul(edge(s), size)
            return const_mul(edge(s), 2 * size) + one * (2 * P.border - 1)

        s1 = pipe.stage(x=scaled(self.s, P.width), y=scaled(self.t, P.height),
                        face=self.face if P.faces == 6 else Const(0, 3))

        # 2: texel indices along each axis, wraps and clamps, bilinear weights
        def axis(x, size):
            if not P.bilinear:
                i = x >> T
                return dict(i0=Mux(i > size - 1, size - 1, i) + P.border)
            i0 = x >> (T + 1)
            i1 = i0 + 1
            if P.edge == "repeat":
                i0 = Mux(i0 < 0, size - 1, i0)
                i1 = Mux(i1 >= size, 0, i1)
            elif P.edge == "clamp":
                i0 = Mux(i0 < 0, 0, Mux(i0 > size - 1, size - 1, i0))
                i1 = Mux(i1 > size - 1, size - 1, i1)
            return dict(i0=i0, i1=i1, f=x[T + 1 - B:T + 1])

        ax, ay = axis(s1.x, P.width), axis(s1.y, P.height)
        return pipe.stage(face=s1.face, **{f"x_{k}": v for k, v in ax.items()},
                          **{f"y_{k}": v for k, v in ay.items()})

    def _addresses(self, pipe: Pipe, s2):
        """Stage 3: texel addresses (face H + j) W + i = face (H W) + j W + i, constant products as
        shift-and-add; banked: bank (px, py) at (face BH + j // 2) BW + i // 2 for the corner index of parity
        px (py). Returns ``(stage, memories, weights, parity, corners)``: ``memories`` a list of ``(init,
        address fields)``."""
        P = self.params
        corners = [("x_i0", "y_i0")] + ([("x_i1", "y_i0"), ("x_i0", "y_i1"), ("x_i1", "y_i1")] if P.bilinear else [])
        weights = dict(fx=s2.x_f, fy=s2.y_f) if P.bilinear else {}

        def address(face_words, row_words, row, col, rows, cols):
            base = const_mul(s2.face, face_words) if P.faces > 1 else 0
            return (base + const_mul(row[:max(1, (rows - 1).bit_length())], row_words)
                    + col[:max(1, (cols - 1).bit_length())])

        if P.banked:
            _, bh, bw = P.bank_shape
            half = {ax: [Mux(getattr(s2, f"{ax}_i0")[0] == par, getattr(s2, f"{ax}_i0"),
                             getattr(s2, f"{ax}_i1")) >> 1 for par in (0, 1)] for ax in "xy"}
            addrs = {f"a{2 * py + px}": address(bh * bw, bw, half["y"][py], half["x"][px], bh, bw)
                     for py in (0, 1) for px in (0, 1)}
            parity = {f"p_{ax}_i{i}": getattr(s2, f"{ax}_i{i}")[0] for ax in "xy" for i in (0, 1)}
            memories = [(P.bank_words[k], [f"a{k}"]) for k in range(4)]
        else:
            mh, mw = P.texels.shape[1:3]                               # memory rows and columns of a face
            addrs = {f"a{k}": address(mh * mw, mw, getattr(s2, yi), getattr(s2, xi), mh, mw)
                     for k, (xi, yi) in enumerate(corners)}
            parity = {}
            memories = [(P.words, list(addrs))]
        return pipe.stage(**addrs, **weights, **parity), memories, weights, parity, corners

    def _read(self, m, pipe: Pipe, s3, memories, weights, parity, corners):
        """Stage 4: the memory read (the read ports' data registers are this stage); banked, stages 5 and 6: the
        bank words registered as they leave the block RAMs (a bank of a large map is a cascade of blocks spread
        over the device, with a multiplexer of its own: ECP5 ran a 64-texel cube map at 78 MHz with the corner
        routing in this stage; on an ECP5 each bank is a :class:`~rtl.bram.RegisteredMemory`, its blocks' own
        output registers this stage), then each corner's word from the bank of its parities (a 4:1 multiplexer).
        Returns ``(corner words, the stage holding the weights as the texels arrive)``."""
        P = self.params
        data, mems = [], []
        blank = self.writes is not None and self.writes.blank
        for k, (words, ports) in enumerate(memories):
            init = [] if blank else words
            if P.banked:        # one read port, its word registered (stage 5): in the block RAMs' own registers
                mem = RegisteredMemory(P.word_bits, len(words), init, name=f"texels{k}")
                m.d.comb += mem.r_addr.eq(getattr(s3, ports[0]))
                data.append(mem.r_data)
            else:
                mem = Memory(shape=P.word_bits, depth=len(words), init=init)
                for a in ports:
                    port = mem.read_port(domain="sync")
                    m.d.comb += port.addr.eq(getattr(s3, a))
                    data.append(port.data)
            m.submodules[f"texels{k}" if P.banked else "texels"] = mem
            mems.append(mem)
        if self.writes is not None:
            self._writes(m, mems)
        s4 = pipe.stage(**{k: getattr(s3, k) for k in (*weights, *parity)})
        if not P.banked:
            return data, s4
        s5 = pipe.stage(fx=s4.fx, fy=s4.fy, **{k: getattr(s4, k) for k in parity})     # the words: registered

        def bank(px, py):
            return Mux(py, Mux(px, data[3], data[2]), Mux(px, data[1], data[0]))
        s6 = pipe.stage(fx=s5.fx, fy=s5.fy, **{f"w{k}": bank(getattr(s5, f"p_{xi}"), getattr(s5, f"p_{yi}"))
                                               for k, (xi, yi) in enumerate(corners)})
        return [getattr(s6, f"w{k}") for k in range(4)], s6

    def _writes(self, m, mems):
        """The uploads (``self.writes``): word ``addr`` of :attr:`SamplerParams.upload_words` goes to the memory
        whose bounds hold it, at ``addr`` less the memory's first index (a compare and a subtraction, registered
        before the write port; the bus is slow, so the write's clock does not matter to the pixels)."""
        P, w = self.params, self.writes
        data = Signal(P.word_bits, name="up_data")
        m.d.sync += data.eq(w.data[:P.word_bits])
        first = 0
        for k, (mem, words) in enumerate(zip(mems, P.memory_words)):
            en, addr = Signal(name=f"up_en{k}"), Signal(range(max(2, len(words))), name=f"up_addr{k}")
            m.d.sync += [en.eq(w.en & (w.addr >= first) & (w.addr < first + len(words))),
                         addr.eq((w.addr - first)[:len(addr)])]
            port = mem.write_port(domain="sync")
            m.d.comb += [port.en.eq(en), port.addr.eq(addr), port.data.eq(data)]
            first += len(words)

    def _channel(self, word, k: int):
        """Channel ``k``'s field of a texel word (signed if its format is)."""
        P = self.params
        lo = sum(f.width for f in P.channels[:k])
        bits = word[lo:lo + P.channels[k].width]
        return bits.as_signed() if P.channels[k].signed else bits

    def blend(self, pipe: Pipe, data, late) -> dict:
        """The exact blend of the model, top = a 2**B + fx (b - a), bot = c 2**B + fx (d - c),
        v = top 2**B + fy (bot - top), one operation per stage, then the rounding to ``out_channels`` (the texels'
        formats, or ``extra_frac`` fraction bits finer): the outputs by name. Also the back of a sampler whose corner
        words ``data`` come from the texture fetch (``rtl/pixel_fetch.py``)."""
        P = self.params
        B = P.weight_bits
        ch = range(len(P.channels))
        texel = [[self._channel(w, k) for w in data] for k in ch]
        s = pipe.stage(fx=late.fx, fy=late.fy, **{f"a{k}": texel[k][0] for k in ch},
                       **{f"c{k}": texel[k][2] for k in ch},
                       **{f"dab{k}": texel[k][1] - texel[k][0] for k in ch},
                       **{f"dcd{k}": texel[k][3] - texel[k][2] for k in ch})

        pt, c = product_stage(pipe, {f"pt{k}": (s.fx, getattr(s, f"dab{k}")) for k in ch}
                         | {f"pb{k}": (s.fx, getattr(s, f"dcd{k}")) for k in ch},
                         {"fy": s.fy} | {f"a{k}": getattr(s, f"a{k}") for k in ch}
                         | {f"c{k}": getattr(s, f"c{k}") for k in ch})
        s = pipe.stage(fy=c["fy"], **{f"top{k}": (c[f"a{k}"] << B) + pt[f"pt{k}"] for k in ch},
                       **{f"bot{k}": (c[f"c{k}"] << B) + pt[f"pb{k}"] for k in ch})
        s = pipe.stage(fy=s.fy, **{f"top{k}": getattr(s, f"top{k}") for k in ch},
                       **{f"dtb{k}": getattr(s, f"bot{k}") - getattr(s, f"top{k}") for k in ch})
        pv, c = product_stage(pipe, {f"pv{k}": (s.fy, getattr(s, f"dtb{k}")) for k in ch},
                         {f"top{k}": getattr(s, f"top{k}") for k in ch})
        s = pipe.stage(**{f"v{k}": (c[f"top{k}"] << B) + pv[f"pv{k}"] for k in ch})
        outs = {}
        for k, (n, fmt, out) in enumerate(zip(P.out_names, P.channels, P.out_channels)):
            outs[n], _ = narrow(getattr(s, f"v{k}"), 2 * B + fmt.frac_bits, out, Rounding.HALF_UP,
                                Overflow.PROVEN)
        return outs
