"""The pixel pipeline with its bump map and color texture in external memory (paper, sections 3.2 and 4; the
maps behind a texel cache each, ``docs/texcache.md``): the flat pipeline of ``rtl/pixel.py`` split around the
texture fetch (``rtl/texfetch.py``), three stream units in a row:

- **front** (:class:`FrontParams`): the perspective unit and both samplers' first two stages (edge rule, texel
  indices and bilinear weights: :meth:`rtl.sampler.Sampler.indices`); with MIP mapping also the LOD unit
  (``rtl/lod.py``) and the trilinear color sampler's first three (:func:`rtl.sampler_mip.level_indices`: the level,
  then per level parity its footprint and weights); out: each cache's footprint (a level cache's also with its
  surface and ``skip`` bit) and weights, and the fragment's other inputs (``N``, ``E``, ``A``) and the ``W = 0``
  flag;
- **fetch**: :class:`~rtl.texfetch.TexFetch`, the decoupled caches (one per map, a trilinear map's even and odd
  levels apart) on one AXI4 read port; the request is each cache's footprint on its surface of
  :meth:`~fxmodel.pipeline.engine.EngineParams.texture_layout`, the lookup FIFOs carry the rest of the fragment
  (weights, inputs, flag and the caller's sideband);
- **back** (:class:`BackParams`): both samplers' blends (:meth:`rtl.sampler.Sampler.blend`; trilinear:
  :func:`rtl.sampler_mip.blends` on both level caches' texels) on the four corner texels the fetch returns
  (registered as they arrive, :data:`BACK_IN_STAGES`), then
  bump, reflection, cube addresses and lookups and shading, the schedule of
  :attr:`~fxmodel.pipeline.pixel.PipelineParams.stage_latency` shifted (:func:`rtl.pixel.shade_half`).

Each part is a free-running flat pipeline behind :class:`~rtl.streams.StreamUnit`'s credit FIFO, so a miss holds
the fragments through the stream handshakes only. The texels are the maps' words, so the pixels are the on-chip
pipeline's bit for bit; the memory traffic is each cache's model.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from types import SimpleNamespace

from amaranth.hdl import Module, ResetInserter, Shape
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, require
from fxmodel.pipeline.engine import texture_ports
from fxmodel.pipeline.pixel import LOD_INPUTS, PipelineParams
from fxmodel.units.texcache import Layout

from .fixed import shape
from .pixel import add_lod, add_unit, shade_half, written_units
from .sampler import Sampler, texel_stages
from .sampler_mip import blends, level_indices
from .streams import StreamUnit, input_layout, output_layout
from .texcache_decoupled import request_layout
from .texfetch import MAPS, TexFetch
from .unit import Pipe, UnitComponent, register

__all__ = ["FrontParams", "BackParams", "FetchPipeline", "CORNERS", "BACK_IN_STAGES"]

#: Prefix of the fragment inputs the front hands on (an output may not share an input's name).
CARRIED = "c_"
#: Input registers of the back (:class:`~rtl.streams.StreamUnit`'s ``in_stages``): the corner words leave the
#: texel caches' banks (block RAM words, unregistered, through the bank multiplexer), and the routed Berlin wall
#: engine's slowest paths ran from them through the blends' texel differences into their multipliers
#: (``docs/fpga/placement-texcache.json``).
BACK_IN_STAGES = 1
#: Request fields of a map's footprint (``rtl.texcache_decoupled.request_layout``) the front computes.
CORNERS = ("x0", "x1", "y0", "y1")


def _rest(P: PipelineParams) -> tuple:
    """The fragment's inputs the back needs (``N``, ``E``, ``A``, the block exponent): all but the perspective
    unit's and the LOD unit's."""
    skip = {p.name for p in P.persp.inputs} | set(LOD_INPUTS)
    return tuple(p for p in P.inputs if p.name not in skip)


def _weights(P: PipelineParams, name: str) -> tuple:
    """The weights of a map's lookup: none for nearest, ``weight_bits`` unsigned each; trilinear: each level
    cache's bilinear weights (``{map}_fx0 .. {map}_fy1``, level parity last), the level blend weight ``g`` and
    the parity ``odd`` of level ``L`` (which cache holds it)."""
    smp = getattr(P, name)
    if not smp.bilinear:
        return ()
    w = Fmt(False, smp.weight_bits, 0)
    if not smp.trilinear:
        return tuple(Port(f"{name}_f{a}", w, "bilinear weight") for a in "xy")
    return (tuple(Port(f"{name}_f{a}{p}", w, "bilinear weight at the level of parity p") for p in (0, 1)
                  for a in "xy")
            + (Port(f"{name}_g", Fmt(False, smp.level_bits, 0), "level blend weight"),
               Port(f"{name}_odd", Fmt(False, 1, 0), "level L odd")))


def _surface_bits(layout: Layout) -> int:
    return Shape.cast(request_layout(layout)["surface"].shape).width


@dataclass(frozen=True)
class FrontParams:
    """The front of the split pipeline: ``pipeline``'s inputs in; each map's footprint (:data:`CORNERS`, in the
    widths of ``request_layout(layout)``), its weights, the fragment's other inputs and the ``W = 0`` flag out."""

    NAME = "pixel_front"
    pipeline: PipelineParams
    layout: Layout

    def __post_init__(self):
        P = self.pipeline
        want = tuple((m, lv) for m in MAPS for lv in range(getattr(P, m).levels))
        require(tuple(k for k, _, _ in self.layout.surfaces) == want, "layout", self.layout.surfaces,
                f"must hold each map's levels {want}, in that order (EngineParams.texture_layout)")

    @property
    def ports(self) -> tuple:
        """The caches, ``(port, map, parity)`` (:func:`fxmodel.pipeline.engine.texture_ports`)."""
        return texture_ports(self.pipeline)

    @property
    def inputs(self) -> tuple:
        return self.pipeline.inputs

    @cached_property
    def outputs(self) -> tuple:
        req = request_layout(self.layout)
        ports = ()
        for port, _, parity in self.ports:
            ports += tuple(Port(f"{port}_{c}", Fmt(False, Shape.cast(req[c].shape).width, 0), "texel index")
                           for c in CORNERS)
            if parity is not None:
                ports += (Port(f"{port}_surface", Fmt(False, _surface_bits(self.layout), 0), "the level's surface"),
                          Port(f"{port}_skip", Fmt(False, 1, 0), "level not needed"))
        ports += tuple(p for m in MAPS for p in _weights(self.pipeline, m))
        return ports + tuple(Port(f"{CARRIED}{p.name}", p.fmt, p.doc) for p in _rest(self.pipeline)) + (
            Port("dbz", Fmt(False, 1, 0), "W = 0"),)

    def index_stages(self, name: str) -> int:
        """A map's sampler stages in the front: edge rule and scaled position, indices and weights (trilinear:
        the level first, ``rtl.sampler_mip.level_indices``)."""
        return 3 if getattr(self.pipeline, name).trilinear else 2

    @cached_property
    def start(self) -> dict:
        """Per map the cycle its sampler stages start: the perspective unit's coordinates (and for a trilinear
        map the LOD unit's level, ``PipelineParams.stage_latency``) are ready then."""
        T = self.pipeline.stage_latency
        return {m: max(T["persp"], T.get("lod", 0)) if getattr(self.pipeline, m).trilinear else T["persp"]
                for m in MAPS}

    @property
    def ready(self) -> int:
        """The cycle every map's footprint and weights are ready."""
        return max(self.start[m] + self.index_stages(m) for m in MAPS)

    @property
    def latency(self) -> int:
        return self.ready + 1                                           # + the output register


