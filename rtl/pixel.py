"""RTL of the whole pixel pipeline (``fxmodel.pipeline.pixel.PipelineParams``): the units' components chained with
delay lines so that every stage sees the signals of the same fragment; one fragment per clock.

The schedule is ``PipelineParams.stage_latency`` (the model's): each unit starts when its last input is ready,
the earlier inputs wait in shift registers, and the two cube address units finish together.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module

from fxmodel.pipeline.pixel import FLAG_BITS, LOD_INPUTS, TEXEL_MAPS, PipelineParams

from .unit import Pipe, UnitComponent, build, register

__all__ = ["Pipeline", "add_unit", "add_lod", "written_units"]


@register(PipelineParams)
class Pipeline(UnitComponent):
    """Pixel pipeline.

    Ports (formats from the stages' parameter objects)
    -------------------------------------------------
    i_valid : Signal(1), in
    U, V, Uc, Vc : Signal(signed), in -- ``persp.uv_fmt``: bump and color numerators, less the triangle's integer
        tile offset times ``W``
    W : Signal(signed), in -- ``persp.recip.in_fmt``
    Nx, Ny, Nz : Signal(signed), in -- ``bump.n_fmt``
    Ex, Ey, Ez : Signal(signed), in -- ``reflect.e_fmt``
    A00, A10, A20, A01, A11, A21 : Signal(signed), in -- ``bump.a_fmt``: the triangle's ``A 2^-e``
    Ae : Signal(unsigned), in -- ``bump.e_fmt``: the triangle's block exponent ``e`` (if ``bump.exp_bits``)
    Ucx, Ucy, Vcx, Vcy, Wx, Wy : Signal(signed), in -- only with ``lod`` (MIP mapping): the triangle's increments
        (``lod.duv_fmt``, ``lod.dw_fmt``); the LOD unit (``rtl/lod.py``) runs beside ``persp`` on ``Uc, Vc, W``
        and them, and the trilinear color sampler starts when both are ready
    o_valid : Signal(1), out
    r, g, b : Signal(unsigned(8)), out -- the pixel's color
    flags : Signal(unsigned(4)), out -- see ``fxmodel.pipeline.pixel.FLAG_BITS``

    Latency: ``params.latency`` (``stage_latency['out']``).
    """

    def __init__(self, params: PipelineParams, writes=None):
        self.writes = writes                        # rtl.sampler.TexelWrites: the board's uploads, or None
        super().__init__(params)

    def elaborate(self, platform):
        P = self.params
        T = P.stage_latency
        m = Module()
        pipe = Pipe(m, platform=platform)

        unit = written_units(m, self.writes)

        def late(value, now, when, name):
            """``value``, ready at cycle ``now``, delayed to cycle ``when``."""
            return pipe.delay(value, when - now, name)

        persp = unit("persp", P.persp, self.i_valid, **{p.name: getattr(self, p.name) for p in P.persp.inputs})
        t0 = T["persp"]
        bmap = unit("bump_map", P.bump_map, persp.o_valid, s=persp.s, t=persp.t)
        if P.lod is None:
            tex = unit("texture", P.texture, persp.o_valid, s=persp.sc, t=persp.tc)
            t_tex = t0
        else:                   # MIP mapping: the LOD beside persp, the texture when both are ready
            lod = add_lod(m, P, self)
            t_lod, t_tex = T["lod"], max(t0, T["lod"])
            tex = unit("texture", P.texture, late(persp.o_valid, t0, t_tex, "v_tex"),
                       s=late(persp.sc, t0, t_tex, "sc"), t=late(persp.tc, t0, t_tex, "tc"),
                       lod=late(lod.level, t_lod, t_tex, "lod"))
        rest = shade_half(m, pipe, unit, late, P, T, self, (persp.o_valid, t0),
                          (bmap, t0 + P.bump_map.latency), (tex, t_tex + P.texture.latency), (persp.dbz, t0))
        self.finish(m, pipe, rest)
        return m


def written_units(m: Module, writes):
    """:func:`add_unit` for a pipeline's units, each texel map's sampler (:data:`~fxmodel.pipeline.pixel.TEXEL_MAPS`)
    with its memories written through ``writes`` (:class:`rtl.sampler.TexelWrites`: the board's uploads) when
    given."""
    def unit(name, params, valid, **inputs):
        if writes is not None and name in TEXEL_MAPS:
            from .sampler import Sampler
            return add_unit(m, name, params, valid, comp=Sampler(params, writes.port(name)), **inputs)
        return add_unit(m, name, params, valid, **inputs)
    return unit


def add_unit(m: Module, name: str, params, valid, comp=None, **inputs):
    """The unit built from ``params`` (or the component ``comp`` built from it) as submodule ``name`` of ``m``, its
    ``i_valid`` and input ports driven by ``valid`` and ``inputs`` (port name to value); returns the component."""
    comp = build(params) if comp is None else comp
    setattr(m.submodules, name, comp)
    m.d.comb += comp.i_valid.eq(valid)
    for port, value in inputs.items():
        m.d.comb += getattr(comp, port).eq(value)
    return comp


def add_lod(m: Module, P: PipelineParams, comp):
    """The LOD unit (``P.lod``, MIP mapping) as submodule ``lod`` of ``m``, beside ``persp``: on the fragment's
    ``Uc, Vc, W`` and the triangle's increments (:data:`~fxmodel.pipeline.pixel.LOD_INPUTS`), ports of ``comp``,
    starting with ``comp.i_valid``. Shared by :class:`Pipeline` and the front of the split pipeline
    (``rtl/pixel_fetch.py``)."""
    names = ("Uc", "Vc", "W") + LOD_INPUTS
    return add_unit(m, "lod", P.lod, comp.i_valid, **{p.name: getattr(comp, n) for p, n in zip(P.lod.inputs, names)})


def shade_half(m, pipe: Pipe, unit, late, P: PipelineParams, T: dict, frag, valid, bmap, tex, dbz) -> dict:
    """The pipeline from the samplers' results on (bump, reflection, cube addresses, cube lookups, shading and
    flags), scheduled by ``T`` (:attr:`~fxmodel.pipeline.pixel.PipelineParams.stage_latency`, or it shifted);
    ``frag`` has the fragment's inputs ``N``, ``E``, ``A`` (ready at cycle 0); ``valid``, ``bmap`` (``du, dv``),
    ``tex`` (``r, g, b``) and ``dbz`` are ``(value, cycle ready)``. Sets ``pipe.depth`` to ``T['shade']`` and
    returns the outputs (``r, g, b, flags``) for the output register. Shared by :class:`Pipeline` and the
    pipeline split around the texture fetch (``rtl/pixel_fetch.py``)."""
    ts = T["samples"]
    du = late(bmap[0].du, bmap[1], ts, "du")
    dv = late(bmap[0].dv, bmap[1], ts, "dv")
    ins = {f"N{c}": late(getattr(frag, f"N{c}"), 0, ts, f"N{c}") for c in "xyz"}
    ins |= {p.name: late(getattr(frag, p.name), 0, ts, p.name) for p in P.bump.inputs[5:]}
    bump = unit("bump", P.bump, late(valid[0], valid[1], ts, "v_s"), du=du, dv=dv, **ins)
    tb = T["bump"]
    refl = unit("reflect", P.reflect, bump.o_valid,
                **{f"N{c}": getattr(bump, f"Np{c}") for c in "xyz"},
                **{f"E{c}": late(getattr(frag, f"E{c}"), 0, tb, f"E{c}") for c in "xyz"})
    tr = T["reflect"]
    cube_n = unit("cube_n", P.cube, refl.o_valid,
                  **{c: late(getattr(bump, f"Np{c}"), tb, tr, f"Np{c}") for c in "xyz"})
    cube_r = unit("cube_r", P.cube, refl.o_valid, x=refl.Rx, y=refl.Ry, z=refl.Rz)
    tc = T["cubes"]
    diff = unit("diffuse", P.diffuse, cube_n.o_valid, face=cube_n.face, s=cube_n.s, t=cube_n.t)
    spec = unit("specular", P.specular, cube_r.o_valid, face=cube_r.face, s=cube_r.s, t=cube_r.t)
    tl = T["lookups"]

    def looked(smp, params, c):
        return late(getattr(smp, c), tc + params.latency, tl, f"{smp.params.NAME}_{c}")

    shade = unit("shade", P.shade, late(cube_n.o_valid, tc, tl, "v_l"),
                 **{f"t{c}": late(getattr(tex[0], c), tex[1], tl, f"tex_{c}") for c in "rgb"},
                 **{f"d{c}": late(getattr(diff, c), tc + P.diffuse.latency, tl, f"d_{c}") for c in "rgb"},
                 **{f"s{c}": late(getattr(spec, c), tc + P.specular.latency, tl, f"s_{c}") for c in "rgb"})
    tsh = T["shade"]
    bits = [None] * len(FLAG_BITS)
    bits[FLAG_BITS["bump_saturated"]] = late(bump.saturated, tb, tsh, "f_bump")
    bits[FLAG_BITS["shade_saturated"]] = shade.saturated
    bits[FLAG_BITS["degenerate"]] = late(refl.degenerate, tr, tsh, "f_deg")
    bits[FLAG_BITS["w_zero"]] = late(dbz[0], dbz[1], tsh, "f_dbz")
    pipe.depth = tsh
    return {"r": shade.r, "g": shade.g, "b": shade.b, "flags": Cat(*bits)}
