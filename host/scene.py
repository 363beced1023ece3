r"""Scene files: the host-side description of what the pixel pipeline renders (paper, sections 3.2, 4 and 5).

A scene is a TOML file (read with :mod:`tomllib`) holding the image size, a camera, triangle meshes (explicit
triangles, or the ``quad`` and ``sphere`` generators), materials (a color texture and an optional bump map, a
specular color and a Phong exponent), directional colored lights and an ambient term. :func:`load_scene` parses
and validates it into frozen dataclasses; everything is float here (the model side), nothing is quantized.

A malformed file raises **one** :class:`SceneError` naming the file and the key path, e.g.
``scenes/x.toml: materials[1].bump.repeat: expected 2 numbers, got "a"``. Unknown keys are errors too (they are
usually typos). Relative PNG paths resolve against the scene file's folder.

Conventions
-----------
* World space is right-handed; the camera looks from ``position`` toward ``target`` with ``up`` roughly up
  (camera space: x right, y up, looking down -z, as in OpenGL).
* A triangle's **front** side is the one from which its vertices appear counter-clockwise (the right-hand rule:
  ``(P1 - P0) x (P2 - P0)`` points to the front). Back faces are culled unless the mesh is ``two_sided``.
* Vertex normals are normalized on load (a zero normal is an error).
* Texture space: ``u`` runs along a texture's columns (left to right) and ``v`` along its rows **top to bottom**
  (row 0 of a PNG is at ``v = 0``), both with period 1 per tile; ``repeat = [ru, rv]`` tiles a map ``ru`` times
  over ``u`` in ``[0, 1]``. On the ``quad`` generator, seen from its front, ``u`` goes right and ``v`` goes down,
  like reading an image.
* Light ``direction`` points **toward** the light (normalized on load); colors are linear RGB floats.

Schema
------
Limits (module constants, the same for files and command-line options): image edges 1 .. 8192 pixels
(:data:`MAX_IMAGE_SIZE`), map edges 1 .. 4096 texels (PNG files too, from their header; graffiti at least 4
high), every coordinate (positions, targets, origins, edges, centers, radii, texture coordinates, ``near``,
``far``) of magnitude at most 1e6 (:data:`MAX_COORD`), colors of lights, ambient and specular at most 1e3
(:data:`MAX_COLOR`), shininess 1e4, bump strength 1e3, repeats 1e4, ``sigma`` 4096 texels; ``near`` at least
1e-6; at most 2^20 triangles (:data:`MAX_TRIANGLES`, each generator's count checked before it runs). Resource
caps (:mod:`host.scene_types` gives the reasons): at most 2048 x 2048 pixels in all (:data:`MAX_PIXELS`; a
file declaring more is drawn only at a size given that has fewer, such as ``--size``, its own giving the
aspect ratio), 32 lights (:data:`MAX_LIGHTS`), maps of 2 x 4096^2 texels in all materials together
(:data:`MAX_SCENE_TEXELS`), a chiselled text of 4096 characters (:data:`MAX_TEXT`). A file may start with a
UTF-8 byte-order mark.

The complete commented example below is also a valid scene (``SCHEMA_EXAMPLE``, tested)::

    # Top-level keys must come before the first [table].
    name = "example"                 # optional, free text
    ambient = [0.08, 0.08, 0.10]     # ambient RGB >= 0 (default [0, 0, 0])

    [image]
    width = 256                      # pixels, 1 .. 8192, width x height at most 2048 x 2048
    height = 192
    background = [0.0, 0.0, 0.0]     # RGB in [0, 1] where no triangle covers a pixel (default black)

    [camera]
    position = [0.0, 1.0, 4.0]       # eye point, world units
    target = [0.0, 0.0, 0.0]         # looked-at point (must differ from position)
    up = [0.0, 1.0, 0.0]             # must not be parallel to the view direction
    fov = 45.0                       # VERTICAL field of view in degrees, 0 < fov < 180
    near = 0.1                       # clipping distances along the view axis, 0 < near < far
    far = 100.0

    [[lights]]                       # 0 .. 32 of them
    direction = [-1.0, 1.0, 0.5]     # TOWARD the light, world space; normalized on load
    color = [0.7, 0.3, 0.8]          # RGB >= 0

    [[materials]]
    name = "tin"                     # unique; meshes refer to materials by name or 0-based index
    color = [0.55, 0.65, 0.85]       # constant RGB in [0, 1] -- or a table, see the next material
    specular = [1.0, 1.0, 1.0]       # specular RGB >= 0 (default [1, 1, 1])
    shininess = 40.0                 # Phong exponent > 0 (default 32)

    [materials.bump]                 # optional; exactly one of `procedural` / `file`
    procedural = "mexican-hat"       # Ricker wavelet, periodic (paper Fig. 9)
    size = [40, 40]                  # texels [width, height] (default [40, 40])
    sigma = 5.0                      # texels (default min(size) / 8)
    repeat = [8, 8]                  # tiles over u, v in [0, 1]; > 0 (default [1, 1])
    strength = 2.0                   # N' = N - strength * (dh/du T + dh/dv B), h per texel (default 1)

    [[materials]]
    name = "wall"
    specular = [0.2, 0.2, 0.2]
    shininess = 8.0

    [materials.color]                # exactly one of `rgb` / `file` / `procedural`
    procedural = "graffiti"          # or: file = "paint.png" (PNG relative to this file), rgb = [r, g, b]
    size = [256, 128]                # graffiti: texels [width, height] (default [256, 128])
    seed = 11                        # graffiti: random seed (default 1)
    repeat = [1, 1]                  # as for bump maps (default [1, 1])
    # procedural = "checker" takes size (default [64, 64]), checks = [8, 8], colors = [[r,g,b], [r,g,b]]

    [materials.bump]
    procedural = "chiselled-text"    # text carved into a rotten surface (paper Fig. 11)
    text = "Berlin Hauptstadt"       # default
    size = [256, 128]                # texels (default [512, 256])
    font_size = 30                   # pixels of Pillow's default font (default size[1] / 5)
    depth = 0.6                      # carving depth, heights in [0, 1] (default 0.6)
    bevel = 1.5                      # chisel slope width in texels (default 1.5)
    rot = 0.25                       # amplitude of the rotting noise (default 0.25)
    seed = 1995                      # (default 1995)
    strength = 1.5
    # file = "height.png" instead: a greyscale PNG (8 or 16 bit), white = high; heights = value / max in [0, 1]

    [[meshes]]
    kind = "quad"                    # two triangles per cell
    material = "tin"
    origin = [-1.0, 0.0, -1.0]       # the corner at uv[0]
    edge_u = [2.0, 0.0, 0.0]         # to the corner where u = uv[1][0]
    edge_v = [0.0, 0.0, 2.0]         # to the corner where v = uv[1][1]; front normal = edge_v x edge_u (+y)
    uv = [[0.0, 0.0], [1.0, 1.0]]    # (u, v) at origin and at origin + edge_u + edge_v (default)
    divisions = [1, 1]               # cells along u, v (default [1, 1])
    two_sided = false                # default false: back faces culled

    [[meshes]]
    kind = "sphere"                  # UV sphere about the +y axis, analytic normals
    material = 1
    center = [0.0, 0.5, 0.0]
    radius = 0.5
    segments = 24                    # around the axis, >= 3 (default 32)
    rings = 12                       # pole to pole, >= 2 (default 16)
    # u = longitude / 2 pi, from +z toward +x; v = colatitude / pi, from the +y pole down

    [[meshes]]
    kind = "triangles"               # explicit triangles
    material = "tin"
    positions = [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]]
    uvs = [[0.0, 1.0], [1.0, 1.0], [0.5, 0.0]]           # one per position
    normals = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]  # optional (default: face normals)
    # indices = [[0, 1, 2]]          # optional; default: consecutive triples of positions

    [animation]                      # optional: frames drawn in turn (host/scene_animation.py)
    frames = 8                       # 2 .. 240
    camera_path = [[0.0, 1.0, 4.0], [2.0, 1.5, 3.0]]  # 1 .. 16 camera positions, piecewise linear in time
    light_turn = 45.0                # degrees the lights turn about +y, -360 .. 360 (default 0)
"""