@dataclass(frozen=True)
class BackParams:
    """The back of the split pipeline: per map its four corner texels (``{map}_texels``, corner 0 low, one
    ``word_bits`` word each) and weights, the fragment's other inputs and ``dbz`` in; ``pipeline``'s outputs."""

    NAME = "pixel_back"
    pipeline: PipelineParams

    @cached_property
    def inputs(self) -> tuple:
        P = self.pipeline
        ports = tuple(Port(f"{port}_texels", Fmt(False, 4 * getattr(P, m).word_bits, 0), "four corner texels")
                      for port, m, _ in texture_ports(P))
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
        T = P.stage_latency
        m = Module()
        pipe = Pipe(m, platform=platform)
        persp = add_unit(m, "persp", P.persp, self.i_valid, **{p.name: getattr(self, p.name) for p in P.persp.inputs})
        if P.lod is not None:                           # the LOD unit beside persp, on Uc, Vc, W and the increments
            lod = add_lod(m, P, self)
        stages = F.ready
        outs = {}
        for name, (s, t) in zip(MAPS, ((persp.s, persp.t), (persp.sc, persp.tc))):
            smp = _sampler(getattr(P, name))
            t0 = F.start[name]
            m.d.comb += [smp.s.eq(pipe.delay(s, t0 - T["persp"], f"{name}_s")),
                         smp.t.eq(pipe.delay(t, t0 - T["persp"], f"{name}_t"))]
            sp = Pipe(m, f"{name}_", platform, pipe.sources)
            done = t0 + F.index_stages(name)

            def late(v, what, name=name, done=done):
                return pipe.delay(v, stages - done, f"{name}_{what}")

            if smp.params.trilinear:
                m.d.comb += smp.lod.eq(pipe.delay(lod.level, t0 - T["lod"], "lod"))
                idx = level_indices(smp, sp)
                assert sp.depth == F.index_stages(name)
                first = F.layout.surface_index[(name, 0)]
                for port, _, p in (q for q in F.ports if q[1] == name):
                    k = getattr(idx, f"k{p}")
                    for c, v in zip(CORNERS, (f"x{p}_i0", f"x{p}_i1", f"y{p}_i0", f"y{p}_i1")):
                        outs[f"{port}_{c}"] = late(getattr(idx, v), f"{port}_{c}")
                    outs[f"{port}_surface"] = late(first + (k << 1) + p, f"{port}_surface")
                    outs[f"{port}_skip"] = late((idx.g == 0) & (idx.odd != p), f"{port}_skip")
                    outs |= {f"{name}_f{a}{p}": late(getattr(idx, f"{a}{p}_f"), f"f{a}{p}") for a in "xy"}
                outs |= {f"{name}_g": late(idx.g, "g"), f"{name}_odd": late(idx.odd, "odd")}
                continue
            idx = smp.indices(sp)
            assert sp.depth == F.index_stages(name)
            x1, y1 = (idx.x_i1, idx.y_i1) if smp.params.bilinear else (idx.x_i0, idx.y_i0)
            # the edge rule leaves every index in [0, size) (border: [0, size + 1]): the request's unsigned
            # width holds it, the truncation is exact
            outs |= {f"{name}_{c}": late(v, c) for c, v in zip(CORNERS, (idx.x_i0, x1, idx.y_i0, y1))}
            if smp.params.bilinear:
                outs |= {f"{name}_fx": late(idx.x_f, "fx"), f"{name}_fy": late(idx.y_f, "fy")}
        outs |= {f"{CARRIED}{p.name}": pipe.delay(getattr(self, p.name), stages, p.name) for p in _rest(P)}
        outs["dbz"] = pipe.delay(persp.dbz, stages - T["persp"], "dbz")
        pipe.depth = stages
        self.finish(m, pipe, outs)
        return m


