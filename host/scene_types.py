"""The parsed scene: cameras, lights, materials, meshes and their limits (the schema's types), as
:func:`host.scene.load_scene` returns them. The file format and its reader are :mod:`host.scene`."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

#: Limits of the schema, stated once: what a file may hold is what the pipeline can compute (anything beyond is
#: refused by key before any work). Image edge in pixels; map (texture, bump map) edge in texels.
MAX_IMAGE_SIZE = 8192
MAX_MAP_SIZE = 4096
#: Largest magnitude of a world coordinate (positions, targets, mesh origins and edges, sphere centers and radii,
#: clipping distances) and of a texture coordinate: far beyond any scene, far below where squares overflow.
MAX_COORD = 1e6
#: Largest light, ambient or specular color component (linear RGB; 1 is full scale).
MAX_COLOR = 1e3
#: Largest Phong exponent, bump strength, map repeat count and Mexican-hat sigma (texels).
MAX_SHININESS = 1e4
MAX_STRENGTH = 1e3
MAX_REPEAT = 1e4
MAX_SIGMA = float(MAX_MAP_SIZE)
#: Most triangles a scene may hold (all meshes together; a mesh generator's count is checked before it runs).
MAX_TRIANGLES = 1 << 20
#: Smallest graffiti texture height (its bands need this many texels).
MIN_GRAFFITI_HEIGHT = 4
#: Resource caps (not what the hardware holds, but what keeps the host's work on one small file bounded):
#: every material's maps are built before the frame is drawn (a full-size map takes 30 to 40 s and 1.5 to 5 GB),
#: though a frame shows one material: the texels of all maps together are at most one material's color texture
#: and bump map at the largest size. Each light is a pass over every texel of both reflectance cubes (about 1 s
#: a light at the largest cube, 1024): at most 32 lights. A chiselled text is measured whole at every font size
#: tried (Pillow refuses 10^6 characters): at most 4096 characters, more than the largest map shows at the
#: smallest font (4 pixels).
MAX_SCENE_TEXELS = 2 * MAX_MAP_SIZE ** 2
#: The image's pixels (width x height, the file's or an override's such as ``--size``): the model keeps about
#: 850 bytes a pixel of a covered frame at its peak (a 1024 x 1024 frame: 0.9 GB and 63 s), so an 8192 x 8192
#: one needed some 55 GB and an hour, and was killed for memory without a message. 2048 x 2048 (about 3.5 GB)
#: at most; an edge may still be 8192 (:data:`MAX_IMAGE_SIZE`, what the scan converter resolves).
MAX_PIXELS = 2048 * 2048
MAX_LIGHTS = 32
MAX_TEXT = 4096


class SceneError(ValueError):
    """A malformed scene file: the message names the file and the key path."""


# ------------------------------------------------------------------------------------------------------------
# parsed scene
# ------------------------------------------------------------------------------------------------------------
Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Camera:
    """Perspective camera (paper section 4: homogeneous x, y, z, w; w is the distance along the view axis).

    Attributes
    ----------
    position, target, up : tuple of 3 float
        World space. ``up`` need only not be parallel to ``target - position``.
    fov : float
        Vertical field of view in degrees.
    near, far : float
        Clipping distances along the view axis, ``0 < near < far``.
    """

    position: Vec3
    target: Vec3
    up: Vec3
    fov: float
    near: float
    far: float

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(right, up, forward)``: orthonormal world vectors, ``right = forward x up`` (right-handed)."""
        f = np.subtract(self.target, self.position, dtype=np.float64)
        f /= np.linalg.norm(f)
        r = np.cross(f, np.asarray(self.up, dtype=np.float64))
        r /= np.linalg.norm(r)
        return r, np.cross(r, f), f


@dataclass(frozen=True)
class Light:
    """Directional light: ``direction`` is a unit vector toward the light; ``color`` linear RGB >= 0."""

    direction: Vec3
    color: Vec3


@dataclass(frozen=True)
class ColorSpec:
    """A material's color texture.

    Attributes
    ----------
    kind : {"rgb", "file", "procedural"}
    rgb : tuple of 3 float or None
        Constant color in [0, 1] (``kind == "rgb"``).
    path : pathlib.Path or None
        Absolute path of the PNG (``kind == "file"``).
    procedural : str or None
        Generator name, one of :data:`COLOR_PROCEDURALS` (``kind == "procedural"``).
    params : tuple of (str, value)
        Generator parameters, defaults filled in (see :attr:`kwargs`).
    repeat : tuple of 2 float
        Tiles over ``u`` and ``v`` in ``[0, 1]``.
    key : str
        Key path in the scene file (for messages), e.g. ``materials[1].color``.
    """

    kind: str
    rgb: Vec3 | None = None
    path: Path | None = None
    procedural: str | None = None
    params: tuple = ()
    repeat: tuple[float, float] = (1.0, 1.0)
    key: str = ""

    @property
    def kwargs(self) -> dict:
        return dict(self.params)


