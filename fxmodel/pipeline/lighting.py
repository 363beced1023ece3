r"""Reflectance cubes: all light sources baked into a diffuse and a specular cube map (paper, sections 2 and 4).

"Another six sided cube map can be used which can be indexed by the unnormalized normal vector" (diffuse), and
the specular cube is indexed by the reflection vector (EQ 1); since the lights live in the cubes, any number of
colored light sources costs nothing per pixel, and a local viewer only changes the reflection vector.

Host-side, float64, quantized once (:func:`fxmodel.core.rounding.quantize`, half-up, saturating with a count):

* diffuse factor ``D(n) = ambient + sum_l c_l max(0, n . l)`` per channel (multiplies the texture albedo);
* specular ``S(r) = 255 sum_l k_s c_l max(0, r . l)**shininess`` per channel, in output-byte units
  (see :mod:`fxmodel.units.shade`);

evaluated at the direction of every texel centre. Face orientation is the OpenGL / Vulkan table of
``docs/design.md`` ("Cube faces: table and tie rule"; the cube address unit's): texel ``(i, j)`` of a face of ``F x
F`` texels has ``s = (i + 1/2) / F``, ``t = (j + 1/2) / F`` and ``(s_c, t_c) = (2s - 1, 2t - 1)``;
:func:`face_directions` inverts the table. The same float functions serve the ideal per-pixel Phong reference, so the
two differ only by what the cube method itself costs (sampling the lighting at texel centres and blending).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, quantize
from fxmodel.units.sampler import Texels

__all__ = ["Light", "Lighting", "face_directions", "bake_cubes"]


@dataclass(frozen=True)
class Light:
    """A directional light: ``direction`` points toward the light (normalized here), ``color`` is RGB."""

    direction: tuple
    color: tuple

    def unit(self) -> np.ndarray:
        d = np.asarray(self.direction, dtype=np.float64)
        n = np.linalg.norm(d)
        if not np.isfinite(n) or n == 0:
            raise ValueError(f"light direction {self.direction!r} has no direction")
        return d / n


@dataclass(frozen=True)
class Lighting:
    """Everything a scene's reflectance cubes depend on."""

    lights: tuple
    ambient: tuple = (0.0, 0.0, 0.0)
    specular: tuple = (1.0, 1.0, 1.0)
    shininess: float = 32.0

    def diffuse_factor(self, n: np.ndarray) -> np.ndarray:
        """``ambient + sum c_l max(0, n.l)`` for unit vectors ``n`` of shape ``(..., 3)``: ``(..., 3)``."""
        out = np.broadcast_to(np.asarray(self.ambient, dtype=np.float64), n.shape[:-1] + (3,)).copy()
        for light in self.lights:
            out += np.maximum(0.0, n @ light.unit())[..., None] * np.asarray(light.color, dtype=np.float64)
        return out

    def specular_bytes(self, r: np.ndarray) -> np.ndarray:
        """``255 sum k_s c_l max(0, r.l)**shininess`` for unit vectors ``r``: ``(..., 3)``."""
        out = np.zeros(r.shape[:-1] + (3,))
        ks = np.asarray(self.specular, dtype=np.float64)
        for light in self.lights:
            lobe = np.maximum(0.0, r @ light.unit()) ** self.shininess
            out += 255.0 * lobe[..., None] * ks * np.asarray(light.color, dtype=np.float64)
        return out


def face_directions(size: int, border: int = 0) -> np.ndarray:
    """Unit directions of the texel centres of the six faces: ``(6, size + 2 border, size + 2 border, 3)`` indexed
    ``[face, j, i]``; a border continues each face's grid past its edges (``|s_c| > 1`` there: those directions
    belong to the neighbouring faces, which makes bilinear filtering seamless)."""
    c = (np.arange(-border, size + border) + 0.5) / size * 2 - 1
    sc, tc = np.meshgrid(c, c)                    # [j, i]: s along i, t along j
    one = np.ones_like(sc)
    dirs = np.stack([
        np.stack([one, -tc, -sc], -1),            # +x: s_c = -z, t_c = -y
        np.stack([-one, -tc, sc], -1),            # -x: s_c = +z, t_c = -y
        np.stack([sc, one, tc], -1),              # +y: s_c = +x, t_c = +z
        np.stack([sc, -one, -tc], -1),            # -y: s_c = +x, t_c = -z
        np.stack([sc, -tc, one], -1),             # +z: s_c = +x, t_c = -y
        np.stack([-sc, -tc, -one], -1),           # -z: s_c = -x, t_c = -y
    ])
    return dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)


def bake_cubes(lighting: Lighting, size: int, diffuse_fmt: Fmt, specular_fmt: Fmt, border: int = 0):
    """Quantized diffuse and specular cubes as :class:`~fxmodel.units.sampler.Texels`
    ``(6, size + 2 border, size + 2 border, 3)``, and the number of texel channels that saturated in each (they
    are clamped, never wrapped)."""
    if not isinstance(size, int) or size < 1:
        raise ValueError(f"cube face size={size!r}: must be a positive int")
    dirs = face_directions(size, border)
    d, dflag = quantize(lighting.diffuse_factor(dirs), diffuse_fmt, Rounding.HALF_UP, Overflow.SATURATE,
                        "diffuse cube")
    s, sflag = quantize(lighting.specular_bytes(dirs), specular_fmt, Rounding.HALF_UP, Overflow.SATURATE,
                        "specular cube")
    return Texels(d), Texels(s), {"diffuse_saturated": int(dflag.sum()), "specular_saturated": int(sflag.sum())}
