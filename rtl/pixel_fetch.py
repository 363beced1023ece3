"""The pixel pipeline with its bump map and color texture in external memory (paper, sections 3.2 and 4; the
maps behind a texel cache each, ``docs/texcache.md``): the flat pipeline of ``rtl/pixel.py`` split around the
texture fetch (``rtl/texfetch.py``), three stream units in a row:

- **front** (:class:`FrontParams`): the perspective unit and both samplers' first two stages (edge rule, texel
  indices and bilinear weights: :meth:`rtl.sampler.Sampler.indices`); out: each map's footprint and weights, and
  the fragment's other inputs (``N``, ``E``, ``A``) and the ``W = 0`` flag;
- **fetch**: :class:`~rtl.texfetch.TexFetch`, both maps' decoupled caches on one AXI4 read port; the request is
  each map's footprint on its surface of :meth:`~fxmodel.pipeline.engine.EngineParams.texture_layout`, the
  lookup FIFOs carry the rest of the fragment (weights, inputs, flag and the caller's sideband);
- **back** (:class:`BackParams`): both samplers' blends (:meth:`rtl.sampler.Sampler.blend`) on the four corner
  texels the fetch returns, then bump, reflection, cube addresses and lookups and shading, the schedule of
  :attr:`~fxmodel.pipeline.pixel.PipelineParams.stage_latency` shifted (:func:`rtl.pixel.shade_half`).

Each part is a free-running flat pipeline behind :class:`~rtl.streams.StreamUnit`'s credit FIFO, so a miss holds
the fragments through the stream handshakes only. The texels are the maps' words, so the pixels are the on-chip
pipeline's bit for bit; the memory traffic is each cache's model.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from types import SimpleNamespace

from amaranth.hdl import Module, Shape
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, require
from fxmodel.pipeline.pixel import PipelineParams
from fxmodel.units.texcache import Layout

from .fixed import shape
from .pixel import add_unit, shade_half
from .sampler import Sampler, texel_stages
from .streams import StreamUnit, input_layout, output_layout
from .texcache_decoupled import request_layout
from .texfetch import MAPS, TexFetch
from .unit import Pipe, UnitComponent, register

__all__ = ["FrontParams", "BackParams", "FetchPipeline", "CORNERS"]

#: Prefix of the fragment inputs the front hands on (an output may not share an input's name).
CARRIED = "c_"
#: Request fields of a map's footprint (``rtl.texcache_decoupled.request_layout``) the front computes.
CORNERS = ("x0", "x1", "y0", "y1")


def _rest(P: PipelineParams) -> tuple:
    """The fragment's inputs the back needs (``N``, ``E``, ``A``, the block exponent): all but the perspective
    unit's."""
    skip = {p.name for p in P.persp.inputs}
    return tuple(p for p in P.inputs if p.name not in skip)


def _weights(P: PipelineParams, name: str) -> tuple:
    """The bilinear weights of a map's lookup (none for nearest), ``weight_bits`` unsigned each."""
    smp = getattr(P, name)
    if not smp.bilinear:
        return ()
    return tuple(Port(f"{name}_f{a}", Fmt(False, smp.weight_bits, 0), "bilinear weight") for a in "xy")


@dataclass(frozen=True)
class FrontParams:
    """The front of the split pipeline: ``pipeline``'s inputs in; each map's footprint (:data:`CORNERS`, in the
    widths of ``request_layout(layout)``), its weights, the fragment's other inputs and the ``W = 0`` flag out."""

    NAME = "pixel_front"
    pipeline: PipelineParams
    layout: Layout

    def __post_init__(self):
        P = self.pipeline
        require(P.lod is None, "pipeline.lod", P.lod, "must be None with the maps in external memory (no MIP "
                "levels in the layout yet)")
        for name in MAPS:
            texel_stages(getattr(P, name))                  # trilinear refused there

    @property
    def inputs(self) -> tuple:
        return self.pipeline.inputs

    @cached_property
    def outputs(self) -> tuple:
        req = request_layout(self.layout)
        ports = tuple(Port(f"{m}_{c}", Fmt(False, Shape.cast(req[c].shape).width, 0), "texel index") for m in MAPS
                      for c in CORNERS)
        ports += tuple(p for m in MAPS for p in _weights(self.pipeline, m))
        return ports + tuple(Port(f"{CARRIED}{p.name}", p.fmt, p.doc) for p in _rest(self.pipeline)) + (
            Port("dbz", Fmt(False, 1, 0), "W = 0"),)

    @property
    def index_stages(self) -> int:
        """The samplers' stages in the front: edge rule and scaled position, indices and weights."""
        return 2

    @property
    def latency(self) -> int:
        return self.pipeline.persp.latency + self.index_stages + 1       # + the output register