from __future__ import annotations

import textwrap
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fxmodel.core.paths import SCENES
from host.meshes import frozen_array, quad_mesh, sphere_mesh
from host.scene_animation import parse_animation
from host.scene_reader import Reader, show_value
from host.scene_types import (
    MAX_COLOR,
    MAX_COORD,
    MAX_IMAGE_SIZE,
    MAX_LIGHTS,
    MAX_MAP_SIZE,
    MAX_PIXELS,
    MAX_REPEAT,
    MAX_SCENE_TEXELS,
    MAX_SHININESS,
    MAX_SIGMA,
    MAX_STRENGTH,
    MAX_TEXT,
    MAX_TRIANGLES,
    MIN_GRAFFITI_HEIGHT,
    BumpSpec,
    Camera,
    ColorSpec,
    Light,
    Material,
    Mesh,
    Scene,
    SceneError,
    Triangles,
)

__all__ = ["SceneError", "Camera", "Light", "ColorSpec", "BumpSpec", "Material", "Mesh", "Scene", "Triangles",
           "SCENES", "scene_path", "load_scene", "scene_at", "parse_scene", "SCHEMA_EXAMPLE",
           "MAX_IMAGE_SIZE", "MAX_MAP_SIZE", "MAX_COORD", "MAX_COLOR", "MAX_SHININESS", "MAX_STRENGTH",
           "MAX_REPEAT", "MAX_SIGMA", "MAX_TRIANGLES", "MAX_LIGHTS", "MAX_SCENE_TEXELS", "MAX_TEXT", "MAX_PIXELS",
           "COLOR_PROCEDURALS", "BUMP_PROCEDURALS"]

