"""Render a scene through the bit-exact pixel pipeline, and through the two float references.

:func:`prepare` turns a scene file into everything the pipeline needs: the front end's fragments (model side,
float), the maps and reflectance cubes quantized once into the pipeline's memories (a
:class:`~fxmodel.pipeline.pixel.PipelineParams`), and the fragments quantized once to the pipeline's input formats
(half-up, saturating). :func:`render` runs the model and the references and writes the images; ``make sim``
(``cosim/sim.py``) sends the same fragment codes through the RTL.

No silent degradation (one code path for ``render``, ``make sim`` and ``fit``): a fragment input that the
preset's format cannot hold is a :class:`ClampError` naming the input, how many fragments, the range the scene
needs and the range the preset holds, and what to do (:func:`prepare`, unless ``allow_clamp``); and
:func:`judge` gives the verdict of a rendered frame against the documented scene bound :data:`SCENE_BOUND_LSB`
(or a ``--max-lsb``): the command lines exit non-zero when it fails and ``report.json`` records it.

Images: ``model.png`` (bit-exact), ``float.png`` (reference (a), same algorithm in float), ``ideal.png``
(reference (b), ideal per-pixel Phong), ``diff.png`` (|model - float| and |model - ideal|, amplified, side by
side), and ``compare.png`` (model and ideal side by side).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fxmodel.core.rounding import Overflow, Rounding, quantize
from fxmodel.pipeline.engine import EngineParams
from fxmodel.pipeline.lighting import Light, Lighting, face_directions
from fxmodel.pipeline.pixel import FLAG_BITS, LOD_INPUTS, PipelineParams
from fxmodel.pipeline.presets import preset_units, top_value
from fxmodel.units.raster import ATTRIBUTE_FORMATS, RasterParams, Records
from host.bumpmap import block_exponent, perturbations, scene_maps
from host.engine_setup import frame_raster, frame_records, frame_rop, raster_params
from host.frontend import rasterize
from host.images import compose, diff_image, metrics, save_png
from host.mipmap import lod_increments, reference_texture
from host.reference import float_pipeline, ideal_phong, max_lsb, perturbed
from host.scene import scene_at, scene_path
from host.truth import add_truth
from host.visibility import disagreement_picture, resolve

__all__ = ["Frame", "prepare", "pipeline_params", "render", "save_png", "compose", "ClampError", "SCENE_BOUND_LSB",
           "judge", "tell", "bound_args", "INPUT_KNOBS", "ILL_CONDITIONED", "ADDRESS_LIMIT_TEXELS",
           "address_errors", "TriangleFrame", "from_triangles", "frame_records", "frame_raster", "frame_rop",
           "render_triangles", "raster_params", "engine_params", "REFERENCE_IMAGES", "save_references"]


#: The documented bound of a frame of an accepted scene: the largest per-channel distance, in 8-bit steps, of the
#: bit-exact frame from reference (a) on every well-conditioned pixel (README, "Which scenes the hardware draws,
#: and how well"). ``render`` and ``make sim`` exit non-zero beyond it (``--max-lsb`` changes it).
SCENE_BOUND_LSB = 2

#: A pixel whose float perturbed normal is shorter than this is ill-conditioned (:meth:`Frame.condition`).
ILL_CONDITIONED = 0.25

#: Where each fragment input's format lives in a preset file (what to widen when a scene needs more range).
INPUT_KNOBS = {**ATTRIBUTE_FORMATS, "Ae": "bump.exp_bits", **{n: "lod.duv_fmt, lod.dw_fmt" for n in LOD_INPUTS}}


#: The largest texture-address error (texels) a fragment may have before the scene is refused: about half a step
#: of an 8-bit texel jump under bilinear filtering (a full-scale edge moves by 255 / 512 LSB).
ADDRESS_LIMIT_TEXELS = 1 / 512


class ClampError(ValueError):
    """A scene the preset cannot draw: fragment inputs outside the preset's input formats (they would be clamped),
    or texture addresses the formats cannot resolve (:data:`ADDRESS_LIMIT_TEXELS`). The message names each input,
    how many fragments, the range the scene needs and the range the preset holds, and what to do.

    Attributes
    ----------
    clamped : dict
        Per input: ``count``, ``needs`` ``[lo, hi]``, ``holds`` ``[lo, hi]``, ``fmt``, ``knob``.
    imprecise : dict
        Per texture address (``U, V`` bump map, ``Uc, Vc`` color texture): ``count``, ``texels`` (the largest
        address error), ``limit``, ``min_W``, ``knob``.
    """

    def __init__(self, where: str, clamped: dict, preset: str, imprecise: dict | None = None):
        self.clamped = clamped
        self.imprecise = imprecise = imprecise or {}
        lines = [f"{where}: preset {preset!r} cannot draw this scene:"]
        lines += [f"  {line}" for line in self.findings(clamped, imprecise)]
        knobs = sorted({k for c in (*clamped.values(), *imprecise.values()) for k in c["knob"].split(", ")})
        lines.append(f"  what to do: `bumpmap fit {where}` finds a preset that draws the scene; or widen "
                     f"{', '.join(knobs)} in a preset file (presets/<name>.toml, then --preset <name>); or pass "
                     f"--allow-clamp to draw it anyway")
        super().__init__("\n".join(lines))

    @staticmethod
    def findings(clamped: dict, imprecise: dict) -> list[str]:
        """One line per input the preset cannot hold or address (the message's body; also
        ``Frame.stats["refused"]`` when :func:`prepare` draws the scene anyway, ``allow_clamp``)."""
        lines = [f"{name}: {c['count']} fragments would be clamped; the scene needs [{c['needs'][0]:.6g}, "
                 f"{c['needs'][1]:.6g}], {c['knob']} holds [{c['holds'][0]:.6g}, {c['holds'][1]:.6g}] ({c['fmt']})"
                 for name, c in clamped.items()]
        return lines + [f"{name}: {c['count']} fragments (W down to {c['min_W']:.3g}) are addressed only to "
                        f"{c['texels']:.3g} texel, the limit is {c['limit']:.3g} texel ({c['knob']}: more "
                        f"fraction bits)" for name, c in imprecise.items()]


def address_errors(frags, persp, shapes: dict) -> dict:
    """The texture-address errors the pipeline's input formats allow, per fragment, in texels.

    ``s = U / W`` from ``U`` and ``W`` rounded half-up to their formats: ``|s_q - s| <= (ulp_U / 2 + |s|
    ulp_W / 2) / W`` to first order, plus the perspective unit's own bound (:meth:`PerspParams.error_bound`,
    the reciprocal's error times ``|s|`` and the rounding of ``s``), times the map's size in texels.

    Parameters
    ----------
    frags : Fragments
    persp : PerspParams
    shapes : dict
        ``{"U": (height, width) of the bump map, "Uc": ... of the color texture}``; a map left out (or of one
        texel) is not addressed.

    Returns
    -------
    dict
        ``{"U": (K,), "Uc": (K,)}``: the larger of the ``s`` and ``t`` errors, in texels.
    """
    ulp_u, ulp_w = float(persp.uv_fmt.ulp), float(persp.recip.in_fmt.ulp)
    W = np.maximum(np.asarray(frags.W), np.finfo(float).tiny)
    out = {}
    for name, (uu, vv) in (("U", (frags.U, frags.V)), ("Uc", (frags.Uc, frags.Vc))):
        h, w = shapes.get(name, (1, 1))
        if h * w <= 1:
            continue
        worst = np.zeros(len(W))
        for num, size in ((uu, w), (vv, h)):
            s = np.abs(np.asarray(num)) / W
            own = s * float(persp.recip.error_bound_ulp / (1 << persp.recip.fo)) + 2.0 ** -(persp.coord_bits + 1)
            worst = np.maximum(worst, ((ulp_u / 2 + s * ulp_w / 2) / W + own) * size)
        out[name] = worst
    return out


def bound_args(parser) -> None:
    """Add ``--max-lsb`` and ``--allow-clamp`` to an ``argparse`` parser: ``render`` and ``make sim`` take both
    (and pass them to :func:`prepare` and :func:`judge`)."""
    from host.args import int_range
    parser.add_argument("--max-lsb", type=int_range(0, 255), default=SCENE_BOUND_LSB, help="exit 1 when the frame is "
                        "farther than this from reference (a) on some pixel, in 8-bit steps, 0 .. 255 (default: the "
                        "documented scene bound, %(default)s)")
    parser.add_argument("--allow-clamp", action="store_true", help="draw fragment inputs that do not fit the "
                        "preset's formats clamped (the counts are printed) instead of refusing the scene")


def tell(report: dict, where: str) -> int:
    """Print a judged report's clamped counts and problems (stderr) and return the exit status: 1 when the
    verdict (:func:`judge`) failed, else 0."""
    import sys
    v = report["verdict"]
    if v["clamped_fragment_inputs"]:
        print(f"warning: {where}: clamped fragment inputs (--allow-clamp): "
              + ", ".join(f"{k} {n}" for k, n in v["clamped_fragment_inputs"].items()), file=sys.stderr)
    for line in v["problems"]:
        print(f"error: {where}: {line}", file=sys.stderr)
    return 0 if v["pass"] else 1


def judge(report: dict, max_lsb: int = SCENE_BOUND_LSB) -> list[str]:
    """The verdict of a rendered frame (a :func:`render` report with references): records ``report["verdict"]``
    (``pass``, ``bound_lsb``, ``max_lsb_vs_float`` and the same on well- and ill-conditioned pixels, the count
    of ill-conditioned pixels, ``clamped_fragment_inputs``, ``problems``) and returns the problems, one line
    each (empty when the frame passes). A frame fails when it is farther than ``max_lsb`` from reference (a) on
    some well-conditioned pixel (:data:`ILL_CONDITIONED`; the ill-conditioned ones are counted and their
    largest difference recorded); clamped inputs (only present with ``allow_clamp``) are listed, not failed.
    A report of :func:`render_triangles` (its figures leave the depth disagreements out) also fails when a depth
    disagreement is beyond the depth precision (``depth.problems``); the verdict then counts the disagreements
    (``depth_disagreements``)."""
    if "max_lsb_vs_float" not in report:
        raise ValueError("judge: the report has no reference (a) figures (render with references=True)")
    problems = []
    worst = report["max_lsb_vs_float_well_conditioned"]
    if worst > max_lsb:
        over = sum(report["pixels_by_lsb_vs_float"][max_lsb + 1:])
        problems.append(f"the frame is {worst} LSB from reference (a) on well-conditioned pixels ({over} pixels), "
                        f"over the bound of {max_lsb} LSB (--max-lsb); `bumpmap fit SCENE --max-lsb "
                        f"{max_lsb}` searches a preset that meets it")
    problems += report.get("depth", {}).get("problems", [])
    clamped = report.get("clamped_fragment_inputs", {})
    report["verdict"] = {"pass": not problems, "bound_lsb": max_lsb, "max_lsb_vs_float": report["max_lsb_vs_float"],
                         "max_lsb_vs_float_well_conditioned": worst,
                         "ill_conditioned_pixels": report["ill_conditioned_pixels"],
                         "max_lsb_vs_float_ill_conditioned": report["max_lsb_vs_float_ill_conditioned"],
                         "clamped_fragment_inputs": clamped, "problems": problems,
                         **({"depth_disagreements": report["depth"]["disagreements"]} if "depth" in report else {})}
    return problems


@dataclass
class Frame:
    """A scene made ready for the pipeline (see :func:`prepare`)."""

    scene: object
    params: PipelineParams
    frags: object
    codes: np.ndarray = field(repr=False)
    lighting: Lighting
    maps: object
    stats: dict = field(default_factory=dict)
    #: The block exponent ``e`` of ``A`` per scene triangle (:func:`host.bumpmap.block_exponent`).
    exponent: np.ndarray = field(default=None, repr=False)
    #: The preset's units (:func:`fxmodel.pipeline.presets.preset_units`): the scan converter's knobs among them.
    units: dict = field(default=None, repr=False)

    def image(self, rgb: np.ndarray, xy=None) -> np.ndarray:
        """A full frame (background where no fragment) from per-fragment bytes ``(K, 3)``, at the front end's
        fragments or at pixels ``xy = (x, y)`` (two arrays ``(K,)``)."""
        sc = self.scene
        img = np.empty((sc.height, sc.width, 3), dtype=np.uint8)
        img[...] = np.floor(np.asarray(sc.background) * 255 + 0.5).astype(np.uint8)
        x, y = (self.frags.x, self.frags.y) if xy is None else xy
        img[y, x] = rgb
        return img

    def float_inputs(self) -> dict:
        f = self.frags
        return {"U": f.U, "s": f.s, "t": f.t, "sc": f.sc, "tc": f.tc, "N": np.asarray(f.N), "E": np.asarray(f.E),
                "A": np.asarray(f.A)}

    def bump_float(self) -> np.ndarray:
        """The unquantized perturbations ``(H, W, 2)`` in the units ``A`` expects (``du / scale``, the codes'
        real values); one zero texel without a bump map."""
        maps = self.maps
        if maps.bump is None:
            return np.zeros((1, 1, 2))
        pu, pv = perturbations(maps.heights)
        scale = maps.bump.scale or 1.0
        return np.stack([pu / scale, pv / scale], -1)

    def condition(self) -> np.ndarray:
        """``|N'|`` of reference (a) per fragment: the length of the float perturbed normal
        ``N + du A0 + dv A1`` (1 for a unit vertex normal and no perturbation). The directions of ``N'`` and of the
        reflection vector ``R`` (``|R| = |N'|^2 |E|``) move by about ``1 / |N'|`` times any error of the inputs:
        a pixel with ``|N'| < ILL_CONDITIONED`` (interpolated vertex normals nearly cancelling, or a perturbation
        nearly opposite the normal) is **ill-conditioned**; the scene bound is stated for the others."""
        n = perturbed(self.float_inputs(), self.bump_float(), self.params.bump_map.filter)
        return np.sqrt(np.einsum("ki,ki->k", n, n))

    def references(self):
        """Bytes ``(K, 3)`` of reference (a) and (b) (computed once, then kept)."""
        if getattr(self, "_references", None) is None:
            self._references = self._compute_references()
        return self._references

    def _compute_references(self):
        p, maps = self.params, self.maps
        bump_float = self.bump_float()
        dirs = face_directions(p.diffuse.width, p.diffuse.border)
        common = dict(bump_float=bump_float, texture=maps.color, bump_filter=p.bump_map.filter,
                      texture_filter=p.texture.filter, **reference_texture(p, self.codes))
        a = float_pipeline(self.float_inputs(), diffuse_cube=self.lighting.diffuse_factor(dirs),
                           specular_cube=self.lighting.specular_bytes(dirs), cube_edge=p.diffuse.edge, **common)
        b = ideal_phong(self.float_inputs(), lighting=self.lighting, **common)
        return a, b


def prepare(scene, *, size=None, preset: str | dict = "default", cube_size: int | None = None,
            allow_clamp: bool = False) -> Frame:
    """Load (if a path), rasterize and quantize a scene for a pipeline preset.

    Parameters
    ----------
    scene : path or Scene
        The scene file (or a loaded scene).
    size : int or (int, int), optional
        Override the image size.
    preset : str or dict
        A pipeline preset name (built in or ``presets/<name>.toml``) or a units dict like
        ``BUILTIN_PRESET_UNITS["default"]`` (see :func:`fxmodel.pipeline.presets.preset_units`).
    cube_size : int, optional
        Texels per reflectance-cube face edge; ``None``: the preset's ``cube_size`` (64 unless a preset file,
        e.g. one written by ``fit``, sets it).
    allow_clamp : bool
        Quantize fragment inputs outside the preset's formats by saturation (counted in
        ``stats["clamped_fragment_inputs"]``) instead of raising :class:`ClampError`.

    Raises
    ------
    SceneError
        A missing or malformed scene file (naming it).
    ClampError
        Some fragment input does not fit its format (unless ``allow_clamp``).
    ValueError, TypeError
        An unknown or bad preset (see :func:`fxmodel.pipeline.presets.preset_units`), or a frame whose visible
        fragments use more than one material.
    """
    t0 = time.perf_counter()
    scene = scene_at(scene, size)
    units = preset_units(preset)
    frame, clamped, imprecise, cols, timing = _build(scene, units, cube_size, t0)
    if (clamped or imprecise) and not allow_clamp:
        raise ClampError(str(scene.path or scene.name), clamped, preset if isinstance(preset, str) else "(units)",
                         imprecise)
    frame.codes = np.stack(cols, 1) if cols and len(frame.frags) else np.zeros((0, len(frame.params.inputs)),
                                                                               np.int64)
    t1, t2 = timing
    frame.stats.update({"clamped_fragment_inputs": {k: c["count"] for k, c in clamped.items()},
                        "imprecise_fragments": {k: c["count"] for k, c in imprecise.items()},
                        "refused": ClampError.findings(clamped, imprecise),
                        "seconds_front_end": round(t1 - t0, 3), "seconds_tables": round(t2 - t1, 3),
                        "seconds_quantize": round(time.perf_counter() - t2, 3)})
    return frame


def _build(scene, units: dict, cube_size: int | None, t0: float):
    """The steps of :func:`prepare` after loading: the front end's fragments, the pipeline with the scene's
    memories, the block exponents and the quantized fragment inputs. Returns ``(frame, clamped, imprecise,
    columns, (t1, t2))``: the frame (without codes), the clamped inputs and unresolved addresses (as
    :class:`ClampError` takes them), the code columns, and when the front end and the tables were done."""
    if cube_size is None:
        cube_size = top_value(units, "cube_size")
    maps = scene_maps(scene, units["bump"].d_fmt)
    frags = rasterize(scene, maps)
    used = np.unique(frags.material)
    if len(used) > 1:
        raise ValueError(f"{scene.path or scene.name}: the pipeline holds one material's maps, but the visible "
                         f"fragments use {len(used)} materials ({', '.join(scene.materials[i].name for i in used)})")
    mi = int(used[0]) if len(used) else 0
    mat, mm = scene.materials[mi], maps[mi]
    bump = np.stack([mm.bump.du, mm.bump.dv], -1) if mm.bump is not None else np.zeros((1, 1, 2), np.int64)
    lighting = Lighting(lights=tuple(Light(tuple(s.direction), tuple(s.color)) for s in scene.lights),
                        ambient=tuple(scene.ambient), specular=tuple(mat.specular), shininess=float(mat.shininess))
    t1 = time.perf_counter()
    params, cube_info = PipelineParams.assemble(bump_codes=bump, texture_bytes=mm.color, lighting=lighting,
                                                cube_face=cube_size, preset=units)
    t2 = time.perf_counter()
    N, E, A = np.asarray(frags.N), np.asarray(frags.E), np.asarray(frags.A)
    # triangle set-up, per scene triangle: the block exponent of A (bumpmap.block_exponent)
    bp = params.bump
    e_tri = np.zeros(len(frags.tri_A), np.int64)
    if bp.exp_bits and len(frags.tri_A):
        tri_n = np.abs(scene.triangles().normals).max(axis=1)
        e_tri = block_exponent(frags.tri_A, tri_n, bump.reshape(-1, 2) * float(bp.d_fmt.ulp), bp.a_fmt, bp.out_fmt,
                               bp.e_max)
    e = e_tri[frags.tri] if len(frags) else np.zeros(0, np.int64)
    values = {"U": frags.U, "V": frags.V, "Uc": frags.Uc, "Vc": frags.Vc, "W": frags.W,
              "Nx": N[:, 0], "Ny": N[:, 1], "Nz": N[:, 2], "Ex": E[:, 0], "Ey": E[:, 1], "Ez": E[:, 2],
              "Ae": e.astype(np.float64)}
    values |= {f"A{i}{j}": np.ldexp(A[:, i, j], -e) for i in range(3) for j in range(2)}
    if params.lod is not None:                                      # MIP mapping: the triangle's increments
        values |= lod_increments(scene, frags, mm.color_repeat)
    # what a format holds, in the scene's units (A: with the largest block exponent)
    unit = {f"A{i}{j}": 2.0 ** bp.e_max for i in range(3) for j in range(2)}
    cols, clamped = [], {}
    for port in params.inputs:
        v = values[port.name]
        c, flag = quantize(v, port.fmt, Rounding.HALF_UP, Overflow.SATURATE, f"fragment {port.name}")
        cols.append(c)
        if flag.any():
            real = A[:, int(port.name[1]), int(port.name[2])] if port.name in unit else v
            k = unit.get(port.name, 1.0)
            clamped[port.name] = {"count": int(flag.sum()), "needs": [float(real.min()), float(real.max())],
                                  "holds": [float(port.fmt.min_value) * k, float(port.fmt.max_value) * k],
                                  "fmt": str(port.fmt) + (f" x 2^e, e <= {bp.e_max}" if port.name in unit else ""),
                                  "knob": INPUT_KNOBS[port.name]}
    shapes = {"U": bump.shape[:2] if np.ptp(bump) else (1, 1), "Uc": mm.color.shape[:2] if np.ptp(mm.color) else (1, 1)}
    imprecise = {}
    for name, err in address_errors(frags, params.persp, shapes).items():
        bad = err > ADDRESS_LIMIT_TEXELS
        if bad.any():
            label = "U, V (bump-map address)" if name == "U" else "Uc, Vc (color-texture address)"
            imprecise[label] = {"count": int(bad.sum()), "texels": float(err.max()), "limit": ADDRESS_LIMIT_TEXELS,
                                "min_W": float(np.asarray(frags.W)[bad].min()),
                                "knob": "persp.uv_fmt, persp.recip.in_fmt"}
    stats = {"fragments": len(frags), "material": mat.name, "cube_size": cube_size,
             "block_exponents": np.bincount(e, minlength=1).tolist(),                 # fragments with e = 0, 1, ...
             **cube_info, "bump_map_saturated": mm.bump.n_saturated if mm.bump is not None else 0}
    frame = Frame(scene=scene, params=params, frags=frags, codes=None, lighting=lighting, maps=mm, stats=stats,
                  exponent=e_tri, units=units)
    return frame, clamped, imprecise, cols, (t1, t2)


def pipeline_params(scene, preset: str | dict = "default", *, cube_size: int | None = None) -> PipelineParams:
    """The pipeline that renders ``scene``: ``preset``'s units with the scene's memories (bump map, texture and
    the reflectance cubes of ``cube_size`` texels, default the preset's), as ``make sim`` streams it; for ``make
    verilog`` and ``make fpga``.

    ``scene`` is a scene name in ``scenes/`` (``tin-plane``) or a file (see :func:`host.scene.scene_path`);
    ``preset`` as :func:`prepare`. The scene is prepared at its own size (a fraction of a second for the shipped
    scenes), so the tables, including which material is visible, are exactly those of the rendered frame.
    """
    return prepare(scene_path(scene), preset=preset, cube_size=cube_size, allow_clamp=True).params


def engine_params(scene, preset: str | dict = "default", *, cube_size: int | None = None) -> EngineParams:
    """The engine from the triangle that draws ``scene``: :func:`raster_params` of ``preset`` feeding
    :func:`pipeline_params` (for ``make fpga``)."""
    frame = prepare(scene_path(scene), preset=preset, cube_size=cube_size, allow_clamp=True)
    return EngineParams(raster=raster_params(frame.units, frame.params.lod), pipeline=frame.params)


#: The images :func:`render` and :func:`render_triangles` write into their ``out_dir`` (``bumpmap render --refs``),
#: each as ``<name>.png``: fixed names, so a caller checks them against its inputs and outputs before any work.
REFERENCE_IMAGES = ("model", "float", "ideal", "diff", "compare", "truth", "fragments", "depth_disagreements")


def save_references(out_dir, images: dict) -> None:
    """Write ``images`` (name -> picture) into ``out_dir`` as ``<name>.png``, each name one of
    :data:`REFERENCE_IMAGES` (the names callers check before any work)."""
    for name, img in images.items():
        if name not in REFERENCE_IMAGES:
            raise ValueError(f"{name!r}: not one of REFERENCE_IMAGES, which callers check before writing")
        save_png(Path(out_dir) / f"{name}.png", img)


def render(frame: Frame, out_dir=None, *, references: bool = True, model=None, exclude=None,
           truth_samples: int = 0) -> dict:
    """Run the bit-exact model (and the references) on a prepared frame; write the images if ``out_dir``.

    ``model``: the frame's outputs ``(K, 4)`` (``r, g, b, flags`` per fragment of ``frame.frags``) when they come
    from elsewhere (the engine from the triangle, :func:`render_triangles`) instead of the pipeline's model on
    ``frame.codes``. ``exclude``: a mask ``(K,)`` of fragments left out of the comparisons with the references
    (the depth disagreements of :func:`render_triangles`, which show another surface than the references).
    ``truth_samples``: also judge the model, (a) and (b) against reference (c), the true image with that many
    samples per pixel along each axis (:func:`host.truth.against_truth`: report ``vs_truth``, image ``truth.png``);
    0 (the default) leaves it out."""
    t0 = time.perf_counter()
    if model is not None:
        out = np.asarray(model, dtype=np.int64)
    else:
        out = frame.params.compute(frame.codes) if len(frame.codes) else np.zeros((0, 4), np.int64)
    seconds = time.perf_counter() - t0
    model = out[:, :3].astype(np.uint8)
    report = {"scene": frame.scene.name, "width": frame.scene.width, "height": frame.scene.height,
              "pixels": len(frame.codes), "model_seconds": round(seconds, 3),
              "model_pixels_per_second": round(len(frame.codes) / seconds) if seconds else None,
              "flags": {name: int(((out[:, 3] >> bit) & 1).sum()) for name, bit in FLAG_BITS.items()},
              **frame.stats}
    images = {"model": frame.image(model)}
    if references:
        a, b = frame.references()
        keep = np.ones(len(model), bool) if exclude is None else ~np.asarray(exclude, bool)
        report.update(metrics(model[keep], a[keep], b[keep]))
        per_pixel = np.abs(model.astype(np.int64) - a.astype(np.int64)).max(1) if len(model) else np.zeros(0, int)
        ill = frame.condition() < ILL_CONDITIONED if len(model) else np.zeros(0, bool)
        per_pixel, ill = per_pixel[keep], ill[keep]
        report["pixels_by_lsb_vs_float"] = np.bincount(per_pixel[~ill], minlength=1).tolist()  # [0 LSB, 1 LSB, ..]
        report["ill_conditioned_pixels"] = int(ill.sum())
        report["max_lsb_vs_float_ill_conditioned"] = int(per_pixel[ill].max(initial=0))
        report["max_lsb_vs_float_well_conditioned"] = int(per_pixel[~ill].max(initial=0))
        images["float"] = frame.image(a)
        images["ideal"] = frame.image(b)
        images["diff"] = compose(frame.image(diff_image(model, a)), frame.image(diff_image(model, b)))
        images["compare"] = compose(images["model"], images["ideal"])
        if truth_samples:
            add_truth(frame, images, report, exclude, truth_samples)
    if out_dir is not None:
        save_references(out_dir, images)
    report["_model_bytes"] = model
    return report


@dataclass
class TriangleFrame:
    """A prepared frame drawn from triangles (:func:`from_triangles`): the engine's parameters, the triangle
    records and the scene triangle of each (``tri``), the bit-exact outputs ``out`` (``x, y, r, g, b, flags`` per
    fragment, in drawing order), the scan (fragments, clocks) and the depth resolution ``vis``
    (:func:`host.visibility.resolve`: which fragment each pixel keeps, against the float z-buffer)."""

    frame: Frame
    params: EngineParams
    records: Records
    out: np.ndarray = field(repr=False)
    scan: object = field(repr=False)
    stats: dict = field(default_factory=dict)
    #: With the depth test (``params.rop``): the model's frame ``(depth, color)`` after drawing, else ``None``.
    fb: tuple | None = field(default=None, repr=False)
    tri: np.ndarray = field(default=None, repr=False)
    vis: object = field(default=None, repr=False)

    def in_frame_order(self) -> np.ndarray:
        """The engine's ``r, g, b, flags`` ``(K, 4)`` of the fragments the depth test keeps, in the front end's
        fragment order (``frame.frags``; :func:`host.visibility.resolve` checked that the pixels are the same)."""
        frame = self.frame
        if self.fb is not None:                        # the depth test decided: the frame buffer's pixels
            return self.fb[1].reshape(-1, 4)[np.asarray(frame.frags.index)]
        pos = np.full(frame.scene.width * frame.scene.height, -1, dtype=np.int64)
        pos[np.asarray(frame.frags.index)] = np.arange(len(frame.frags))
        model = np.zeros((len(frame.frags), 4), dtype=np.int64)
        w = self.vis.winner
        model[pos[self.out[w, 1] * frame.scene.width + self.out[w, 0]]] = self.out[w, 2:6]
        return model

    def disagreements_in_frame_order(self) -> np.ndarray:
        """Per fragment of ``frame.frags``: True at a depth disagreement (:mod:`host.visibility`)."""
        frame, vis = self.frame, self.vis
        bad = np.zeros(frame.scene.width * frame.scene.height, bool)
        bad[vis.pixel[vis.disagree]] = True
        return bad[np.asarray(frame.frags.index)]

    def image(self, rgb: np.ndarray) -> np.ndarray:
        """A full frame from bytes ``(K, 3)`` in drawing order: each pixel shows the fragment the depth test keeps
        (:attr:`vis`; background where none)."""
        w = self.vis.winner
        return self.frame.image(np.asarray(rgb)[w], (self.out[w, 0], self.out[w, 1]))


def from_triangles(frame: Frame, raster: RasterParams | None = None, depth: bool = False) -> TriangleFrame:
    """The frame drawn by the engine from triangles: the host's set-up (:func:`host.frontend.triangle_records`)
    into records, the scan converter and interpolators, then the same pixel pipeline (``frame.params``), with the
    same block exponent of ``A`` per scene triangle as the fragments (``frame.exponent``).

    ``depth=True``: the engine with its depth test and frame buffer (:class:`~fxmodel.units.rop.RopParams` for the
    scene's frame, cleared to its background): overlapping geometry is drawn, and ``fb`` holds the frame; the
    pixels covered must then be the front end's visible ones.

    ``raster``: default :func:`raster_params` of the frame's preset (the pipeline's input formats).
    Records of other materials than the frame's are dropped (the pipeline holds one material's maps; the frame
    shows none of their pixels, :func:`prepare` checked). Overlapping triangles are resolved by the depth test
    (:func:`host.visibility.resolve`, with the raster-operations unit's model); raises ``ValueError`` when the
    float z-buffer over the scan converter's fragments keeps other fragments than the front end.
    """
    p = frame.params
    raster = frame_raster(frame) if raster is None else raster
    scene = frame.scene
    rop = frame_rop(frame, raster, scene.width, scene.height) if depth else None
    params = EngineParams(raster=raster, pipeline=p, rop=rop)
    t0 = time.perf_counter()
    try:
        recs, tri = frame_records(frame, raster)
    except ValueError as exc:       # a vertex value or slope beyond the record's formats: name the scene, the remedy
        where = str(scene.path or scene.name)
        raise ValueError(f"{where}: the engine from triangles cannot set up this scene with this preset ({exc}); "
                         f"`bumpmap fit {where}` finds a preset that draws it") from None
    t1 = time.perf_counter()
    fb = None
    if depth:
        zbuf, color, rop_stats, out, res = params.draw(recs)
        fb = (zbuf, color)
    else:
        out, res = params.compute(recs)
    t2 = time.perf_counter()
    clocks = int(res.clocks.sum())
    stats = {"input": "triangles", "triangles": len(recs), "triangles_dropped": int(recs.dropped),
             "fragments": len(res), "raster_clocks": clocks,
             "clocks_per_fragment": round(clocks / len(res), 4) if len(res) else None,
             "raster_saturated": int(res.codes["flags"].sum()),
             "record_bits": sum(q.fmt.width for q in raster.record), "raster_guard_bits": raster.guard_bits,
             "seconds_setup": round(t1 - t0, 3), "seconds_model": round(t2 - t1, 3)}
    tframe = TriangleFrame(frame=frame, params=params, records=recs, out=out, scan=res, stats=stats, fb=fb,
                           tri=tri)
    tframe.vis = resolve(tframe)
    stats.update(tframe.vis.stats)
    if depth:
        # bytes per covered pixel: the one definition, ``visibility``'s ``memory`` (same RopParams, same draw)
        stats["depth_test"] = {**rop_stats, **{k: v for k, v in stats["memory"].items() if k.endswith("_per_pixel")},
                               "fragments_per_covered_pixel": stats["depth"]["overdraw"]}
    return tframe


def render_triangles(tframe: TriangleFrame, out_dir=None, truth_samples: int = 0) -> dict:
    """Render from triangles: the report and images of :func:`render` are those of the frame the engine from the
    triangle draws (``model.png``; its distance from reference (a) is what :func:`judge` judges), with the frame
    from float-interpolated fragments beside it, so that the interpolators' share of the error shows:
    ``from_fragments`` (its figures against the references), ``triangles_vs_fragments`` and the image
    ``fragments.png``.

    Overlapping triangles: each pixel shows the fragment the depth test keeps. Pixels where it keeps another
    triangle than reference (a)'s float z-buffer (depth disagreements, legitimate within the depth precision:
    :mod:`host.visibility`) show another surface than (a); they are left out of the comparisons with the
    references and counted (``depth.disagreements``), ``depth.problems`` lists disagreements beyond the precision
    (:func:`judge` fails on them), and ``depth_disagreements.png`` marks them. The report gets ``depth`` and
    ``memory`` (:func:`host.visibility.resolve`)."""
    frame = tframe.frame
    frag = render(frame)
    frag_bytes = frag.pop("_model_bytes")
    report = render(frame, out_dir, model=tframe.in_frame_order(), exclude=tframe.disagreements_in_frame_order(),
                    truth_samples=truth_samples)
    tri_bytes = report.pop("_model_bytes")
    report.pop("model_pixels_per_second")
    report["model_seconds"] = tframe.stats["seconds_model"]
    report.update(tframe.stats)
    report["depth"] = dict(report["depth"], problems=list(tframe.vis.problems))
    report["from_fragments"] = {k: frag[k] for k in ("psnr_db_vs_float", "max_lsb_vs_float", "psnr_db_vs_ideal",
                                                     "max_lsb_vs_ideal", "max_lsb_vs_float_well_conditioned")}
    report["triangles_vs_fragments"] = {"max_lsb_vs_float": report["max_lsb_vs_float"],
                                        "psnr_db_vs_float": report["psnr_db_vs_float"],
                                        "max_lsb_vs_ideal": report["max_lsb_vs_ideal"],
                                        "max_lsb_vs_fragments": max_lsb(tri_bytes, frag_bytes),
                                        "pixels_differing_from_fragments":
                                            int(np.any(tri_bytes != frag_bytes, -1).sum())}
    if out_dir is not None:
        save_references(out_dir, {"fragments": frame.image(frag_bytes),
                                  "depth_disagreements": disagreement_picture(frame.image(tri_bytes), tframe.vis,
                                                                              frame.scene.width)})
    report["_triangle_bytes"] = tframe.out
    return report