@register(BackParams)
class Back(UnitComponent):
    """The back (:class:`BackParams`), flat ports as every unit's (``rtl/unit.py``); ``writes``
    (:class:`rtl.sampler.TexelWrites`, optional): the board's uploads into the reflectance cubes' memories."""

    def __init__(self, params: BackParams, writes=None):
        self.writes = writes
        super().__init__(params)

    def elaborate(self, platform):
        B = self.params
        P = B.pipeline
        T = B.schedule
        m = Module()
        pipe = Pipe(m, platform=platform)

        def late(value, now, when, name):
            return pipe.delay(value, when - now, name)

        unit = written_units(m, self.writes)
        res = {}
        for name in MAPS:
            smp = _sampler(getattr(P, name))
            sp = Pipe(m, f"{name}_", platform, pipe.sources)
            wb = smp.params.word_bits

            def corners(port, wb=wb):
                words = getattr(self, f"{port}_texels")
                return [words[k * wb:(k + 1) * wb] for k in range(4)]

            if smp.params.trilinear:                        # the level caches' texels, memory p = parity p
                ports = [q[0] for q in texture_ports(P) if q[1] == name]
                data_ = {(p, n): w for p, port in enumerate(ports) for n, w in enumerate(corners(port))}
                wts = SimpleNamespace(**{f"f{a}{p}": getattr(self, f"{name}_f{a}{p}") for p in (0, 1) for a in "xy"},
                                      g=getattr(self, f"{name}_g"), odd=getattr(self, f"{name}_odd"))
                outs = blends(smp, sp, data_, wts)
            elif smp.params.bilinear:
                w = SimpleNamespace(fx=getattr(self, f"{name}_fx"), fy=getattr(self, f"{name}_fy"))
                outs = smp.blend(sp, corners(name), w)
            else:
                outs = {n: smp._channel(corners(name)[0], k) for k, n in enumerate(smp.params.out_names)}
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
        Per cache (:func:`fxmodel.pipeline.engine.texture_ports`: one per map, two for a trilinear map's even and
        odd levels) its :class:`~fxmodel.units.texcache.TexCacheParams`
        (:meth:`~fxmodel.pipeline.engine.EngineParams.texture_caches`).
    layout : Layout
        The maps in memory (:meth:`~fxmodel.pipeline.engine.EngineParams.texture_layout`: each map's levels, the
        maps in the order of ``MAPS``).
    side : ShapeLike, optional
        Sideband carried with each fragment, as :class:`~rtl.streams.StreamUnit`'s.
    addr_bits : int
    writes : TexelWrites, optional
        The reflectance cubes' write bus (:class:`rtl.sampler.TexelWrites`: the board's uploads; the maps in
        memory are not on it).

    Ports: ``i``, ``o`` as ``StreamUnit(pipeline, side)``'s; ``mem`` (AXI4 manager, read channels); ``busy`` (a
    lookup or fill inside the fetch); with ``flush`` also ``flush`` (in): the fetch's registers to their reset
    values in the next clock, every cache empty (its tags invalid): the board raises it when a map in memory is
    loaded, while the fetch is idle (``busy`` low, no burst outstanding).
    """

    def __init__(self, pipeline: PipelineParams, caches: dict, layout: Layout, side=None, addr_bits: int = 32,
                 writes=None, flush: bool = False):
        self.front = FrontParams(pipeline, layout)
        ports = self.front.ports
        require(list(caches) == [q[0] for q in ports], "caches", list(caches),
                f"must name the caches {[q[0] for q in ports]} in that order")
        self.back = BackParams(pipeline)
        self.pipeline, self.side, self.writes = pipeline, side, writes
        fields = {p.name: shape(p.fmt) for p in self.back.inputs if not p.name.endswith("_texels")}
        if side is not None:
            fields["side"] = side
        self.carry = data.StructLayout(fields)
        self.fetch = TexFetch(caches, layout, self.carry.size, addr_bits,
                              skips=[q[0] for q in ports if q[2] is not None])
        members = {"i": In(stream.Signature(input_layout(pipeline, side))),
                   "o": Out(stream.Signature(output_layout(pipeline, side))),
                   "mem": Out(self.fetch.signature.members["mem"].signature), "busy": Out(1)}
        super().__init__(members | ({"flush": In(1)} if flush else {}))

    def elaborate(self, platform):
        m = Module()
        m.submodules.front = front = StreamUnit(self.front, self.side)
        fetch = self.fetch
        m.submodules.fetch = ResetInserter(self.flush)(fetch) if hasattr(self, "flush") else fetch
        back_unit = None if self.writes is None else Back(self.back, self.writes)
        m.submodules.back = back = StreamUnit(self.back, self.side, back_unit, in_stages=BACK_IN_STAGES)
        wiring.connect(m, wiring.flipped(self.i), front.i)
        wiring.connect(m, back.o, wiring.flipped(self.o))
        wiring.connect(m, wiring.flipped(self.mem), fetch.mem)
        m.d.comb += self.busy.eq(fetch.busy)
        fo, fi = front.o.payload, fetch.i.payload
        m.d.comb += [fetch.i.valid.eq(front.o.valid), front.o.ready.eq(fetch.i.ready)]
        for port, name, parity in self.front.ports:
            req = getattr(fi, port)
            if parity is None:
                m.d.comb += req.surface.eq(self.front.layout.surface_index[(name, 0)])
            else:
                m.d.comb += [req.surface.eq(getattr(fo, f"{port}_surface")), req.skip.eq(getattr(fo, f"{port}_skip"))]
            m.d.comb += [getattr(req, c).eq(getattr(fo, f"{port}_{c}")) for c in CORNERS]
        carried = data.View(self.carry, fi.side)
        rest = {p.name for p in _rest(self.pipeline)}
        m.d.comb += [getattr(carried, f).eq(getattr(fo, f"{CARRIED}{f}" if f in rest else f))
                     for f in self.carry.members]
        out, bi = fetch.o.payload, back.i.payload
        m.d.comb += [back.i.valid.eq(fetch.o.valid), fetch.o.ready.eq(back.i.ready)]
        m.d.comb += [getattr(bi, f"{port}_texels").eq(getattr(out, port)) for port, _, _ in self.front.ports]
        carried = data.View(self.carry, out.side)
        m.d.comb += [getattr(bi, f).eq(getattr(carried, f)) for f in self.carry.members]
        return m