# ------------------------------------------------------------------------------------------------------------
# procedural generators: parameter schemas (the generators live in host.bumpmap)
# ------------------------------------------------------------------------------------------------------------
def _size(r: Reader, v, key):
    return r.vector(v, key, 2, lo=1, hi=MAX_MAP_SIZE, integer=True)


def _graffiti_size(r: Reader, v, key):
    size = _size(r, v, key)
    if size[1] < MIN_GRAFFITI_HEIGHT:
        r.fail(key, f"graffiti needs a texture at least {MIN_GRAFFITI_HEIGHT} texels high, got {show_value(v)}")
    return size


def _text(r: Reader, v, key):
    text = r.string(v, key)
    if len(text) > MAX_TEXT:
        r.fail(key, f"{len(text):,} characters, more than the {MAX_TEXT} a chiselled text may have")
    return text


def _rgb01(r: Reader, v, key):
    return r.vector(v, key, 3, lo=0.0, hi=1.0)


#: name -> {param: (default or callable(params) -> default, validator(reader, value, key) -> value)}
COLOR_PROCEDURALS: dict[str, dict[str, tuple[Any, Callable]]] = {
    "graffiti": {
        "size": ((256, 128), _graffiti_size),
        "seed": (1, lambda r, v, k: r.integer(v, k, 0, 2**32 - 1)),
    },
    "checker": {
        "size": ((64, 64), _size),
        "checks": ((8, 8), lambda r, v, k: r.vector(v, k, 2, lo=1, hi=MAX_MAP_SIZE, integer=True)),
        "colors": (((1.0, 1.0, 1.0), (0.1, 0.1, 0.1)),
                   lambda r, v, k: (r.fail(k, f"expected 2 RGB colors, got {show_value(v)}")
                                    if not isinstance(v, list) or len(v) != 2
                                    else tuple(_rgb01(r, c, f"{k}[{i}]") for i, c in enumerate(v)))),
    },
}

