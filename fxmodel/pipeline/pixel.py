r"""The whole pixel pipeline, bit-exact: fragment -> color (paper, sections 3.2, 4 and 4.1; ``docs/design.md``,
"Data flow of one pixel").

::

    fragment (U, V, Uc, Vc, W homogeneous; N unnormalized; E eye vector; the triangle's A, 3 x 2)
      -> persp      s = U (1/W), t = V (1/W); sc, tc from Uc, Vc; repeat-wrapped  (reciprocal, section 4.1)
      -> samplers   (du, dv) from the bump map at (s, t), RGB from the color texture at (sc, tc)
      -> bump       N' = N + du A[:,0] + dv A[:,1]                     (section 3.2, Fig. 6)
      -> reflect    R = 2 N'(N'.E) - E (N'.N'), block-normalized       (EQ 1)
      -> cube       face, s, t of N' (diffuse) and of R (specular)     (section 4)
      -> samplers   bilinear lookups in the diffuse and specular reflectance cubes (seamless: one-texel border)
      -> shade      RGB = texture * D + S, saturated to bytes

Every stage is the unit of its own module, with its own parameter object; :class:`PipelineParams` holds one of
each (plus the four memories inside the samplers) and checks that each stage's output format is the next
stage's input format, so the chain is wired by codes, never re-scaled. The model is the composition of the
units' models; ``rtl/pixel.py`` chains the units' components with delay lines, one fragment per clock.

MIP mapping (optional, off by default; paper section 6 names "artifact reduced MIP mapping" as the next step):
with :attr:`PipelineParams.lod` set, the fragment also carries the triangle's increments ``Ucx, Ucy, Vcx, Vcy,
Wx, Wy`` (per-pixel steps of ``Uc, Vc, W`` along x and y, constants of the triangle), the LOD unit
(:mod:`fxmodel.units.lod`) computes the color texture's level of detail from ``Uc, Vc, W`` and them, beside the
perspective unit, and the color texture is sampled trilinearly (:mod:`fxmodel.units.sampler`, step 5) from its MIP
pyramid (:mod:`fxmodel.units.mip`). The bump map stays unfiltered (the filtering study, ``docs/filtering.md``).

Outputs: ``r, g, b`` bytes and ``flags``, a bit field: bit 0 bump engine saturated ``N'``, bit 1 shading
saturated, bit 2 degenerate reflection (``N' = 0`` or ``E = 0``), bit 3 ``W = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import Port, Unit, register, require
from fxmodel.pipeline.lighting import Light, Lighting, bake_cubes
from fxmodel.pipeline.presets import preset_units, top_value
from fxmodel.units.bump import BumpParams
from fxmodel.units.cube import CubeParams
from fxmodel.units.lod import LodParams
from fxmodel.units.persp import PerspParams
from fxmodel.units.reflect import ReflectParams
from fxmodel.units.sampler import SamplerParams, Texels, mip_texels
from fxmodel.units.shade import ShadeParams
from fxmodel.units.shapes import repr_without_defaults

__all__ = ["PipelineParams", "FLAG_BITS", "LOD_INPUTS", "TEXEL_MAPS", "lod_slopes"]

FLAG_BITS = {"bump_saturated": 0, "shade_saturated": 1, "degenerate": 2, "w_zero": 3}

#: The fragment inputs the LOD unit adds (the triangle's increments), in the order of
#: :meth:`fxmodel.units.lod.LodParams.compute` after ``U, V, W``.
LOD_INPUTS = ("Ucx", "Ucy", "Vcx", "Vcy", "Wx", "Wy")
#: The samplers whose texel memories a board uploads into (``host.protocol.MEMORIES``), by their index on the
#: texel memories' write bus (``rtl.sampler.TexelWrites``).
TEXEL_MAPS = ("bump_map", "texture", "diffuse", "specular")

#: Formats of the increments with MIP mapping: the LOD unit's fraction bits, and integer bits for a frame of 64
#: pixels (a triangle's per-pixel steps of ``Uc, Vc, W`` grow as the frame shrinks; the grazing floor at 128 pixels
#: steps ``Vc`` by up to 77 a pixel on a sliver at the near plane, and ``W`` by up to 2.2).
LOD_DUV_FMT, LOD_DW_FMT = Fmt(True, 9, 28), Fmt(True, 4, 30)


def lod_slopes(lod) -> tuple:
    """The scan converter's ``slopes`` (:class:`fxmodel.units.raster.RasterParams`) that hand the LOD unit ``lod``
    its increments from triangles: each of :data:`LOD_INPUTS` the step of ``Uc``, ``Vc`` or ``W`` along ``x`` or
    ``y``, in ``lod.duv_fmt`` / ``lod.dw_fmt``; none without MIP mapping (``lod`` None)."""
    if lod is None:
        return ()
    return tuple((n, n[:-1], n[-1], lod.dw_fmt if n[0] == "W" else lod.duv_fmt) for n in LOD_INPUTS)


@dataclass(frozen=True)
class PipelineParams(Unit):
    """Parameters of the pixel pipeline: one parameter object per stage (see the module docstring).

    Parameters
    ----------
    persp, bump, reflect, cube, shade
        The units' parameter objects.
    bump_map, texture, diffuse, specular : SamplerParams
        The four memories and how they are sampled.
    lod : LodParams or None
        The color texture's level-of-detail unit (``texture`` then trilinear with ``lod_fmt = lod.out_fmt``);
        ``None`` (the default): no MIP mapping.
    """

    NAME = "pipeline"

    persp: PerspParams
    bump_map: SamplerParams
    texture: SamplerParams
    bump: BumpParams
    reflect: ReflectParams
    cube: CubeParams
    diffuse: SamplerParams
    specular: SamplerParams
    shade: ShadeParams
    lod: LodParams | None = None

    def __repr__(self):
        """The dataclass ``repr`` without ``lod`` when it is ``None`` (the same as before MIP mapping: build caches
        and recorded resource counts are keyed by it)."""
        return repr_without_defaults(self, ("lod",))

    def __post_init__(self):
        require(self.persp.color, "persp.color", self.persp.color,
                "must be True (separate color texture address)")
        require(self.bump_map.coord_fmt == self.persp.coord_fmt and self.texture.coord_fmt == self.persp.coord_fmt,
                "bump_map/texture.coord_fmt", (self.bump_map.coord_fmt, self.texture.coord_fmt),
                f"must be persp's coord_fmt {self.persp.coord_fmt}")
        require(self.bump_map.channels == (self.bump.d_fmt,) * 2 and self.bump_map.faces == 1,
                "bump_map.channels/faces", (self.bump_map.channels, self.bump_map.faces),
                f"must be one face of two {self.bump.d_fmt} channels (du, dv)")
        require(self.texture.channels == (self.shade.tex_fmt,) * 3 and self.texture.faces == 1,
                "texture.channels/faces", (self.texture.channels, self.texture.faces),
                f"must be one face of three {self.shade.tex_fmt} channels")
        require(self.reflect.n_fmt == self.bump.out_fmt, "reflect.n_fmt", self.reflect.n_fmt,
                f"must be bump.out_fmt {self.bump.out_fmt}")
        cube_bits = self.cube.in_fmt.width
        require(self.bump.out_fmt.width == cube_bits, "cube.in_fmt", self.cube.in_fmt,
                f"its width {cube_bits} must equal N' width {self.bump.out_fmt.width} (the codes are wired directly)")
        require(self.reflect.r_fmt.width == cube_bits, "cube.in_fmt", self.cube.in_fmt,
                f"its width {cube_bits} must equal R width {self.reflect.r_fmt.width}")
        for name, fmt in (("diffuse", self.shade.diffuse_fmt), ("specular", self.shade.specular_fmt)):
            smp = getattr(self, name)
            require(smp.faces == 6 and smp.out_channels == (fmt,) * 3, f"{name}.out_channels/faces",
                    (smp.out_channels, smp.faces), f"must be a cube of three {fmt} output channels (shade's input)")
            require(smp.coord_fmt == self.cube.st_fmt, f"{name}.coord_fmt", smp.coord_fmt,
                    f"must be the cube unit's st_fmt {self.cube.st_fmt}")
        if self.lod is None:
            require(not self.texture.trilinear, "texture.filter", self.texture.filter, "trilinear needs lod")
            return
        L = self.lod
        require(isinstance(L, LodParams), "lod", L, "must be LodParams or None")
        require(self.texture.trilinear and self.texture.lod_fmt == L.out_fmt, "texture.filter/lod_fmt",
                (self.texture.filter, self.texture.lod_fmt), f"must be trilinear with lod_fmt {L.out_fmt}")
        require(L.uv_fmt == self.persp.uv_fmt and L.w_fmt == self.persp.recip.in_fmt, "lod.uv_fmt/w_fmt",
                (L.uv_fmt, L.w_fmt), f"must be the fragment's {self.persp.uv_fmt}, {self.persp.recip.in_fmt}")
        require(tuple(L.size) == (self.texture.width, self.texture.height), "lod.size", L.size,
                f"must be the color texture's (width, height) {(self.texture.width, self.texture.height)}")

    # -- ports --------------------------------------------------------------------------------------------
    @property
    def inputs(self):
        return (self.persp.inputs
                + tuple(Port(f"N{c}", self.bump.n_fmt, "interpolated normal") for c in "xyz")
                + tuple(Port(f"E{c}", self.reflect.e_fmt, "eye vector") for c in "xyz")
                + self.bump.inputs[5:]                                   # A00 .. A21
                + (() if self.lod is None else
                   tuple(Port(n, self.lod.duv_fmt if n[0] != "W" else self.lod.dw_fmt, "the triangle's increment")
                         for n in LOD_INPUTS)))

    @property
    def outputs(self):
        return self.shade.outputs[:3] + (Port("flags", Fmt(False, len(FLAG_BITS), 0), str(FLAG_BITS)),)

    @cached_property
    def stage_latency(self) -> dict:
        """When each stage's result is ready (cycles after the fragment), as the RTL schedules it."""
        t = {"persp": self.persp.latency}
        if self.lod is not None:                                        # beside persp, from the fragment
            t["lod"] = getattr(self.lod, "latency", 0)
        t["samples"] = max(t["persp"], t.get("lod", 0)) + max(self.bump_map.latency, self.texture.latency)
        t["bump"] = t["samples"] + self.bump.latency
        t["reflect"] = t["bump"] + self.reflect.latency
        t["cubes"] = t["reflect"] + self.cube.latency
        t["lookups"] = t["cubes"] + max(self.diffuse.latency, self.specular.latency)
        t["shade"] = t["lookups"] + self.shade.latency
        t["out"] = t["shade"] + 1                                       # the pipeline's output register
        return t

    @property
    def latency(self) -> int:
        return self.stage_latency["out"]

    #: The stages in RTL order (``cube`` twice: the normal's and the reflection's address units).
    STAGES = ("persp", "bump_map", "texture", "bump", "reflect", "cube", "cube", "diffuse", "specular", "shade")

    @property
    def stages(self) -> tuple:
        """:data:`STAGES`, and ``lod`` when MIP mapping (``rtl/pixel.py`` builds it after ``persp``)."""
        return self.STAGES[:1] + (("lod",) if self.lod is not None else ()) + self.STAGES[1:]

    def products(self) -> tuple:
        """Every stage's products (:attr:`stages`), the samplers' blends and the LOD unit's included."""
        return tuple(p for name in self.stages for p in getattr(self, name).products())

    def memories(self) -> tuple:
        """Every stage's memories: the reciprocal tables, the four texel memories (the texture's MIP levels), the
        LOD unit's ``log2`` table."""
        return tuple(m for name in self.stages for m in getattr(self, name).memories())

    def _info(self):
        mems = {n: getattr(self, n).info()["texels"] for n in ("bump_map", "texture", "diffuse", "specular")}
        return {"stage_ready_cycle": self.stage_latency, "memories": mems,
                "memory_bits": sum(getattr(self, n).depth * getattr(self, n).word_bits
                                   for n in ("bump_map", "texture", "diffuse", "specular")),
                "max_error_units": "see the scene report: PSNR and max LSB against the float references"}

    # -- bit-exact model: the composition of the units' models -------------------------------------------
    def trace(self, codes: np.ndarray) -> dict:
        """Every stage's codes for fragment codes ``(K, inputs)`` (the RTL's internal signals, for debugging)."""
        c = np.asarray(codes, dtype=np.int64)
        col = {p.name: c[:, i] for i, p in enumerate(self.inputs)}

        def cols(names):
            return np.stack([col[n] for n in names], axis=1)

        N, E = cols(["Nx", "Ny", "Nz"]), cols(["Ex", "Ey", "Ez"])
        A = cols([p.name for p in self.bump.inputs[5:]])
        st = self.persp.compute(cols([p.name for p in self.persp.inputs]))
        sto = {p.name: st[:, i] for i, p in enumerate(self.persp.outputs)}
        duv = self.bump_map.compute(np.stack([sto["s"], sto["t"]], 1))
        if self.lod is None:
            tex = self.texture.compute(np.stack([sto["sc"], sto["tc"]], 1))
        else:
            lod, _ = self.lod.compute(*(col[n] for n in ("Uc", "Vc", "W", *LOD_INPUTS)))
            tex = self.texture.compute(np.stack([sto["sc"], sto["tc"], lod], 1))
        npr = self.bump.compute(np.column_stack([N, duv, A]))
        r = self.reflect.compute(np.column_stack([npr[:, :3], E]))
        cd = self.cube.compute(npr[:, :3])
        cs = self.cube.compute(r[:, :3])
        d = self.diffuse.compute(cd[:, :3])
        sp = self.specular.compute(cs[:, :3])
        out = self.shade.compute(np.column_stack([tex, d, sp]))
        flags = (npr[:, 3] << FLAG_BITS["bump_saturated"]) | (out[:, 3] << FLAG_BITS["shade_saturated"]) \
            | (r[:, 3] << FLAG_BITS["degenerate"]) | (sto["dbz"] << FLAG_BITS["w_zero"])
        extra = {} if self.lod is None else {"lod": lod}
        return {"st": st, **extra, "duv": duv, "tex": tex, "N'": npr, "R": r, "cube_n": cd, "cube_r": cs, "D": d,
                "S": sp, "rgb": out[:, :3], "flags": flags}

    def _compute(self, cols):
        tr = self.trace(np.stack(cols, axis=1))
        return [tr["rgb"][:, 0], tr["rgb"][:, 1], tr["rgb"][:, 2], tr["flags"]]

    def hard_cases(self) -> np.ndarray:
        """Fragments built from each stage's own hard cases where they are fragment inputs."""
        rng = np.random.default_rng(5)
        base = self.random_inputs(rng, 64)
        names = [p.name for p in self.inputs]

        def embed(row, unit_params, cases):
            rows = np.repeat(row[None], len(cases), axis=0)
            for j, p in enumerate(unit_params.inputs):
                if p.name in names:
                    rows[:, names.index(p.name)] = cases[:, j]
            return rows

        return np.concatenate([base, embed(base[0], self.persp, self.persp.hard_cases()),
                               embed(base[1], self.bump, self.bump.hard_cases())])

    @classmethod
    def assemble(cls, *, bump_codes, texture_bytes, lighting: Lighting, cube_face: int,
                 preset: str | dict = "default", bump_filter: str = "bilinear", texture_filter: str = "bilinear",
                 weight_bits: int | None = None, cube_edge: str = "border"):
        """A pipeline from a scene's tables: the bump map codes ``(H, W, 2)`` in ``bump.d_fmt``, the texture
        bytes ``(H, W, 3)``, the lighting (baked into cubes of ``cube_face`` texels) and the units' preset.

        ``weight_bits`` of the bump-map and texture bilinear weights: 10 keep a hard texture edge (a jump of up to 255)
        within a quarter step of the exact blend; 12 (the default) also keep a steep bump map (strength up to 8) from
        moving ``N'`` enough to shift a highlight by a step; the cube lookups' lighting is smooth, 8 bits there.
        ``None``: the preset's ``weight_bits`` (12 unless a preset file sets it). ``preset`` is a preset name or a units
        dict (see :func:`fxmodel.pipeline.presets.preset_units`). The preset's ``mip_levels`` (0: none), ``lod_bias``,
        ``level_bits`` and ``blend_frac`` turn on MIP mapping of the color texture (:attr:`lod`), when the texture has a
        level beyond level 0 (not for a one-texel texture). The preset's ``shade.diffuse_fmt`` is the diffuse cube's
        texel format; its sampler's blend keeps ``diffuse_extra_frac`` more fraction bits, and the shading unit's
        ``diffuse_fmt`` is derived from the sampler's output format."""
        units = preset_units(preset)
        if weight_bits is None:
            weight_bits = top_value(units, "weight_bits")
        persp, bump, reflect, cube, shade = (units[k] for k in ("persp", "bump", "reflect", "cube", "shade"))
        texture = SamplerParams(texels=Texels(np.asarray(texture_bytes)[None]), channels=(shade.tex_fmt,) * 3,
                                coord_fmt=persp.coord_fmt, filter=texture_filter, edge="repeat",
                                weight_bits=weight_bits, names=("r", "g", "b"))
        lod = None
        if min(top_value(units, "mip_levels"), max(texture.width, texture.height).bit_length()) >= 2:  # a level 1
            lod = LodParams(uv_fmt=persp.uv_fmt, w_fmt=persp.recip.in_fmt, size=(texture.width, texture.height),
                            bias=top_value(units, "lod_bias"), duv_fmt=LOD_DUV_FMT, dw_fmt=LOD_DW_FMT)
            mips = mip_texels(texture.texels, top_value(units, "mip_levels"))
            texture = texture.replace(filter="trilinear", mips=mips, lod_fmt=lod.out_fmt,
                                      level_bits=top_value(units, "level_bits"),
                                      blend_frac=top_value(units, "blend_frac"))
        diffuse, specular, info = bake_cubes(lighting, cube_face, shade.diffuse_fmt, shade.specular_fmt,
                                             border=1 if cube_edge == "border" else 0)
        diffuse = SamplerParams(texels=diffuse, channels=(shade.diffuse_fmt,) * 3, coord_fmt=cube.st_fmt,
                                edge=cube_edge, names=("r", "g", "b"),
                                extra_frac=top_value(units, "diffuse_extra_frac"))
        shade = shade.replace(diffuse_fmt=diffuse.out_channels[0])     # the preset's diffuse_fmt: the texels'
        coord = persp.coord_fmt
        params = cls(
            persp=persp, bump=bump, reflect=reflect, cube=cube, shade=shade,
            bump_map=SamplerParams(texels=Texels(np.asarray(bump_codes)[None]), channels=(bump.d_fmt,) * 2,
                                   coord_fmt=coord, filter=bump_filter, edge="repeat", weight_bits=weight_bits,
                                   names=("du", "dv")),
            texture=texture,
            diffuse=diffuse,
            specular=SamplerParams(texels=specular, channels=(shade.specular_fmt,) * 3, coord_fmt=cube.st_fmt,
                                   edge=cube_edge, names=("r", "g", "b")), lod=lod)
        return params, info


def _demo() -> PipelineParams:
    """A small self-contained pipeline (8 x 8 bump ripple, 4 x 4 checker, two lights, 8-texel cube faces) for
    the unit tests and co-simulation with random fragments."""
    bump = BumpParams.PRESETS["default"]
    i = np.arange(8)
    du = np.round(400 * np.sin(2 * np.pi * i / 8))[None, :].repeat(8, 0)
    duv = np.stack([du, du.T], -1).astype(np.int64)
    checker = ((i[:4, None] + i[None, :4]) % 2 * 155 + 100)[..., None].repeat(3, -1)
    lighting = Lighting(lights=(Light((-1.0, 1.0, 1.0), (0.8, 0.3, 0.8)), Light((0.0, -1.0, 1.0), (1.0, 1.0, 1.0))),
                        ambient=(0.1, 0.1, 0.12), specular=(0.8, 0.8, 0.8), shininess=24.0)
    del bump
    return PipelineParams.assemble(bump_codes=duv, texture_bytes=checker, lighting=lighting, cube_face=8)[0]


PipelineParams.PRESETS = {"default": _demo()}
register(PipelineParams)
