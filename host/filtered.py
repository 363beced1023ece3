r"""Reference (a) with filtering: the float model of the filtering choices (MIP maps, LEAN, anisotropy), to
choose among them by measurement against the true image (:mod:`host.truth`) before any hardware is built (paper
section 6).

:func:`render_filtered` is :func:`host.reference.float_pipeline` (perspective division, bump-map lookup,
``N' = N + du A0 + dv A1``, EQ 1, bilinear reflectance-cube lookups, ``b D + S``) with the two map lookups
replaced by the filtered ones of :mod:`host.mipmap` and, for LEAN bump maps, the specular lobe widened by the
slope variance the filter averaged away:

* the slope covariance ``Sigma`` moves the unit normal by ``P A d / |N'|`` for a slope change ``d`` and the
  reflection vector by ``J`` times that (:func:`lobe_widening`: twice the tilt in the plane of incidence,
  ``2 (n.e)`` times across it), so a Phong lobe ``cos^s`` (angular variance ``1 / s`` per axis) convolved with
  the reflection vector's spread has ``1 / s' = 1 / s + sigma_R^2`` (half the trace of its covariance; Toksvig
  2004 and LEAN, Olano & Baker 2010, give the same first-order widening), and keeps its energy: it is scaled by
  ``(s' + 1) / (s + 1)``;
* ``lean="moments"`` takes ``Sigma = M - B B^T`` from the filtered ``B`` and ``M`` (LEAN as published: bilinear
  blending of two texels with different slopes counts as variance, even where the pixel is smaller than a
  texel); ``lean="covariance"`` stores each texel's own ``M - B B^T`` in the pyramid (zero at level 0) and
  filters that, so only the variance within the texels of the level the footprint chose widens the lobe;
* ``spec="exact"`` evaluates that lobe per pixel (a float oracle no cube can hold); ``spec="cubes"`` bakes
  ``lobes`` specular cubes at exponents ``s / ratio^k`` (each with its energy factor) and blends the two whose
  exponents bracket ``s'`` linearly in ``log s'``: what the hardware would hold (``lobes`` times the specular
  cube's block RAM) and look up (two cube lookups, or one and a blend).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fxmodel.pipeline.lighting import face_directions
from host.mipmap import (
    anisotropic_taps,
    lean_pyramid,
    level_of_detail,
    pyramid,
    sample_anisotropic,
    sample_trilinear,
    screen_derivatives,
    texel_derivatives,
)
from host.reference import cube_address_float, sample_float, to_bytes

__all__ = ["Choice", "render_filtered", "lobe_widening", "lookups_per_pixel"]


@dataclass(frozen=True)
class Choice:
    """One filtering design point.

    Attributes
    ----------
    color : str
        ``none`` (bilinear at level 0, today), ``trilinear``, ``nearest-level`` (bilinear in the nearest level) or
        ``anisotropic`` (``taps`` trilinear taps along the major axis).
    bump : str
        ``none`` (today), ``mean`` (trilinear slopes only) or ``lean`` (slopes and second moments).
    bump_footprint : str
        ``isotropic`` or ``anisotropic`` (the bump map's lookups, like ``color``'s).
    spec : str
        ``exact`` or ``cubes`` (see the module docstring); only with ``bump="lean"``.
    lobes, ratio : int, float
        Specular cubes and the ratio of their exponents (``spec="cubes"``).
    bias : float
        LOD bias, levels (both maps).
    taps : int
        Largest number of anisotropic taps.
    kernel : str
        Downsampling kernel (:data:`host.mipmap.KERNELS`).
    lean : str
        ``moments`` or ``covariance`` (see the module docstring); only with ``bump="lean"``.
    shrink, min_face : int
        Specular cube ``k`` has faces of ``max(min_face, F >> (k shrink))`` texels (``F`` the pipeline's): a wider
        lobe is smoother and needs fewer texels (``shrink=1`` halves the face per lobe).
    """

    color: str = "none"
    bump: str = "none"
    bump_footprint: str = "isotropic"
    spec: str = "exact"
    lobes: int = 4
    ratio: float = 4.0
    bias: float = 0.0
    taps: int = 16
    kernel: str = "box"
    lean: str = "moments"
    shrink: int = 0
    min_face: int = 8

    def label(self) -> str:
        parts = [f"color {self.color}", f"bump {self.bump}"]
        if self.bump != "none" and self.bump_footprint != "isotropic":
            parts.append(f"bump {self.bump_footprint}")
        if self.bump == "lean" and self.lean != "moments":
            parts.append(f"lean {self.lean}")
        if self.bump == "lean":
            parts.append("exact lobe" if self.spec == "exact" else f"{self.lobes} lobes x{self.ratio:g}")
            if self.spec == "cubes" and self.shrink:
                parts.append(f"faces / {2 ** self.shrink} per lobe (min {self.min_face})")
        if "anisotropic" in (self.color, self.bump_footprint):
            parts.append(f"{self.taps} taps")
        if self.bias:
            parts.append(f"bias {self.bias:+g}")
        if self.kernel != "box":
            parts.append(self.kernel)
        return ", ".join(parts)


def _lookup(levels, s, t, dtex, shape, footprint: str, choice: Choice):
    if footprint == "anisotropic":
        return sample_anisotropic(levels, s, t, dtex, shape, choice.taps, choice.bias)
    lod = level_of_detail(dtex, choice.bias)
    return sample_trilinear(levels, s, t, lod, trilinear=footprint != "nearest-level")


def lobe_widening(n, E, A, cov, shininess: float):
    """``(s', energy)`` per fragment: the widened Phong exponent and the factor ``(s' + 1) / (s + 1)`` for the
    unnormalized perturbed normals ``n`` ``(K, 3)``, unit eye vectors ``E``, bump matrices ``A`` ``(K, 3, 2)``
    and slope covariances ``cov`` ``(K, 2, 2)`` (see the module docstring).

    To first order a slope change ``d`` moves the unit normal by ``dn = P A d / |n|`` (``P`` the projector across
    ``n``) and the reflection vector ``R = 2 (n.e) n - e`` by ``J dn``, ``J = 2 (n e^T + (n.e) I)``: twice as far
    for a tilt in the plane of incidence, ``2 (n.e)`` times for one across it (at a grazing view, little). The
    covariance of ``R`` is ``(J P A) cov (J P A)^T / |n|^2``; half its trace is the variance per axis."""
    nn = np.maximum(np.einsum("ki,ki->k", n, n), 1e-300)
    u = n / np.sqrt(nn)[:, None]
    P = np.eye(3)[None] - np.einsum("ki,kj->kij", u, u)
    ne = np.einsum("ki,ki->k", u, E)
    J = 2 * (np.einsum("ki,kj->kij", u, E) + ne[:, None, None] * np.eye(3)[None])
    M = np.einsum("kij,kjl,kla->kia", J, P, A) / np.sqrt(nn)[:, None, None]
    sigma2 = np.maximum(np.einsum("kia,kab,kib->k", M, cov, M), 0.0) / 2
    s2 = shininess / (1 + shininess * sigma2)
    return s2, (s2 + 1) / (shininess + 1)


def _specular(frame, R, s2, energy, choice: Choice):
    """Widened specular ``(K, 3)`` at reflection vectors ``R``."""
    p, lighting = frame.params, frame.lighting
    if choice.spec == "exact":
        r = R / np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-300)
        out = np.zeros((len(R), 3))
        ks = np.asarray(lighting.specular, dtype=np.float64)
        for light in lighting.lights:
            lobe = np.maximum(0.0, r @ light.unit()) ** s2
            out += 255.0 * (energy * lobe)[:, None] * ks * np.asarray(light.color, dtype=np.float64)
        return out
    s = lighting.shininess
    exps = [s / choice.ratio ** k for k in range(choice.lobes)]
    faces = [max(choice.min_face, p.specular.width >> (k * choice.shrink)) for k in range(choice.lobes)]
    cubes = [replace(lighting, shininess=e).specular_bytes(face_directions(n, p.specular.border)) * ((e + 1) / (s + 1))
             for e, n in zip(exps, faces)]
    x = np.clip(np.log(s / s2) / np.log(choice.ratio), 0, choice.lobes - 1)
    k0 = np.minimum(np.floor(x).astype(np.int64), choice.lobes - 1)
    f = (x - k0)[:, None]
    face, ss, ts = cube_address_float(R)
    out = np.zeros((len(R), 3))
    for k in np.unique(k0):
        sel = np.flatnonzero(k0 == k)
        lo = sample_float(cubes[k], face[sel], ss[sel], ts[sel], "bilinear", p.specular.edge)
        hi = sample_float(cubes[min(k + 1, choice.lobes - 1)], face[sel], ss[sel], ts[sel], "bilinear",
                          p.specular.edge)
        out[sel] = lo + f[sel] * (hi - lo)
    return out


def lookups_per_pixel(frame, choice: Choice) -> dict:
    """Mean bilinear lookups per fragment of each map under ``choice`` (one level: 1, trilinear: 2, anisotropic:
    2 per tap): the clocks per pixel of a sampler doing one bilinear lookup a clock, or the samplers needed for
    one pixel a clock."""
    f, maps = frame.frags, frame.maps
    duv = screen_derivatives(frame.scene, f)
    out = {}
    for name, mode, rep, shape in (("color", choice.color, maps.color_repeat, maps.color.shape[:2]),
                                   ("bump", "none" if choice.bump == "none" else choice.bump_footprint,
                                    maps.bump_repeat, frame.bump_float().shape[:2])):
        if mode in ("none", "nearest-level"):
            out[name] = 1.0
        elif mode in ("trilinear", "isotropic"):
            out[name] = 2.0
        else:
            out[name] = round(2.0 * float(anisotropic_taps(texel_derivatives(duv, rep, shape), choice.taps)[0].mean()),
                              3)
    return out


def render_filtered(frame, choice: Choice) -> np.ndarray:
    """Bytes ``(K, 3)`` of the frame's fragments (a :class:`host.render.Frame`) with the filtering ``choice``;
    ``Choice()`` (nothing filtered) is reference (a)."""
    f, p, maps = frame.frags, frame.params, frame.maps
    frags = frame.float_inputs()
    duv = screen_derivatives(frame.scene, f)
    tex = np.asarray(maps.color, dtype=np.float64)
    if choice.color == "none":
        color = sample_float(tex[None], np.zeros(len(f), np.int64), f.sc, f.tc, p.texture.filter, "repeat")
    else:
        dt = texel_derivatives(duv, maps.color_repeat, tex.shape[:2])
        levels = [np.floor(lv + 0.5) for lv in pyramid(tex, choice.kernel)]      # held as bytes
        color = _lookup(levels, f.sc, f.tc, dt, tex.shape[:2], choice.color, choice)
    slopes = frame.bump_float()
    cov = None
    if choice.bump == "none":
        B = sample_float(slopes[None], np.zeros(len(f), np.int64), f.s, f.t, p.bump_map.filter, "repeat")
    else:
        db = texel_derivatives(duv, maps.bump_repeat, slopes.shape[:2])
        levels = lean_pyramid(slopes, choice.kernel)
        if choice.bump == "mean":
            levels = [lv[..., :2] for lv in levels]
        elif choice.lean == "covariance":          # per texel M - B B^T: no variance from blending texels
            levels = [np.concatenate([lv[..., :2], lv[..., 2:] - np.stack(
                [lv[..., 0] ** 2, lv[..., 0] * lv[..., 1], lv[..., 1] ** 2], -1)], -1) for lv in levels]
        m = _lookup(levels, f.s, f.t, db, slopes.shape[:2], choice.bump_footprint, choice)
        B = m[:, :2]
        if choice.bump == "lean":
            c = m[:, 2:] if choice.lean == "covariance" else \
                m[:, 2:] - np.stack([B[:, 0] ** 2, B[:, 0] * B[:, 1], B[:, 1] ** 2], -1)
            cov = np.stack([c[:, 0], c[:, 1], c[:, 1], c[:, 2]], -1).reshape(-1, 2, 2)
    A, E = frags["A"], frags["E"]
    n = frags["N"] + B[:, :1] * A[:, :, 0] + B[:, 1:2] * A[:, :, 1]
    R = 2 * n * np.sum(n * E, 1, keepdims=True) - E * np.sum(n * n, 1, keepdims=True)
    dirs = face_directions(p.diffuse.width, p.diffuse.border)
    fd, sd, td = cube_address_float(n)
    D = sample_float(frame.lighting.diffuse_factor(dirs), fd, sd, td, "bilinear", p.diffuse.edge)
    if cov is None:
        fs, ss, ts = cube_address_float(R)
        S = sample_float(frame.lighting.specular_bytes(dirs), fs, ss, ts, "bilinear", p.diffuse.edge)
    else:
        s2, energy = lobe_widening(n, E, A, cov, frame.lighting.shininess)
        S = _specular(frame, R, s2, energy, choice)
    return to_bytes(color * D + S)
