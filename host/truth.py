r"""Reference (c), the true image: ideal per-pixel Phong integrated over each pixel's area (paper section 6 names
filtering, "artifact reduced MIP mapping for bump textures", as the next step; this is what a filter is judged
against).

References (a) and (b) (:mod:`host.reference`) shade one sample at each pixel's centre, so wherever a pixel
covers many texels they alias exactly as the hardware does, and cannot show it. Reference (c) shades
``K x K`` samples per pixel with reference (b)'s lighting (normalized perturbed normal, exact Phong, the
full-resolution maps filtered bilinearly, as the scene conventions define a map) and averages them with a box
filter over the pixel:

* **Samples** (:mod:`host.supersample`): the front end's own projection, clipping, snapping, fill rule, depth
  rule and perspective-correct attributes, evaluated at sample points instead of pixel centres, a band of rows
  at a time (memory bounded by the band, any ``K`` up to 128).
* **Pattern: stratified (jittered), fixed seed**: one uniformly random point in each of the ``K x K`` cells of
  a pixel, drawn per row from a generator seeded by ``(seed, row)``, so the frame is reproducible. Chosen by
  measurement (``tools/filtering.py``, the record's ``pattern_study``): on the grazing floor, where a pixel
  covers hundreds of texels, a regular ``8 x 8`` grid aliases against the checker and is about twice as far
  from a ``32 x 32`` truth (RMSE) as the jittered ``8 x 8``, and moves the figures of a filtered frame by about
  2 dB; jittered, the figures at ``8 x 8`` and ``16 x 16`` agree closely. ``pattern="grid"`` gives the regular
  grid ``(x + (i + 1/2) / K, y + (j + 1/2) / K)``: the frame rasterizing at ``K`` times the resolution gives
  (but for vertices snapped to 1/256 of a pixel rather than of a sample).
* Each sample's radiance ``texture D + S`` is clipped to ``[0, 255]`` (a display cannot show more) and averaged
  in float; uncovered samples count as the background; the mean is rounded half-up to a byte once.
* **Coverage**: the number of covered samples per pixel. Pixels with all ``K^2`` covered are *fully covered*
  (the figures the issue compares), the others with some coverage are *edge* pixels, reported apart (their value
  mixes surface and background, which a one-sample renderer cannot match).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fxmodel.pipeline.lighting import Light, Lighting
from host.bumpmap import perturbations, scene_maps
from host.reference import perturbed, sample_float
from host.supersample import scene_samples

__all__ = ["Truth", "material_lighting", "bump_float", "radiance", "true_image", "against_truth", "add_truth",
           "DEFAULT_SAMPLES"]

#: Samples per pixel along each axis of reference (c) by default.
DEFAULT_SAMPLES = 8


@dataclass
class Truth:
    """Reference (c) of a scene.

    Attributes
    ----------
    image : ndarray (H, W, 3) uint8
        The box-filtered true image (background where nothing is covered).
    mean : ndarray (H, W, 3) float64
        The same before rounding, in 8-bit units.
    coverage : ndarray (H, W) int64
        Covered samples per pixel, ``0 .. samples**2``.
    samples : int
        ``K``: samples per pixel along each axis.
    """

    image: np.ndarray = field(repr=False)
    mean: np.ndarray = field(repr=False)
    coverage: np.ndarray = field(repr=False)
    samples: int

    @property
    def full(self) -> np.ndarray:
        """Mask ``(H, W)`` of the pixels every sample of which is covered."""
        return self.coverage == self.samples ** 2

    @property
    def edge(self) -> np.ndarray:
        """Mask ``(H, W)`` of the partly covered pixels."""
        return (self.coverage > 0) & ~self.full


def material_lighting(scene, material) -> Lighting:
    """The lighting of one material of ``scene`` (as :func:`host.render.prepare` builds it)."""
    return Lighting(lights=tuple(Light(tuple(li.direction), tuple(li.color)) for li in scene.lights),
                    ambient=tuple(scene.ambient), specular=tuple(material.specular),
                    shininess=float(material.shininess))


def bump_float(maps) -> np.ndarray:
    """The unquantized perturbations ``(H, W, 2)`` of a material in the units ``A`` expects (as
    :meth:`host.render.Frame.bump_float`); one zero texel without a bump map."""
    if maps.bump is None:
        return np.zeros((1, 1, 2))
    pu, pv = perturbations(maps.heights)
    scale = maps.bump.scale or 1.0
    return np.stack([pu / scale, pv / scale], -1)


def radiance(frags: dict, *, bump, texture, lighting: Lighting) -> np.ndarray:
    """Reference (b)'s shading before rounding: ``clip(texture D + S, 0, 255)`` ``(K, 3)`` float, the maps
    sampled bilinearly at the exact addresses (``frags`` as :func:`host.reference.ideal_phong` takes them)."""
    n = perturbed(frags, bump, "bilinear")
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    e = frags["E"] / np.maximum(np.linalg.norm(frags["E"], axis=1, keepdims=True), 1e-300)
    r = 2 * n * np.sum(n * e, 1, keepdims=True) - e
    tex = sample_float(np.asarray(texture, dtype=np.float64)[None], np.zeros(len(n), np.int64), frags["sc"],
                       frags["tc"], "bilinear", "repeat")
    return np.clip(tex * lighting.diffuse_factor(n) + lighting.specular_bytes(r), 0.0, 255.0)


def true_image(scene, samples: int = DEFAULT_SAMPLES, pattern: str = "jittered", seed: int = 0) -> Truth:
    """Reference (c) of ``scene`` (a loaded :class:`host.scene.Scene`, at its own size) with ``samples x samples``
    samples per pixel (:func:`host.supersample.offsets`: ``jittered`` or ``grid``), a band of rows at a time.

    Raises
    ------
    ValueError
        ``samples`` not a power of two from 1 to 128 (sample positions are exact in 1/256 pixel), or an unknown
        ``pattern``.
    """
    if not isinstance(samples, int) or isinstance(samples, bool) or samples < 1 or samples > 128 or \
            samples & (samples - 1):
        raise ValueError(f"samples={samples!r}: must be a power of two from 1 to 128")
    k, w, h = samples, scene.width, scene.height
    maps = scene_maps(scene)
    lighting = [material_lighting(scene, m) for m in scene.materials]
    bumps = [bump_float(m) for m in maps]
    total = np.zeros((h * w, 3))
    coverage = np.zeros(h * w, np.int64)
    for y0, y1, cov, smp in scene_samples(scene, [m.a_gain for m in maps], k, pattern, seed):
        coverage[y0 * w:y1 * w] = cov.ravel()
        for mi in np.unique(smp.material):
            sel = np.flatnonzero(smp.material == mi)
            f = {"U": smp.s[sel], "s": smp.s[sel], "t": smp.t[sel], "sc": smp.sc[sel], "tc": smp.tc[sel],
                 "N": smp.N[sel], "E": smp.E[sel], "A": smp.A[sel]}
            rad = radiance(f, bump=bumps[mi], texture=maps[mi].color, lighting=lighting[mi])
            for c in range(3):
                total[:, c] += np.bincount(smp.pix[sel], weights=rad[:, c], minlength=h * w)
    bg = np.asarray(scene.background, dtype=np.float64) * 255.0
    mean = (total + (k * k - coverage)[:, None] * bg) / (k * k)
    image = np.clip(np.floor(mean + 0.5), 0, 255).astype(np.uint8)
    return Truth(image=image.reshape(h, w, 3), mean=mean.reshape(h, w, 3), coverage=coverage.reshape(h, w),
                 samples=k)


def against_truth(scene, images: dict, samples: int = DEFAULT_SAMPLES, exclude=None, *, flip: bool = True):
    """The figures of each frame in ``images`` (name -> bytes ``(H, W, 3)`` of ``scene`` at its size) against
    reference (c): ``({"samples", "full_pixels", "edge_pixels", name: {"full": ..., "edge": ...}}, truth)``
    with :func:`host.metrics.compare`'s measures on the fully covered and on the edge pixels. ``exclude``: pixels
    ``(x, y)`` (two arrays) left out of both (the depth disagreements of a frame drawn from triangles). The hook
    of ``render`` and ``make sim`` for (c)."""
    from host.metrics import compare
    truth = true_image(scene, samples)
    full, edge = truth.full.copy(), truth.edge.copy()
    x = y = None
    if exclude is not None:
        x, y = (np.asarray(v, np.int64) for v in exclude)
        full[y, x] = edge[y, x] = False
    out = {"samples": samples, "full_pixels": int(full.sum()), "edge_pixels": int(edge.sum())}
    for name, img in images.items():
        if x is not None and len(x):
            # FLIP filters over a neighbourhood: an excluded pixel (another surface than the references show) would
            # leak its difference into the kept pixels around it. Compare them as if equal to (c) there, so the
            # figures of the kept pixels measure the kept pixels only (the per-pixel measures are masked anyway).
            img = np.array(img, copy=True)
            img[y, x] = truth.image[y, x]
        out[name] = {"full": compare(img, truth.image, full, flip=flip),
                     "edge": compare(img, truth.image, edge, flip=flip)}
    return out, truth


def add_truth(frame, images: dict, report: dict, exclude, samples: int) -> None:
    """Reference (c) beside (a) and (b) in a rendered frame (:func:`host.render.render`'s ``truth_samples``):
    ``report["vs_truth"]`` (:func:`against_truth` of the model, (a) and (b), the fragments ``exclude`` left out)
    and the images ``truth`` and ``compare`` (model, ideal, truth side by side)."""
    from host.images import compose
    ex = None
    if exclude is not None:
        mask = np.asarray(exclude, bool)
        ex = (frame.frags.x[mask], frame.frags.y[mask])
    report["vs_truth"], truth = against_truth(frame.scene, {k: images[k] for k in ("model", "float", "ideal")},
                                              samples, exclude=ex)
    images["truth"] = truth.image
    images["compare"] = compose(images["model"], images["ideal"], truth.image)