@dataclass(frozen=True)
class BackParams:
    """The back of the split pipeline: per map its four corner texels (``{map}_texels``, corner 0 low, one
    ``word_bits`` word each) and weights, the fragment's other inputs and ``dbz`` in; ``pipeline``'s outputs."""

    NAME = "pixel_back"
    pipeline: PipelineParams

    @cached_property
    def inputs(self) -> tuple:
        P = self.pipeline
        ports = tuple(Port(f"{m}_texels", Fmt(False, 4 * getattr(P, m).word_bits, 0), "four corner texels")
                      for m in MAPS)
        ports += tuple(p for m in MAPS for p in _weights(P, m))
        return ports + _rest(P) + (Port("dbz", Fmt(False, 1, 0), "W = 0"),)

    @property
    def outputs(self) -> tuple:
        return self.pipeline.outputs

    def blend_latency(self, name: str) -> int:
        """Cycles from a map's texels to its blended channels: the sampler's stages after its texels arrive."""
        smp = getattr(self.pipeline, name)
        return smp.latency - texel_stages(smp)

    @cached_property
    def schedule(self) -> dict:
        """The pipeline's :attr:`~fxmodel.pipeline.pixel.PipelineParams.stage_latency` from the samplers' results
        on, shifted so that the later blend is ready at ``samples``."""
        T = self.pipeline.stage_latency
        shift = max(self.blend_latency(m) for m in MAPS) - T["samples"]
        return {k: v + shift for k, v in T.items() if k not in ("persp", "lod")}

    @property
    def latency(self) -> int:
        return self.schedule["out"]


def _sampler(params):
    """A :class:`~rtl.sampler.Sampler` used for its stage builders only: its ports are plain signals of the caller's
    module, the component itself is never elaborated (so never reported unused)."""
    smp = Sampler(params)
    smp._MustUse__used = True
    return smp


@register(FrontParams)
class Front(UnitComponent):
    """The front (:class:`FrontParams`), flat ports as every unit's (``rtl/unit.py``)."""

    def elaborate(self, platform):
        F = self.params
        P = F.pipeline
        m = Module()
        pipe = Pipe(m)
        persp = add_unit(m, "persp", P.persp, self.i_valid, **{p.name: getattr(self, p.name) for p in P.persp.inputs})
        outs = {}
        for name, (s, t) in zip(MAPS, ((persp.s, persp.t), (persp.sc, persp.tc))):
            smp = _sampler(getattr(P, name))
            m.d.comb += [smp.s.eq(s), smp.t.eq(t)]
            sp = Pipe(m, f"{name}_")
            idx = smp.indices(sp)
            assert sp.depth == F.index_stages
            x1, y1 = (idx.x_i1, idx.y_i1) if smp.params.bilinear else (idx.x_i0, idx.y_i0)
            # the edge rule leaves every index in [0, size) (border: [0, size + 1]): the request's unsigned
            # width holds it, the truncation is exact
            outs |= {f"{name}_x0": idx.x_i0, f"{name}_x1": x1, f"{name}_y0": idx.y_i0, f"{name}_y1": y1}
            if smp.params.bilinear:
                outs |= {f"{name}_fx": idx.x_f, f"{name}_fy": idx.y_f}
        stages = P.persp.latency + F.index_stages          # the indices and weights are ready then
        outs |= {f"{CARRIED}{p.name}": pipe.delay(getattr(self, p.name), stages, p.name) for p in _rest(P)}
        outs["dbz"] = pipe.delay(persp.dbz, F.index_stages, "dbz")
        pipe.depth = stages
        self.finish(m, pipe, outs)
        return m


