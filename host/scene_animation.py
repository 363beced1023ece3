"""A scene's animation (the optional ``[animation]`` table of a scene file, ``host/scene.py``): a camera path and
a turn of the lights, drawn as ``frames`` pictures in turn (the paper's renderer drew animated scenes, section 5:
"an animation of the Berlin wall"). :func:`frames` gives each frame's scene; the board's host tool sends them one
after another (``bumpmap send``), ``bumpmap animate`` writes the model's frames as an animated picture.

Schema (validated like the rest of the file; limits are module constants)::

    [animation]
    frames = 24                       # pictures, 2 .. 240 (MAX_FRAMES)
    camera_path = [[0.0, 2.9, 3.5], [1.5, 2.5, 3.0]]   # camera positions, 1 .. 16 keys (MAX_KEYS), the camera
                                      # moving along them piecewise linearly, evenly in time, looking at
                                      # camera.target (default: camera.position alone)
    light_turn = 90.0                 # degrees every light turns about the world's +y axis over the
                                      # animation, -360 .. 360 (default 0)
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from host.scene_reader import Reader
from host.scene_types import MAX_COORD, Camera, Light

__all__ = ["Animation", "MAX_FRAMES", "MAX_KEYS", "parse_animation", "frames"]

#: Limits: pictures of an animation, camera keys.
MAX_FRAMES, MAX_KEYS = 240, 16


@dataclass(frozen=True)
class Animation:
    """``frames`` pictures; the camera at ``camera_path`` (keys, evenly spaced in time); the lights turned by
    ``light_turn`` degrees about +y from the first frame to the last."""

    frames: int
    camera_path: tuple
    light_turn: float = 0.0


def _camera_at(path: np.ndarray, t: float) -> np.ndarray:
    """The position on the piecewise-linear ``path`` at time ``t`` in [0, 1]."""
    if len(path) == 1:
        return path[0]
    s = t * (len(path) - 1)
    k = min(int(s), len(path) - 2)
    return path[k] + (s - k) * (path[k + 1] - path[k])


def _turn(d, degrees: float) -> tuple:
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    x, y, z = d
    return (float(c * x + s * z), float(y), float(-s * x + c * z))


def _frame(camera: Camera, lights, anim: Animation, k: int):
    t = k / (anim.frames - 1)
    pos = tuple(float(v) for v in _camera_at(np.asarray(anim.camera_path, dtype=float), t))
    return (replace(camera, position=pos),
            tuple(Light(_turn(li.direction, anim.light_turn * t), li.color) for li in lights))


def parse_animation(r: Reader, t, camera: Camera, lights) -> Animation:
    """The ``[animation]`` table, each frame's camera checked as ``[camera]`` is (not at the target, its view
    direction not parallel to ``up``)."""
    r.table(t, "animation", ("frames", "camera_path", "light_turn"), ("frames",))
    n = r.integer(t["frames"], "animation.frames", 2, MAX_FRAMES)
    path = r.vectors(t.get("camera_path", [list(camera.position)]), "animation.camera_path", 3, mag=MAX_COORD)
    if not 1 <= len(path) <= MAX_KEYS:
        r.fail("animation.camera_path", f"needs 1 .. {MAX_KEYS} positions, got {len(path)}")
    turn = r.number(t.get("light_turn", 0.0), "animation.light_turn", lo=-360.0, hi=360.0)
    anim = Animation(n, tuple(tuple(float(v) for v in p) for p in path), float(turn))
    up = np.asarray(camera.up) / np.linalg.norm(camera.up)
    for k in range(n):
        cam, _ = _frame(camera, lights, anim, k)
        f = np.asarray(camera.target) - np.asarray(cam.position)
        if not np.linalg.norm(f) > 1e-9:
            r.fail("animation.camera_path", f"frame {k}: the camera reaches camera.target")
        if np.linalg.norm(np.cross(f / np.linalg.norm(f), up)) < 1e-6:
            r.fail("animation.camera_path", f"frame {k}: the view direction is parallel to camera.up")
    return anim


def frames(scene) -> list:
    """The scenes of the animation's frames in order (``[scene]`` without an animation)."""
    anim = scene.animation
    if anim is None:
        return [scene]
    out = []
    for k in range(anim.frames):
        cam, lights = _frame(scene.camera, scene.lights, anim, k)
        out.append(replace(scene, camera=cam, lights=lights))
    return out
