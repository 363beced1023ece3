r"""The engine from the triangle, bit-exact (paper Fig. 5): the scan converter and interpolators
(:mod:`fxmodel.units.raster`) feeding the pixel pipeline (:mod:`fxmodel.pipeline.pixel`), optionally with the depth
test and frame buffer (:mod:`fxmodel.units.rop`). Its RTL is ``rtl/engine.py``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fxmodel.core.cost import estimate
from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, require
from fxmodel.pipeline.pixel import FLAG_BITS, PipelineParams
from fxmodel.units.raster import RasterParams, scan
from fxmodel.units.rop import RopParams
from fxmodel.units.rop import draw as rop_draw
from fxmodel.units.shapes import repr_without_defaults
from fxmodel.units.texcache import Layout, TexCacheParams, footprints, level_lookups, simulate

__all__ = ["EngineParams", "RASTER_SATURATED_FLAG", "TEXTURE_MAPS", "PIPELINE_IN_STAGES", "texture_ports"]

#: Registers between the scan converter's output FIFO and the pixel pipeline's first stage with the maps on chip
#: (``rtl/engine.py``, ``StreamUnit(in_stages=)``): the FIFO's LUT RAM read through its multiplexer, with the
#: perspective unit's first stage (the reciprocal's operand negated through a carry chain) behind it in one clock,
#: was among the board's engine paths late at 100 MHz at the placements measured (``docs/board.md``).
PIPELINE_IN_STAGES = 1

#: The maps that move to external memory with :attr:`EngineParams.textures`, in memory and lookup order (the
#: reflectance cubes stay on chip).
TEXTURE_MAPS = ("bump_map", "texture")


def texture_ports(pipeline: PipelineParams) -> tuple:
    """The texel caches of ``pipeline``'s maps in external memory, in request order: ``(port, map, parity)`` each.
    A bilinear or nearest map has one cache (port = the map's name, parity ``None``); a trilinear map two,
    ``{map}_even`` and ``{map}_odd``, its even and its odd levels (a lookup's two levels differ in parity, so both
    caches look up in the same clock, as the on-chip sampler's two level memories do:
    :func:`fxmodel.units.texcache.level_lookups`)."""
    out = ()
    for name in TEXTURE_MAPS:
        if getattr(pipeline, name).trilinear:
            out += ((f"{name}_even", name, 0), (f"{name}_odd", name, 1))
        else:
            out += ((name, name, None),)
    return out


@dataclass(frozen=True)
class EngineParams:
    """The engine from the triangle (paper Fig. 5): the scan converter and interpolators (:mod:`fxmodel.units.raster`)
    feeding the pixel pipeline. Triangle records in; per fragment ``x``, ``y``, ``r, g, b`` and ``flags`` out
    (the pipeline's flags, plus :data:`RASTER_SATURATED_FLAG` when an interpolated attribute saturated).

    With ``rop`` (:class:`~fxmodel.units.rop.RopParams`) the fragments' colors go through the depth test into the frame
    buffer instead (:meth:`draw`; ``rtl/pipeline.py``'s engine then has the ROP's memory port instead of ``o``):
    the scan converter's ``Z`` rides the pixel pipeline's sideband beside ``x``, ``y``.

    Parameters
    ----------
    raster : RasterParams
        Its attributes and per-triangle constants must include every pipeline input with the same format (``Z``
        and others ride along): the block exponent ``Ae`` of the bump engine is a per-triangle constant.
    pipeline : PipelineParams
    rop : RopParams, optional
        ``max_size`` the raster's, ``z_in`` the raster's ``Z`` format, ``flag_bits`` the width of the outputs'
        ``flags``.
    textures : TexCacheParams, optional
        The bump map and the color texture in external memory (:meth:`texture_layout`), each behind a texel cache
        of these parameters (:mod:`fxmodel.units.texcache`; ``texel_bits`` per map from its sampler,
        :meth:`texture_caches`); ``None`` (default): on chip. The frame is the same either way; the caches'
        traffic is :meth:`texture_traffic`.
    """

    NAME: ClassVar[str] = "engine"

    raster: RasterParams
    pipeline: PipelineParams
    rop: RopParams | None = None
    #: In ``repr`` only when set (:meth:`__repr__`): the recorded FPGA counts and the build folders are keyed by
    #: the ``repr`` of the design they belong to (``tools/fpga_report.py``, ``rtl/digest.py``), and the engine
    #: with its maps on chip keeps its keys.
    textures: TexCacheParams | None = None

    def __repr__(self):
        """The dataclass ``repr`` without ``textures`` when it is ``None``."""
        return repr_without_defaults(self, ("textures",))

    def __post_init__(self):
        require(isinstance(self.raster, RasterParams), "raster", type(self.raster).__name__, "must be RasterParams")
        require(isinstance(self.pipeline, PipelineParams), "pipeline", type(self.pipeline).__name__,
                "must be PipelineParams")
        attrs = dict(self.raster.attrs + self.raster.carried)
        for p in self.pipeline.inputs:
            require(attrs.get(p.name) == p.fmt, f"raster.attrs[{p.name!r}]", str(attrs.get(p.name)),
                    f"must be the pipeline's input format {p.fmt}")
        if self.rop is not None:
            R = self.rop
            require(isinstance(R, RopParams), "rop", type(R).__name__, "must be RopParams or None")
            require(R.max_size == self.raster.max_size, "rop.max_size", R.max_size,
                    f"must be the raster's max_size {self.raster.max_size}")
            require(R.z_in == attrs.get("Z"), "rop.z_in", str(R.z_in),
                    f"must be the raster's Z format {attrs.get('Z')}")
            require(R.flag_bits == self.outputs[-1].fmt.width, "rop.flag_bits", R.flag_bits,
                    f"must be the engine's flags width {self.outputs[-1].fmt.width}")

        if self.textures is not None:
            require(isinstance(self.textures, TexCacheParams), "textures", type(self.textures).__name__,
                    "must be TexCacheParams or None")
            for name in TEXTURE_MAPS:
                smp = getattr(self.pipeline, name)
                require(smp.faces == 1 and smp.word_bits <= 8 * self.textures.texel_bytes, f"pipeline.{name}",
                        smp.word_bits, f"must be one face of at most {8 * self.textures.texel_bytes}-bit words")

    def texture_layout(self, base: int = 0) -> Layout:
        """The maps in external memory: the bump map then the color texture, each map's MIP levels in order
        (surfaces ``(name, level)``; level 0 only unless its sampler is trilinear), each level blocked by the
        caches' line as level 0 is, from ``base``."""
        T = self.textures
        require(T is not None, "textures", None, "the maps are on chip")
        return Layout(tuple(((name, lv),) + tuple(size) for name in TEXTURE_MAPS
                            for lv, size in enumerate(getattr(self.pipeline, name).level_sizes)),
                      T.block, T.texel_bytes, base)

    def texture_words(self) -> list:
        """The texel words of each surface in external memory (``(height, width)`` arrays, layout order: each
        map's MIP levels, :meth:`texture_layout`): the samplers' packed words, as their memories on chip hold them."""
        out = []
        for (name, lv), h, w in self.texture_layout().surfaces:
            smp = getattr(self.pipeline, name)
            out.append(np.array(smp.level_words(lv), np.int64).reshape(h, w))
        return out

    def texture_ports(self) -> tuple:
        """The texel caches, in request order (:func:`texture_ports` of the pipeline)."""
        return texture_ports(self.pipeline)

    def texture_caches(self) -> dict:
        """Per cache (:meth:`texture_ports`) its parameters: :attr:`textures` with its map's ``word_bits``."""
        return {port: dataclasses.replace(self.textures, texel_bits=getattr(self.pipeline, name).word_bits)
                for port, name, _ in self.texture_ports()}

    def texture_lookups(self, records, base: int = 0) -> dict:
        """Per cache (:meth:`texture_ports`) the :class:`~fxmodel.units.texcache.Trace` of its lookups: the
        fragments in drawing order, the sampler's footprints at the perspective unit's coordinates (a trilinear
        map: at the LOD unit's levels, only the levels a lookup needs, :func:`~fxmodel.units.texcache.
        level_lookups`)."""
        res = scan(self.raster, records)
        codes = np.stack([res.codes[p.name] for p in self.pipeline.inputs], axis=1) if len(res) else \
            np.zeros((0, len(self.pipeline.inputs)), np.int64)
        tr = self.pipeline.trace(codes) if len(res) else {"st": np.zeros((0, 4), np.int64),
                                                           "lod": np.zeros(0, np.int64)}
        st = tr["st"]
        layout = self.texture_layout(base)
        out = {}
        for k, name in enumerate(TEXTURE_MAPS):
            smp = getattr(self.pipeline, name)
            s, t = st[:, 2 * k], st[:, 2 * k + 1]
            if smp.trilinear:
                surfaces = [layout.surface_index[(name, lv)] for lv in range(smp.levels)]
                out[f"{name}_even"], out[f"{name}_odd"] = level_lookups(smp, s, t, tr["lod"], surfaces)
            else:
                out[name] = footprints(smp, s, t, layout.surface_index[(name, 0)])
        return out

    def texture_traffic(self, records, base: int = 0) -> dict:
        """Per cache (:meth:`texture_ports`) the :class:`~fxmodel.units.texcache.CacheResult` of its lookups
        (:meth:`texture_lookups`) through its empty cache."""
        layout, caches = self.texture_layout(base), self.texture_caches()
        return {port: simulate(caches[port], layout, trace)
                for port, trace in self.texture_lookups(records, base).items()}

    @property
    def inputs(self) -> tuple:
        """The triangle record (:attr:`RasterParams.record`), the design's input payload."""
        return self.raster.record

    def products(self) -> tuple:
        """The scan converter's and the pixel pipeline's products (``fxmodel/core/cost.py``)."""
        return self.raster.products() + self.pipeline.products()

    def memories(self) -> tuple:
        mems = self.raster.memories() + self.pipeline.memories()
        if self.textures is None:
            return mems
        maps = [m for name in TEXTURE_MAPS for m in getattr(self.pipeline, name).memories()]
        return tuple(m for m in mems if m not in maps) + tuple(
            m for c in self.texture_caches().values() for m in c.memories(decoupled=True))

    def cost(self) -> dict:
        """:func:`fxmodel.core.cost.estimate` of the whole engine."""
        return estimate(self)

    @property
    def outputs(self) -> tuple:
        pf = self.raster.pixel_fmt
        return ((Port("x", pf), Port("y", pf)) + self.pipeline.outputs[:3]
                + (Port("flags", Fmt(False, len(FLAG_BITS) + 1, 0), str(FLAG_BITS | {"raster_saturated": 4})),))

    @property
    def latency(self) -> int:
        """Cycles from a fragment leaving the scan converter to its color on the outputs: the pixel pipeline's,
        and :data:`PIPELINE_IN_STAGES` with the maps on chip."""
        return self.pipeline.latency + (PIPELINE_IN_STAGES if self.textures is None else 0)

    def compute(self, records):
        """``(out, scan)``: output codes ``(K, outputs)`` in the order the hardware draws, and the
        :class:`~fxmodel.units.raster.ScanResult` (fragments, clocks)."""
        res = scan(self.raster, records)
        codes = np.stack([res.codes[p.name] for p in self.pipeline.inputs], axis=1) if len(res) else \
            np.zeros((0, len(self.pipeline.inputs)), np.int64)
        col = self.pipeline.compute(codes) if len(res) else np.zeros((0, 4), np.int64)
        flags = col[:, 3] | (res.codes["flags"] << RASTER_SATURATED_FLAG)
        out = np.column_stack([res.codes["x"], res.codes["y"], col[:, :3], flags]).astype(np.int64)
        return out, res

    def draw(self, records, fb=None):
        """The engine with its depth test (``rop`` set): ``(depth, color, stats, out, scan)``, the frame after
        drawing ``records`` over ``fb`` (default: the clear frame) with :func:`fxmodel.units.rop.draw`, its traffic,
        and :meth:`compute`'s per-fragment outputs and scan."""
        require(self.rop is not None, "rop", None, "draw needs the engine's RopParams")
        out, res = self.compute(records)
        frags = np.column_stack([out[:, 0], out[:, 1], res.codes["Z"] if len(res) else np.zeros(0, np.int64),
                                 out[:, 2:6]]) if len(out) else np.zeros((0, 7), np.int64)
        depth, color, stats = rop_draw(self.rop, frags, fb)
        return depth, color, stats, out, res


#: Bit of :attr:`EngineParams.outputs` ``flags`` set when the scan converter saturated an attribute.
RASTER_SATURATED_FLAG = len(FLAG_BITS)
