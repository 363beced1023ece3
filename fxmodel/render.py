"""Render a scene through the bit-exact pixel pipeline, and through the two float references.

:func:`prepare` turns a scene file into everything the pipeline needs: the front end's fragments (model side,
float), the maps and reflectance cubes quantized once into the pipeline's memories (a
:class:`~fxmodel.pipeline.PipelineParams`), and the fragments quantized once to the pipeline's input formats
(half-up, saturating; the count of clamped values is reported). :func:`render` runs the model and the references
and writes the images; ``make sim`` (``cosim/sim.py``) sends the same fragment codes through the RTL.

Images: ``model.png`` (bit-exact), ``float.png`` (reference (a), same algorithm in float), ``ideal.png``
(reference (b), ideal per-pixel Phong), ``diff.png`` (|model - float| and |model - ideal|, amplified, side by
side), and ``compare.png`` (model and ideal side by side).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .bumpmap import perturbations, scene_maps
from .frontend import rasterize
from .lighting import Light, Lighting, face_directions
from .pipeline import FLAG_BITS, PipelineParams
from .presets import preset_units, top_value
from .reference import float_pipeline, ideal_phong, max_lsb, psnr
from .rounding import Overflow, Rounding, quantize
from .scene import load_scene, scene_path

__all__ = ["Frame", "prepare", "pipeline_params", "render", "save_png", "compose"]

DIFF_GAIN = 16


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

    def image(self, rgb: np.ndarray) -> np.ndarray:
        """A full frame (background where no fragment) from per-fragment bytes ``(K, 3)``."""
        sc = self.scene
        img = np.empty((sc.height, sc.width, 3), dtype=np.uint8)
        img[...] = np.floor(np.asarray(sc.background) * 255 + 0.5).astype(np.uint8)
        img[self.frags.y, self.frags.x] = rgb
        return img

    def float_inputs(self) -> dict:
        f = self.frags
        return {"U": f.U, "s": f.s, "t": f.t, "sc": f.sc, "tc": f.tc, "N": np.asarray(f.N), "E": np.asarray(f.E),
                "A": np.asarray(f.A)}

    def references(self):
        """Bytes ``(K, 3)`` of reference (a) and (b)."""
        p, maps = self.params, self.maps
        if maps.bump is not None:
            # the unquantized perturbations in the units A expects (du / scale, the codes' real values)
            pu, pv = perturbations(maps.heights)
            scale = maps.bump.scale or 1.0
            bump_float = np.stack([pu / scale, pv / scale], -1)
        else:
            bump_float = np.zeros((1, 1, 2))
        dirs = face_directions(p.diffuse.width, p.diffuse.border)
        common = dict(bump_float=bump_float, texture=maps.color, bump_filter=p.bump_map.filter,
                      texture_filter=p.texture.filter)
        a = float_pipeline(self.float_inputs(), diffuse_cube=self.lighting.diffuse_factor(dirs),
                           specular_cube=self.lighting.specular_bytes(dirs), cube_edge=p.diffuse.edge, **common)
        b = ideal_phong(self.float_inputs(), lighting=self.lighting, **common)
        return a, b


def prepare(scene, *, size=None, preset: str | dict = "default", cube_size: int | None = None) -> Frame:
    """Load (if a path), rasterize and quantize a scene for a pipeline preset.

    Parameters
    ----------
    scene : path or Scene
        The scene file (or a loaded scene).
    size : int or (int, int), optional
        Override the image size.
    preset : str or dict
        A pipeline preset name (built in or ``presets/<name>.toml``) or a units dict like
        ``BUILTIN_PRESET_UNITS["default"]`` (see :func:`fxmodel.presets.preset_units`).
    cube_size : int, optional
        Texels per reflectance-cube face edge; ``None``: the preset's ``cube_size`` (64 unless a preset file,
        e.g. one written by ``fit``, sets it).

    Raises
    ------
    SceneError
        A missing or malformed scene file (naming it).
    ValueError, TypeError
        An unknown or bad preset (see :func:`fxmodel.presets.preset_units`), or a frame whose visible
        fragments use more than one material.
    """
    t0 = time.perf_counter()
    if not hasattr(scene, "materials"):
        scene = load_scene(scene, size=size)
    elif size is not None:
        scene = scene.with_size(*((size, size) if isinstance(size, int) else size))
    units = preset_units(preset)
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
    lighting = Lighting(lights=tuple(Light(tuple(l.direction), tuple(l.color)) for l in scene.lights),
                        ambient=tuple(scene.ambient), specular=tuple(mat.specular), shininess=float(mat.shininess))
    t1 = time.perf_counter()
    params, cube_info = PipelineParams.assemble(bump_codes=bump, texture_bytes=mm.color, lighting=lighting,
                                                cube_face=cube_size, preset=units)
    t2 = time.perf_counter()
    N, E, A = np.asarray(frags.N), np.asarray(frags.E), np.asarray(frags.A)
    values = {"U": frags.U, "V": frags.V, "Uc": frags.Uc, "Vc": frags.Vc, "W": frags.W,
              "Nx": N[:, 0], "Ny": N[:, 1], "Nz": N[:, 2], "Ex": E[:, 0], "Ey": E[:, 1], "Ez": E[:, 2]}
    values |= {f"A{i}{j}": A[:, i, j] for i in range(3) for j in range(2)}
    cols, clamped = [], {}
    for port in params.inputs:
        c, flag = quantize(values[port.name], port.fmt, Rounding.HALF_UP, Overflow.SATURATE, f"fragment {port.name}")
        cols.append(c)
        if flag.any():
            clamped[port.name] = int(flag.sum())
    codes = np.stack(cols, 1) if cols and len(frags) else np.zeros((0, len(params.inputs)), np.int64)
    stats = {"fragments": len(frags), "material": mat.name, "cube_size": cube_size,
             "clamped_fragment_inputs": clamped, **cube_info,
             "bump_map_saturated": mm.bump.n_saturated if mm.bump is not None else 0,
             "seconds_front_end": round(t1 - t0, 3), "seconds_tables": round(t2 - t1, 3),
             "seconds_quantize": round(time.perf_counter() - t2, 3)}
    return Frame(scene=scene, params=params, frags=frags, codes=codes, lighting=lighting, maps=mm, stats=stats)


def pipeline_params(scene, preset: str | dict = "default", *, cube_size: int | None = None) -> PipelineParams:
    """The pipeline that renders ``scene``: ``preset``'s units with the scene's memories (bump map, texture and
    the reflectance cubes of ``cube_size`` texels, default the preset's), as ``make sim`` streams it; for ``make verilog`` and
    ``make fpga``.

    ``scene`` is a scene name in ``scenes/`` (``tin-plane``) or a file (see :func:`fxmodel.scene.scene_path`);
    ``preset`` as :func:`prepare`. The scene is prepared at its own size (a fraction of a second for the shipped
    scenes), so the tables, including which material is visible, are exactly those of the rendered frame.
    """
    return prepare(scene_path(scene), preset=preset, cube_size=cube_size).params


def save_png(path, img: np.ndarray) -> Path:
    from PIL import Image
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(path)
    return path


def compose(*imgs: np.ndarray, gap: int = 4) -> np.ndarray:
    """Images side by side on a dark grey gap."""
    h = max(i.shape[0] for i in imgs)
    w = sum(i.shape[1] for i in imgs) + gap * (len(imgs) - 1)
    out = np.full((h, w, 3), 40, dtype=np.uint8)
    x = 0
    for img in imgs:
        out[:img.shape[0], x:x + img.shape[1]] = img
        x += img.shape[1] + gap
    return out


def diff_image(a: np.ndarray, b: np.ndarray, gain: int = DIFF_GAIN) -> np.ndarray:
    return np.clip(np.abs(a.astype(np.int64) - b.astype(np.int64)) * gain, 0, 255).astype(np.uint8)


def metrics(model: np.ndarray, float_a: np.ndarray, ideal_b: np.ndarray) -> dict:
    return {"psnr_db_vs_float": round(psnr(model, float_a), 2), "max_lsb_vs_float": max_lsb(model, float_a),
            "psnr_db_vs_ideal": round(psnr(model, ideal_b), 2), "max_lsb_vs_ideal": max_lsb(model, ideal_b),
            "psnr_db_float_vs_ideal": round(psnr(float_a, ideal_b), 2)}


def render(frame: Frame, out_dir=None, *, references: bool = True) -> dict:
    """Run the bit-exact model (and the references) on a prepared frame; write the images if ``out_dir``."""
    t0 = time.perf_counter()
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
        report.update(metrics(model, a, b))
        images["float"] = frame.image(a)
        images["ideal"] = frame.image(b)
        images["diff"] = compose(frame.image(diff_image(model, a)), frame.image(diff_image(model, b)))
        images["compare"] = compose(images["model"], images["ideal"])
    if out_dir is not None:
        for name, img in images.items():
            save_png(Path(out_dir) / f"{name}.png", img)
    report["_model_bytes"] = model
    return report
