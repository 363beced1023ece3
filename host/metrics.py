"""Image error measures against a reference frame: PSNR, RMSE, largest and 99th-percentile difference, and
NVIDIA's perceptual FLIP, each over a mask of pixels (the fully covered ones, or the edge pixels).

Every figure is a plain JSON value: a frame equal to its reference has ``psnr_db`` ``None`` (not ``Infinity``,
which strict JSON cannot hold), and an empty mask gives ``None`` for every figure and ``pixels`` 0.

FLIP (Andersson et al., "FLIP: A Difference Evaluator for Alternating Images", HPG 2020; the PyPI package
``flip-evaluator``) is evaluated on the whole frames, LDR, default viewing conditions (67 pixels per degree), the
byte values read as sRGB display values, and its per-pixel map is averaged over the mask.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["psnr_db", "rmse", "flip_map", "compare"]


def _diff(a, b, mask=None) -> np.ndarray:
    """Per-channel differences ``(n, C)`` in 8-bit steps of the pixels of ``mask`` (all pixels without one)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"images of different shapes: {a.shape} and {b.shape}")
    d = a - b
    if mask is not None:
        d = d[np.asarray(mask, bool)]
    return d.reshape(d.shape[0] if d.ndim > 1 else d.size, -1)


def rmse(a, b, mask=None) -> float | None:
    """Root-mean-square difference in 8-bit steps over the channels of the masked pixels (``None`` when empty)."""
    d = _diff(a, b, mask)
    return None if d.size == 0 else float(np.sqrt(np.mean(d * d)))


def psnr_db(a, b, mask=None) -> float | None:
    """Peak signal-to-noise ratio ``10 log10(255^2 / MSE)`` in dB over the masked pixels; ``None`` when the
    images agree there exactly (or the mask is empty): strict JSON has no infinity."""
    e = rmse(a, b, mask)
    return None if not e else float(10 * math.log10(255.0 ** 2 / (e * e)))


def flip_map(reference, test) -> np.ndarray:
    """Per-pixel LDR FLIP ``(H, W)`` of byte images ``(H, W, 3)`` (default viewing conditions)."""
    import flip_evaluator as flip
    ref = np.ascontiguousarray(np.asarray(reference, dtype=np.float32) / 255.0)
    tst = np.ascontiguousarray(np.asarray(test, dtype=np.float32) / 255.0)
    err, _, _ = flip.evaluate(ref, tst, "LDR", applyMagma=False, computeMeanError=False)
    return np.asarray(err, dtype=np.float64).reshape(ref.shape[:2])


def compare(test, reference, mask=None, *, flip: bool = True, digits: int = 4) -> dict:
    """Every measure of ``test`` against ``reference`` (byte images ``(H, W, 3)``) over ``mask`` ``(H, W)``.

    Returns
    -------
    dict
        ``pixels``, ``psnr_db`` (``None`` for an exact match), ``rmse``, ``max_lsb`` and ``p99_lsb`` (the 99th
        percentile over the masked pixels of the largest channel difference, in 8-bit steps), and ``flip_mean``
        (the mean FLIP over the masked pixels) unless ``flip=False``; all ``None`` for an empty mask.
    """
    test = np.asarray(test)
    reference = np.asarray(reference)
    m = np.ones(test.shape[:2], bool) if mask is None else np.asarray(mask, bool)
    n = int(m.sum())
    out = {"pixels": n, "psnr_db": None, "rmse": None, "max_lsb": None, "p99_lsb": None}
    if flip:
        out["flip_mean"] = None
    if n == 0:
        return out
    per_pixel = np.abs(_diff(test, reference, m)).max(axis=1)
    p = psnr_db(test, reference, m)
    out.update(psnr_db=None if p is None else round(p, 2), rmse=round(rmse(test, reference, m), digits),
               max_lsb=int(per_pixel.max()), p99_lsb=round(float(np.percentile(per_pixel, 99)), 2))
    if flip:
        out["flip_mean"] = round(float(flip_map(reference, test)[m].mean()), digits)
    return out
