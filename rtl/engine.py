"""RTL of the engine from the triangle (:class:`fxmodel.pipeline.engine.EngineParams`, paper Fig. 5): the scan
converter (``rtl/raster.py``) feeding the pixel pipeline (``rtl/pixel.py``) through its stream interface, optionally
with the depth test and frame buffer (``rtl/rop.py``).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.pipeline.engine import PIPELINE_IN_STAGES, EngineParams

from .fixed import shape
from .pixel import Pipeline
from .raster import Raster, record_layout
from .streams import StreamUnit, payload_layout
from .unit import register

__all__ = ["Engine"]


@register(EngineParams)
class Engine(wiring.Component):
    """The engine from the triangle: the scan converter (``rtl/raster.py``) feeding the pixel pipeline through its
    stream interface (``rtl/streams.py``), the fragment's pixel riding the pipeline's sideband.

    Ports (formats from :class:`~fxmodel.pipeline.engine.EngineParams`)
    ---------------------------------------------------------------------
    i : In(stream.Signature(record_layout(params.raster))) -- triangle records
    o : Out(stream.Signature(payload_layout(params.outputs))) -- per fragment ``x``, ``y`` (``raster.pixel_fmt``),
        ``r, g, b`` and ``flags`` (the pipeline's ``FLAG_BITS``, bit 4 an interpolated attribute saturated)
    busy : Out(1) -- the scan converter's Pixel Calculator is on a row (its clocks are the model's ``clocks``)

    Backpressure on ``o`` fills the pixel pipeline's output FIFO (its ``i.ready`` falls), which holds the scan
    converter, which stops taking records. Without stalls a fragment's color leaves ``params.latency`` cycles after it
    left the scan converter (the pixel pipeline's, and with the maps on chip its input registers,
    ``fxmodel.pipeline.engine.PIPELINE_IN_STAGES``).

    With ``params.rop`` (the engine with its depth test) ``o`` is replaced by the raster-operations unit
    (``rtl/rop.py``): the sideband also carries ``Z``, and the colors go through the depth test into the frame
    buffer; ports ``axi`` (its AXI4 manager port) or ``fb`` (its read-out, on chip), ``status`` (its sticky
    flags) and ``rop_busy`` (a fragment in the ROP not yet finished; fragments inside the pixel pipeline are not
    counted: wait its ``latency`` after the last one left the scan converter).

    ``writes`` (:class:`rtl.sampler.TexelWrites`, optional): the texel memories' write bus, driven by the design
    around the engine (the board's uploads); its signals are shared, not ports. With the maps in external memory
    it reaches the reflectance cubes' memories only.

    With ``params.textures`` the maps are read through port ``tex`` (AXI4 manager, read channels, ``tex_addr_bits``
    address bits), ``fetch_busy`` is high while a lookup or a fill is inside the texture fetch (a fragment may
    wait there for its misses far longer than the pipeline's latency), and with ``tex_flush`` the input ``tex_flush``
    empties the texel caches (``rtl.pixel_fetch.FetchPipeline``'s ``flush``: a map was loaded).
    """

    def __init__(self, params: EngineParams, writes=None, tex_addr_bits: int = 32, tex_flush: bool = False):
        self.params, self.writes = params, writes
        members = {"i": In(stream.Signature(record_layout(params.raster))), "busy": Out(1)}
        if params.textures is not None:
            from .pixel_fetch import FetchPipeline
            self._pixel = FetchPipeline(params.pipeline, params.texture_caches(), params.texture_layout(),
                                        self._side_layout(params), tex_addr_bits, writes, tex_flush)
            members |= {"tex": Out(self._pixel.signature.members["mem"].signature), "fetch_busy": Out(1)}
            if tex_flush:
                members["tex_flush"] = In(1)
        if params.rop is None:
            members["o"] = Out(stream.Signature(payload_layout(params.outputs)))
        else:
            from .rop import Rop
            self._rop = Rop(params.rop)
            port = "fb" if params.rop.on_chip else "axi"
            members |= {port: Out(self._rop.signature.members[port].signature),
                        "status": Out(self._rop.status.shape()), "rop_busy": Out(1)}
        super().__init__(members)

    @staticmethod
    def _side_layout(P: EngineParams) -> data.StructLayout:
        """The pixel pipeline's sideband: the fragment's pixel, the raster's saturation flag, ``Z`` with the ROP."""
        pf = P.raster.pixel_fmt
        fields = {"x": shape(pf), "y": shape(pf), "rsat": 1}
        if P.rop is not None:
            fields["z"] = shape(P.raster.out_fmt("Z"))
        return data.StructLayout(fields)

    def elaborate(self, platform):
        P = self.params
        m = Module()
        side = self._side_layout(P)
        m.submodules.raster = ras = Raster(P.raster)
        if P.textures is None:
            unit = None if self.writes is None else Pipeline(P.pipeline, self.writes)
            m.submodules.pipeline = pix = StreamUnit(P.pipeline, side, unit, in_stages=PIPELINE_IN_STAGES)
        else:                                               # the maps through the texture fetch, port ``tex``
            m.submodules.pipeline = pix = self._pixel
            wiring.connect(m, wiring.flipped(self.tex), pix.mem)
            m.d.comb += self.fetch_busy.eq(pix.busy)
            if hasattr(self, "tex_flush"):
                m.d.comb += pix.flush.eq(self.tex_flush)
        wiring.connect(m, wiring.flipped(self.i), ras.i)
        m.d.comb += [pix.i.valid.eq(ras.o.valid), ras.o.ready.eq(pix.i.ready), self.busy.eq(ras.busy)]
        m.d.comb += [pix.i.payload[p.name].eq(ras.o.payload[p.name]) for p in P.pipeline.inputs]
        m.d.comb += [pix.i.payload.side.x.eq(ras.o.payload.x), pix.i.payload.side.y.eq(ras.o.payload.y),
                     pix.i.payload.side.rsat.eq(ras.o.payload.flags)]
        res = pix.o.payload
        if P.rop is None:
            sink = self.o
        else:
            m.d.comb += pix.i.payload.side.z.eq(ras.o.payload.Z)
            m.submodules.rop = rop = self._rop
            port = "fb" if P.rop.on_chip else "axi"
            wiring.connect(m, wiring.flipped(getattr(self, port)), getattr(rop, port))
            m.d.comb += [self.status.eq(rop.status), self.rop_busy.eq(rop.busy), rop.i.payload.z.eq(res.side.z)]
            sink = rop.i
        out = sink.payload
        m.d.comb += [sink.valid.eq(pix.o.valid), pix.o.ready.eq(sink.ready),
                     out.x.eq(res.side.x), out.y.eq(res.side.y), out.r.eq(res.r), out.g.eq(res.g),
                     out.b.eq(res.b), out.flags.eq(Cat(res.flags, res.side.rsat))]
        return m