BUMP_PROCEDURALS: dict[str, dict[str, tuple[Any, Callable]]] = {
    "mexican-hat": {
        "size": ((40, 40), _size),
        "sigma": (lambda p: min(p["size"]) / 8.0, lambda r, v, k: r.number(v, k, lo=0.0, hi=MAX_SIGMA, lo_open=True)),
    },
    "chiselled-text": {
        "text": ("Berlin Hauptstadt", lambda r, v, k: _text(r, v, k)),
        "size": ((512, 256), _size),
        "font_size": (lambda p: max(4, p["size"][1] // 5), lambda r, v, k: r.integer(v, k, 4, 1000)),
        "depth": (0.6, lambda r, v, k: r.number(v, k, lo=0.0, hi=1.0)),
        "bevel": (1.5, lambda r, v, k: r.number(v, k, lo=0.0, hi=100.0)),
        "rot": (0.25, lambda r, v, k: r.number(v, k, lo=0.0, hi=1.0)),
        "seed": (1995, lambda r, v, k: r.integer(v, k, 0, 2**32 - 1)),
    },
}


def _procedural_params(r: Reader, table: dict, key: str, schema: dict, fixed: tuple[str, ...]) -> tuple:
    for k in table:
        if k not in schema and k not in fixed:
            r.fail(f"{key}.{k}", f"unknown key for procedural {show_value(table['procedural'])} "
                                 f"(allowed: {', '.join(fixed + tuple(schema))})")
    out = {}
    for name, (default, check) in schema.items():       # in schema order: later defaults may use earlier values
        if name in table:
            out[name] = check(r, table[name], f"{key}.{name}")
        else:
            out[name] = default(out) if callable(default) else default
    return tuple(out.items())


# ------------------------------------------------------------------------------------------------------------
# parsing
# ------------------------------------------------------------------------------------------------------------
#: The shipped scenes (``scene_path`` resolves bare names here).


def scene_path(scene) -> Path:
    """The file of a scene given by name in :data:`SCENES` (``tin-plane`` -> ``scenes/tin-plane.toml``) or by
    path (anything with a suffix, returned as given). Existence is checked by :func:`load_scene`."""
    path = Path(scene)
    return path if path.suffix else SCENES / f"{scene}.toml"


def load_scene(path, *, size: int | tuple[int, int] | None = None) -> Scene:
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or pathlib.Path
        The TOML file. Relative PNG paths inside resolve against its folder.
    size : int or (int, int), optional
        Override the image size: ``(width, height)``, or a width with the height keeping the aspect ratio
        (for tests at, e.g., 64 x 64). The override's pixels are checked, not the file's: a file declaring
        more than :data:`MAX_PIXELS` is drawn at a size that has fewer.

    Raises
    ------
    SceneError
        One error naming the file and the key path (also for a missing file or a TOML syntax error).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")          # a byte-order mark is accepted
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text: {exc}") from None
    return _at_size(parse_scene(text, source=str(path), base=path.resolve().parent, path=path,
                                resized=size is not None), size)


def _at_size(scene: Scene, size) -> Scene:
    """``scene`` at ``size``: unchanged for ``None``, ``(width, height)``, or a width with the height keeping the
    aspect ratio (:meth:`Scene.with_size`), the one meaning of a size for :func:`load_scene` and :func:`scene_at`."""
    if size is None:
        return scene
    return scene.with_size(*size) if isinstance(size, tuple) else scene.with_size(size)


def scene_at(scene, size: int | tuple[int, int] | None = None) -> Scene:
    """A scene given by path (loaded by :func:`load_scene`, ``size`` its override) or already loaded (then at
    ``size`` if given), as :func:`host.render.prepare` takes it: ``size`` means the same either way,
    ``(width, height)``, or a width with the height keeping the aspect ratio (:meth:`Scene.with_size`). A file is
    read once, at the size asked, so its own pixels may exceed :data:`MAX_PIXELS`."""
    return load_scene(scene, size=size) if not hasattr(scene, "materials") else _at_size(scene, size)


def parse_scene(text: str, *, source: str = "<string>", base: Path | None = None,
                path: Path | None = None, resized: bool = False) -> Scene:
    """Parse scene TOML ``text``; ``source`` names it in errors, ``base`` resolves relative PNG paths.
    ``resized``: the caller draws it at another size (:meth:`Scene.with_size`, which checks that size's pixels),
    so the declared image gives the aspect ratio alone and may have more pixels than an image may."""
    r = Reader(source)
    base = Path.cwd() if base is None else base
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{source}: TOML syntax error: {exc}") from None
    except RecursionError:              # tomllib recurses per level: [[[[...]]]] a few hundred deep
        raise SceneError(f"{source}: TOML nested too deeply to read (arrays or inline tables within each other "
                         "hundreds of levels deep; a scene needs a few)") from None
    r.table(doc, "", ("name", "ambient", "image", "camera", "lights", "materials", "meshes", "animation"),
            ("image", "camera", "materials", "meshes"))
    name = r.string(doc.get("name", path.stem if path else "scene"), "name")
    ambient = r.vector(doc.get("ambient", [0, 0, 0]), "ambient", 3, lo=0.0, hi=MAX_COLOR)

    img = r.table(doc["image"], "image", ("width", "height", "background"), ("width", "height"))
    width = r.integer(img["width"], "image.width", 1, MAX_IMAGE_SIZE)
    height = r.integer(img["height"], "image.height", 1, MAX_IMAGE_SIZE)
    if width * height > MAX_PIXELS and not resized:
        r.fail("image", f"{width} x {height} is {width * height:,} pixels, more than the {MAX_PIXELS:,} "
                        "(2048 x 2048) an image may have")
    background = _rgb01(r, img.get("background", [0, 0, 0]), "image.background")

    camera = _camera(r, doc["camera"])

    lights = []
    light_tables = r.array_of_tables(doc.get("lights", []), "lights")
    if len(light_tables) > MAX_LIGHTS:
        r.fail("lights", f"{len(light_tables):,} lights, more than the {MAX_LIGHTS} a scene may have")
    for i, t in enumerate(light_tables):
        key = f"lights[{i}]"
        r.table(t, key, ("direction", "color"), ("direction", "color"))
        d = np.array(r.vector(t["direction"], f"{key}.direction", 3, nonzero=True, mag=MAX_COORD))
        if not np.linalg.norm(d) > 1e-9 * np.abs(d).max():
            r.fail(f"{key}.direction", f"too short to normalize, got {show_value(t['direction'])}")
        lights.append(Light(tuple(float(x) for x in d / np.linalg.norm(d)),
                            r.vector(t["color"], f"{key}.color", 3, lo=0.0, hi=MAX_COLOR)))

    mats = r.array_of_tables(doc["materials"], "materials")
    if not mats:
        r.fail("materials", "at least one material is needed")
    materials = [_material(r, t, f"materials[{i}]", base) for i, t in enumerate(mats)]
    names = {}
    for i, m in enumerate(materials):
        if m.name in names:
            r.fail(f"materials[{i}].name", f"{show_value(m.name)} is already the name of materials[{names[m.name]}]")
        names[m.name] = i
    _texel_budget(r, materials)

    meshes, count = [], 0
    for i, t in enumerate(r.array_of_tables(doc["meshes"], "meshes")):
        # each mesh's count is checked against what the meshes before it leave of the budget, before its
        # generator runs: many meshes, each within the budget alone, must not all be built first
        meshes.append(_mesh(r, t, f"meshes[{i}]", names, len(materials), before=count))
        count += meshes[-1].n_triangles
    anim = parse_animation(r, doc["animation"], camera, lights) if "animation" in doc else None
    return Scene(path=path, name=name, width=width, height=height, background=background, camera=camera,
                 ambient=ambient, lights=tuple(lights), materials=tuple(materials), meshes=tuple(meshes),
                 animation=anim)


def _camera(r: Reader, t) -> Camera:
    r.table(t, "camera", ("position", "target", "up", "fov", "near", "far"), ("position", "target", "fov"))
    pos = r.vector(t["position"], "camera.position", 3, mag=MAX_COORD)
    tgt = r.vector(t["target"], "camera.target", 3, mag=MAX_COORD)
    up = r.vector(t.get("up", [0, 1, 0]), "camera.up", 3, nonzero=True, mag=MAX_COORD)
    fov = r.number(t["fov"], "camera.fov", lo=0.0, hi=180.0, lo_open=True, hi_open=True)
    near = r.number(t.get("near", 0.1), "camera.near", lo=1e-6, hi=MAX_COORD)
    far = r.number(t.get("far", 1000.0), "camera.far", lo=1e-6, hi=4 * MAX_COORD)
    if far <= near:
        r.fail("camera.far", f"must be greater than camera.near ({near:g}), got {show_value(t.get('far'))}")
    f = np.subtract(tgt, pos)
    if not np.linalg.norm(f) > 1e-9 * max(1.0, np.abs(pos).max()):
        r.fail("camera.target", f"must differ from camera.position, got {show_value(t['target'])}")
    f = f / np.linalg.norm(f)
    u = np.asarray(up) / np.linalg.norm(up)
    if np.linalg.norm(np.cross(f, u)) < 1e-6:
        r.fail("camera.up", "must not be parallel to the view direction target - position, "
               f"got {show_value(t.get('up'))}")
    return Camera(pos, tgt, up, fov, near, far)


def _repeat(r: Reader, t: dict, key: str):
    return r.vector(t.get("repeat", [1, 1]), f"{key}.repeat", 2, lo=0.0, lo_open=True, hi=MAX_REPEAT)


def _material(r: Reader, t, key: str, base: Path) -> Material:
    r.table(t, key, ("name", "color", "bump", "specular", "shininess"), ("name",))
    name = r.string(t["name"], f"{key}.name")
    if not name:
        r.fail(f"{key}.name", "must not be empty")
    color = _color(r, t.get("color", [0.8, 0.8, 0.8]), f"{key}.color", base)
    bump = _bump(r, t["bump"], f"{key}.bump", base) if "bump" in t else None
    specular = r.vector(t.get("specular", [1, 1, 1]), f"{key}.specular", 3, lo=0.0, hi=MAX_COLOR)
    shininess = r.number(t.get("shininess", 32.0), f"{key}.shininess", lo=0.0, lo_open=True, hi=MAX_SHININESS)
    return Material(name, color, bump, specular, shininess)


def _one_of(r: Reader, t: dict, key: str, options: tuple[str, ...]) -> str:
    present = [o for o in options if o in t]
    if len(present) != 1:
        r.fail(key, f"needs exactly one of {', '.join(repr(o) for o in options)}"
                    + (f", got {', '.join(repr(p) for p in present)}" if present else ""))
    return present[0]


def _color(r: Reader, v, key: str, base: Path) -> ColorSpec:
    if isinstance(v, list):
        return ColorSpec("rgb", rgb=_rgb01(r, v, key), key=key)
    if not isinstance(v, dict):
        r.fail(key, f"expected [r, g, b] or a table, got {show_value(v)}")
    kind = _one_of(r, v, key, ("rgb", "file", "procedural"))
    if kind == "procedural":
        proc = r.string(v["procedural"], f"{key}.procedural", tuple(COLOR_PROCEDURALS))
        params = _procedural_params(r, v, key, COLOR_PROCEDURALS[proc], ("procedural", "repeat"))
        return ColorSpec("procedural", procedural=proc, params=params, repeat=_repeat(r, v, key), key=key)
    r.table(v, key, (kind, "repeat"))
    if kind == "rgb":
        return ColorSpec("rgb", rgb=_rgb01(r, v["rgb"], f"{key}.rgb"), repeat=_repeat(r, v, key), key=key)
    return ColorSpec("file", path=r.png(v["file"], f"{key}.file", base), repeat=_repeat(r, v, key), key=key)


def _bump(r: Reader, v, key: str, base: Path) -> BumpSpec:
    if not isinstance(v, dict):
        r.fail(key, f"expected a table, got {show_value(v)}")
    kind = _one_of(r, v, key, ("file", "procedural"))
    common = ("repeat", "strength")
    strength = r.number(v.get("strength", 1.0), f"{key}.strength", lo=0.0, hi=MAX_STRENGTH)
    if kind == "procedural":
        proc = r.string(v["procedural"], f"{key}.procedural", tuple(BUMP_PROCEDURALS))
        params = _procedural_params(r, v, key, BUMP_PROCEDURALS[proc], ("procedural",) + common)
        return BumpSpec("procedural", procedural=proc, params=params, repeat=_repeat(r, v, key),
                        strength=strength, key=key)
    r.table(v, key, ("file",) + common)
    return BumpSpec("file", path=r.png(v["file"], f"{key}.file", base), repeat=_repeat(r, v, key),
                    strength=strength, key=key)


def _map_texels(r: Reader, spec) -> int:
    """Texels of a material's color texture or bump map (a PNG's from the size :meth:`Reader.png` read from its
    header; a constant color, a 1 x 1 texture, is not counted)."""
    if spec is None:
        return 0
    if spec.kind == "procedural":
        w, h = spec.kwargs["size"]
        return w * h
    if spec.kind == "file":
        w, h = r.png_sizes[spec.path]
        return w * h
    return 0


def _texel_budget(r: Reader, materials) -> None:
    """Refuse maps of more than :data:`MAX_SCENE_TEXELS` texels in all (every material's are built), naming the
    first material beyond it; before any map is built."""
    total = 0
    for i, m in enumerate(materials):
        total += _map_texels(r, m.color) + _map_texels(r, m.bump)
        if total > MAX_SCENE_TEXELS:
            r.fail(f"materials[{i}]", f"its maps bring the scene's maps to {total:,} texels, more than the "
                                      f"{MAX_SCENE_TEXELS:,} (two of {MAX_MAP_SIZE} x {MAX_MAP_SIZE}) a scene "
                                      "may have: every material's maps are built, though a frame shows one")


def _triangle_budget(r: Reader, count: int, key: str, before: int = 0) -> None:
    """Refuse ``count`` more triangles after the ``before`` of the meshes before this one, beyond
    :data:`MAX_TRIANGLES` (called before a generator runs)."""
    if before + count > MAX_TRIANGLES:
        more = f" after the {before:,} of the meshes before it" if before else ""
        r.fail(key, f"makes {count:,} triangles{more}, more than the {MAX_TRIANGLES:,} a scene may hold")


def _unit_rows(r: Reader, n: np.ndarray, key: str) -> np.ndarray:
    length = np.linalg.norm(n, axis=-1)
    bad = np.flatnonzero(length.ravel() == 0)
    if bad.size:
        r.fail(f"{key}[{bad[0]}]", "zero-length normal")
    return n / length[..., None]


def _mesh(r: Reader, t, key: str, names: dict, n_mat: int, before: int = 0) -> Mesh:
    if not isinstance(t, dict):
        r.fail(key, f"expected a table, got {show_value(t)}")
    if "kind" not in t:
        r.fail(f"{key}.kind", "missing (one of 'triangles', 'quad', 'sphere')")
    kind = r.string(t["kind"], f"{key}.kind", ("triangles", "quad", "sphere"))
    common = ("kind", "material", "two_sided")
    if kind == "triangles":
        r.table(t, key, common + ("positions", "uvs", "normals", "indices"), ("material", "positions", "uvs"))
    elif kind == "quad":
        r.table(t, key, common + ("origin", "edge_u", "edge_v", "uv", "divisions"),
                ("material", "origin", "edge_u", "edge_v"))
    else:
        r.table(t, key, common + ("center", "radius", "segments", "rings"), ("material", "center", "radius"))
    mat = t["material"]
    if isinstance(mat, str):
        if mat not in names:
            r.fail(f"{key}.material", f"no material is named {show_value(mat)} (names: {', '.join(names)})")
        mat = names[mat]
    else:
        mat = r.integer(mat, f"{key}.material", 0, n_mat - 1)
    two_sided = r.boolean(t.get("two_sided", False), f"{key}.two_sided")

    if kind == "triangles":
        pos = r.vectors(t["positions"], f"{key}.positions", 3, mag=MAX_COORD)
        uvs = r.vectors(t["uvs"], f"{key}.uvs", 2, mag=MAX_COORD)
        if len(uvs) != len(pos):
            r.fail(f"{key}.uvs", f"expected {len(pos)} [u, v] pairs (one per position), got {len(uvs)}")
        nrm = None
        if "normals" in t:
            nrm = _unit_rows(r, r.vectors(t["normals"], f"{key}.normals", 3, mag=MAX_COORD), f"{key}.normals")
            if len(nrm) != len(pos):
                r.fail(f"{key}.normals", f"expected {len(pos)} normals (one per position), got {len(nrm)}")
        if "indices" in t:
            idx = t["indices"]
            if not isinstance(idx, list) or not idx:
                r.fail(f"{key}.indices", f"expected a non-empty list of [i, j, k], got {show_value(idx)}")
            idx = np.array([r.vector(x, f"{key}.indices[{i}]", 3, lo=0, hi=len(pos) - 1, integer=True)
                            for i, x in enumerate(idx)], dtype=np.int64)
        else:
            if len(pos) % 3:
                r.fail(f"{key}.positions", f"without indices, expected a multiple of 3 vertices, got {len(pos)}")
            idx = np.arange(len(pos)).reshape(-1, 3)
        _triangle_budget(r, len(idx), f"{key}.indices" if "indices" in t else f"{key}.positions", before)
        P, UV = pos[idx], uvs[idx]
        cross = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
        area = np.linalg.norm(cross, axis=-1)
        if np.any(area == 0):
            i = int(np.flatnonzero(area == 0)[0])
            r.fail(f"{key}.{'indices' if 'indices' in t else 'positions'}", f"triangle {i} has zero area")
        N = nrm[idx] if nrm is not None else np.repeat((cross / area[:, None])[:, None], 3, axis=1)
        P, N, UV = frozen_array(P), frozen_array(N), frozen_array(UV)
    elif kind == "quad":
        o = r.vector(t["origin"], f"{key}.origin", 3, mag=MAX_COORD)
        eu = r.vector(t["edge_u"], f"{key}.edge_u", 3, nonzero=True, mag=MAX_COORD)
        ev = r.vector(t["edge_v"], f"{key}.edge_v", 3, nonzero=True, mag=MAX_COORD)
        if np.linalg.norm(np.cross(ev, eu)) <= 1e-12 * np.linalg.norm(eu) * np.linalg.norm(ev):
            r.fail(f"{key}.edge_v", f"must not be parallel to edge_u, got {show_value(t['edge_v'])}")
        uv = t.get("uv", [[0, 0], [1, 1]])
        if not isinstance(uv, list) or len(uv) != 2:
            r.fail(f"{key}.uv", f"expected [[u0, v0], [u1, v1]], got {show_value(uv)}")
        uv = tuple(r.vector(x, f"{key}.uv[{i}]", 2, mag=MAX_COORD) for i, x in enumerate(uv))
        if uv[0][0] == uv[1][0] or uv[0][1] == uv[1][1]:
            r.fail(f"{key}.uv", f"u0 must differ from u1 and v0 from v1, got {show_value(t['uv'])}")
        div = r.vector(t.get("divisions", [1, 1]), f"{key}.divisions", 2, lo=1, hi=1024, integer=True)
        _triangle_budget(r, 2 * div[0] * div[1], f"{key}.divisions", before)
        P, N, UV = quad_mesh(o, eu, ev, uv, div)
    else:
        c = r.vector(t["center"], f"{key}.center", 3, mag=MAX_COORD)
        rad = r.number(t["radius"], f"{key}.radius", lo=0.0, lo_open=True, hi=MAX_COORD)
        seg = r.integer(t.get("segments", 32), f"{key}.segments", 3, 4096)
        rings = r.integer(t.get("rings", 16), f"{key}.rings", 2, 4096)
        _triangle_budget(r, 2 * seg * (rings - 1), f"{key}.segments", before)
        P, N, UV = sphere_mesh(c, rad, seg, rings)
    return Mesh(kind, mat, two_sided, P, N, UV, key)


#: The commented example of the module docstring, as TOML text (the lead can paste it into the README).
SCHEMA_EXAMPLE = textwrap.dedent(__doc__.split("tested)::\n\n", 1)[1]).strip() + "\n"