@register(BackParams)
class Back(UnitComponent):
    """The back (:class:`BackParams`), flat ports as every unit's (``rtl/unit.py``)."""

    def elaborate(self, platform):
        B = self.params
        P = B.pipeline
        T = B.schedule
        m = Module()
        pipe = Pipe(m)

        def late(value, now, when, name):
            return pipe.delay(value, when - now, name)

        def unit(name, params, valid, **inputs):
            return add_unit(m, name, params, valid, **inputs)

        res = {}
        for name in MAPS:
            smp = _sampler(getattr(P, name))
            sp = Pipe(m, f"{name}_")
            words = getattr(self, f"{name}_texels")
            wb = smp.params.word_bits
            corners = [words[k * wb:(k + 1) * wb] for k in range(4)]
            if smp.params.bilinear:
                w = SimpleNamespace(fx=getattr(self, f"{name}_fx"), fy=getattr(self, f"{name}_fy"))
                outs = smp.blend(sp, corners, w)
            else:
                outs = {n: smp._channel(corners[0], k) for k, n in enumerate(smp.params.out_names)}
            r = sp.stage(**outs)                            # the sampler's output register
            assert sp.depth == B.blend_latency(name)
            res[name] = (r, sp.depth)
        rest = shade_half(m, pipe, unit, late, P, T, self, (self.i_valid, 0), res[MAPS[0]], res[MAPS[1]],
                          (self.dbz, 0))
        self.finish(m, pipe, rest)
        return m


class FetchPipeline(wiring.Component):
    """The pixel pipeline with both maps read through the texture fetch (module docstring), with stream ports.

    Parameters
    ----------
    pipeline : PipelineParams
    caches : dict
        Per map (:data:`~rtl.texfetch.MAPS`) its :class:`~fxmodel.units.texcache.TexCacheParams`
        (:meth:`~fxmodel.pipeline.engine.EngineParams.texture_caches`).
    layout : Layout
        The maps in memory (:meth:`~fxmodel.pipeline.engine.EngineParams.texture_layout`: surface ``k`` is map
        ``MAPS[k]``).
    side : ShapeLike, optional
        Sideband carried with each fragment, as :class:`~rtl.streams.StreamUnit`'s.
    addr_bits : int

    Ports: ``i``, ``o`` as ``StreamUnit(pipeline, side)``'s; ``mem`` (AXI4 manager, read channels); ``busy`` (a
    lookup or fill inside the fetch).
    """

    def __init__(self, pipeline: PipelineParams, caches: dict, layout: Layout, side=None, addr_bits: int = 32):
        require([k for k, _, _ in layout.surfaces] == [(m, 0) for m in MAPS], "layout", layout.surfaces,
                f"must hold the maps {MAPS} at level 0, in that order")
        self.front = FrontParams(pipeline, layout)
        self.back = BackParams(pipeline)
        self.pipeline, self.side = pipeline, side
        fields = {p.name: shape(p.fmt) for p in self.back.inputs if not p.name.endswith("_texels")}
        if side is not None:
            fields["side"] = side
        self.carry = data.StructLayout(fields)
        self.fetch = TexFetch(caches, layout, self.carry.size, addr_bits)
        super().__init__({"i": In(stream.Signature(input_layout(pipeline, side))),
                          "o": Out(stream.Signature(output_layout(pipeline, side))),
                          "mem": Out(self.fetch.signature.members["mem"].signature), "busy": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.front = front = StreamUnit(self.front, self.side)
        m.submodules.fetch = fetch = self.fetch
        m.submodules.back = back = StreamUnit(self.back, self.side)
        wiring.connect(m, wiring.flipped(self.i), front.i)
        wiring.connect(m, back.o, wiring.flipped(self.o))
        wiring.connect(m, wiring.flipped(self.mem), fetch.mem)
        m.d.comb += self.busy.eq(fetch.busy)
        fo, fi = front.o.payload, fetch.i.payload
        m.d.comb += [fetch.i.valid.eq(front.o.valid), front.o.ready.eq(fetch.i.ready)]
        for k, name in enumerate(MAPS):
            req = getattr(fi, name)
            m.d.comb += req.surface.eq(k)
            m.d.comb += [getattr(req, c).eq(getattr(fo, f"{name}_{c}")) for c in CORNERS]
        carried = data.View(self.carry, fi.side)
        rest = {p.name for p in _rest(self.pipeline)}
        m.d.comb += [getattr(carried, f).eq(getattr(fo, f"{CARRIED}{f}" if f in rest else f))
                     for f in self.carry.members]
        out, bi = fetch.o.payload, back.i.payload
        m.d.comb += [back.i.valid.eq(fetch.o.valid), fetch.o.ready.eq(back.i.ready)]
        m.d.comb += [getattr(bi, f"{name}_texels").eq(getattr(out, name)) for name in MAPS]
        carried = data.View(self.carry, out.side)
        m.d.comb += [getattr(bi, f).eq(getattr(carried, f)) for f in self.carry.members]
        return m
