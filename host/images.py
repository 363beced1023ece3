"""The pictures and figures of a rendered frame: PNG output (atomic), images side by side, amplified differences,
PSNR and largest differences against the float references, strict-JSON ready (an exact match is ``null``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from host.atomic import atomic_save_png
from host.reference import max_lsb, psnr

__all__ = ["DIFF_GAIN", "save_png", "compose", "diff_image", "psnr_db", "metrics", "summary_table", "db_text",
           "truth_rows", "depth_rows", "disagreement_row", "verdict_row"]

#: Gain of the difference images (``diff.png``): one 8-bit step shows as this many.
DIFF_GAIN = 16


def save_png(path, img: np.ndarray) -> Path:
    """Write ``img`` as a PNG atomically (:func:`host.atomic.atomic_save_png`); returns the path."""
    return atomic_save_png(path, img)


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


def psnr_db(a: np.ndarray, b: np.ndarray) -> float | None:
    """PSNR in dB rounded to 0.01 for a JSON report, ``None`` (JSON ``null``) for identical frames, whose PSNR
    is infinite (strict JSON has no ``Infinity``; the report's ``exact_*`` fields say so)."""
    value = psnr(a, b)
    return round(value, 2) if np.isfinite(value) else None


def metrics(model: np.ndarray, float_a: np.ndarray, ideal_b: np.ndarray) -> dict:
    """PSNR and largest difference of the model's bytes against references (a) and (b). An exact match has
    ``psnr_db_*`` ``null`` and ``exact_*`` true (an empty frame matches exactly)."""
    return {"psnr_db_vs_float": psnr_db(model, float_a), "max_lsb_vs_float": max_lsb(model, float_a),
            "psnr_db_vs_ideal": psnr_db(model, ideal_b), "max_lsb_vs_ideal": max_lsb(model, ideal_b),
            "psnr_db_float_vs_ideal": psnr_db(float_a, ideal_b),
            "exact_vs_float": bool(np.array_equal(model, float_a)),
            "exact_vs_ideal": bool(np.array_equal(model, ideal_b))}


def summary_table(rows) -> str:
    """``(label, value)`` rows as the aligned two-column summary the commands print (``bumpmap sim``, ``render``)."""
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)


def db_text(value) -> str:
    """A report's PSNR for a summary (``None``: the frames are identical)."""
    return "identical (exact)" if value is None else f"{value} dB"


def truth_rows(report: dict) -> list:
    """Summary rows of the model and float (a) against reference (c), when the report has them (``--truth``)."""
    vt = report.get("vs_truth")
    if not vt:
        return []
    if not vt["full_pixels"]:                   # nothing compared: not "identical (exact)"
        return [(f"{label} vs truth (c)", f"not compared: no fully covered pixel ({vt['edge_pixels']:,} edge pixels, "
                                          f"{vt['samples']}x{vt['samples']} samples)")
                for label in ("model", "float (a)")]
    return [(f"{label} vs truth (c)", f"{db_text(vt[k]['full']['psnr_db'])}, FLIP {vt[k]['full']['flip_mean']}, "
                                      f"p99 {vt[k]['full']['p99_lsb']} LSB ({vt['full_pixels']:,} covered pixels, "
                                      f"{vt['samples']}x{vt['samples']} samples)")
            for k, label in (("model", "model"), ("float", "float (a)"))]


def depth_rows(report: dict) -> list:
    """The summary table's rows of a frame drawn from triangles: overdraw, the depth test, the disagreements
    with reference (a)'s float z-buffer (:func:`disagreement_row`), the frame-buffer traffic."""
    d, m = report["depth"], report["memory"]
    return [("overdraw", f"{d['overdraw']} fragments per pixel ({d['passed']:,} passed, {d['failed']:,} failed "
                         f"the depth test)"),
            disagreement_row(report),
            ("memory / pixel", f"{m['bytes_read_per_pixel']} bytes read, {m['bytes_written_per_pixel']} written")]


def disagreement_row(report: dict) -> tuple:
    """The summary row of the depth disagreements with reference (a): the pixels they leave out of the
    comparisons."""
    d = report["depth"]
    return ("depth disagreements", f"{d['disagreements']:,} of {d['covered_pixels']:,} pixels left out of the "
                                   f"comparisons, largest gap {d['max_depth_gap_of_disagreements']:.3g} (precision "
                                   f"{d['precision']:.3g})")


def verdict_row(report: dict) -> tuple:
    """The summary row of a judged report (:func:`host.render.judge`): pass or FAIL against the bound."""
    v = report["verdict"]
    return ("verdict", f"{'pass' if v['pass'] else 'FAIL'} (bound {v['bound_lsb']} LSB from (a))")