@dataclass(frozen=True)
class BumpSpec:
    """A material's bump map (paper section 3.2; Fig. 9 and Fig. 11).

    Attributes
    ----------
    kind : {"file", "procedural"}
    path : pathlib.Path or None
        Absolute path of the greyscale height PNG (``kind == "file"``).
    procedural : str or None
        One of :data:`BUMP_PROCEDURALS`.
    params : tuple of (str, value)
        Generator parameters with defaults filled in.
    repeat : tuple of 2 float
        Tiles over ``u`` and ``v`` in ``[0, 1]``.
    strength : float
        Slope multiplier: ``N' = N - strength (dh/du T + dh/dv B)``, ``h`` differentiated per texel.
    key : str
        Key path in the scene file.
    """

    kind: str
    path: Path | None = None
    procedural: str | None = None
    params: tuple = ()
    repeat: tuple[float, float] = (1.0, 1.0)
    strength: float = 1.0
    key: str = ""

    @property
    def kwargs(self) -> dict:
        return dict(self.params)


@dataclass(frozen=True)
class Material:
    """Color texture, optional bump map, specular color and Phong exponent."""

    name: str
    color: ColorSpec
    bump: BumpSpec | None
    specular: Vec3
    shininess: float


@dataclass(frozen=True)
class Mesh:
    """Triangles of one material, as read-only float64 arrays.

    Attributes
    ----------
    kind : {"triangles", "quad", "sphere"}
    material : int
        Index into :attr:`Scene.materials`.
    two_sided : bool
        If false, back faces are culled; if true they are drawn with ``N`` and ``A`` negated.
    positions : ndarray, shape (T, 3, 3)
        Vertex positions, world space, counter-clockwise seen from the front.
    normals : ndarray, shape (T, 3, 3)
        Unit vertex normals.
    uvs : ndarray, shape (T, 3, 2)
        Texture coordinates ``(u, v)`` per vertex (before any repeat).
    key : str
        Key path in the scene file, e.g. ``meshes[0]``.
    """

    kind: str
    material: int
    two_sided: bool
    positions: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    uvs: np.ndarray = field(repr=False)
    key: str = ""

    @property
    def n_triangles(self) -> int:
        return self.positions.shape[0]


class Triangles(NamedTuple):
    """All triangles of a scene, concatenated in file order (:meth:`Scene.triangles`)."""

    positions: np.ndarray      # (T, 3, 3)
    normals: np.ndarray        # (T, 3, 3)
    uvs: np.ndarray            # (T, 3, 2)
    material: np.ndarray       # (T,) int64
    two_sided: np.ndarray      # (T,) bool
    mesh: np.ndarray           # (T,) int64


@dataclass(frozen=True)
class Scene:
    """A parsed, validated scene (see the module docstring for the file format).

    Attributes
    ----------
    path : pathlib.Path or None
        The scene file (None for a scene parsed from a string).
    name : str
    width, height : int
        Image size in pixels.
    background : tuple of 3 float
    camera : Camera
    ambient : tuple of 3 float
    lights : tuple of Light
    materials : tuple of Material
    meshes : tuple of Mesh
    animation : host.scene_animation.Animation or None
        A camera path and a turn of the lights (``[animation]``), or none.
    """

    path: Path | None
    name: str
    width: int
    height: int
    background: Vec3
    camera: Camera
    ambient: Vec3
    lights: tuple[Light, ...]
    materials: tuple[Material, ...]
    meshes: tuple[Mesh, ...]
    animation: object = None

    def with_size(self, width: int, height: int | None = None) -> Scene:
        """The same scene at another image size; ``height`` defaults to keeping the aspect ratio."""
        if height is None:
            height = max(1, round(width * self.height / self.width))
        for name, v in (("width", width), ("height", height)):
            if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= MAX_IMAGE_SIZE:
                raise ValueError(f"{name}={v!r}: must be an int in 1..{MAX_IMAGE_SIZE}")
        if width * height > MAX_PIXELS:
            raise ValueError(f"{self.path or self.name}: at {width} x {height}, {width * height:,} pixels, more than "
                             f"the {MAX_PIXELS:,} (2048 x 2048) an image may have")
        return replace(self, width=width, height=height)

    def triangles(self) -> Triangles:
        """All triangles, concatenated over the meshes in file order (the front end's triangle index)."""
        if not self.meshes:
            z = np.zeros((0, 3, 3))
            return Triangles(z, z, np.zeros((0, 3, 2)), np.zeros(0, np.int64), np.zeros(0, bool),
                             np.zeros(0, np.int64))
        counts = [m.n_triangles for m in self.meshes]
        return Triangles(
            np.concatenate([m.positions for m in self.meshes]),
            np.concatenate([m.normals for m in self.meshes]),
            np.concatenate([m.uvs for m in self.meshes]),
            np.repeat(np.array([m.material for m in self.meshes], np.int64), counts),
            np.repeat(np.array([m.two_sided for m in self.meshes], bool), counts),
            np.repeat(np.arange(len(self.meshes), dtype=np.int64), counts))
