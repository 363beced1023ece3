"""Command-line argument types shared by every entry point: numbers checked against their range at parse time,
so a bad value is refused with one line naming the option and the range before any work starts (exit 2)."""

from __future__ import annotations

import argparse
import math

__all__ = ["int_range", "float_range", "size_arg", "cube_size_arg", "SIZE_HELP"]


def int_range(lo: int | None = None, hi: int | None = None):
    """An ``argparse`` type: an integer in ``[lo, hi]`` (``None``: unbounded on that side)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{value} is out of range: {_describe(lo, hi)}")
        return value
    parse.__name__ = "integer"
    return parse


def float_range(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False):
    """An ``argparse`` type: a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not finite")
        below = lo is not None and (value <= lo if lo_open else value < lo)
        if below or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{value:g} is out of range: {_describe(lo, hi, lo_open)}")
        return value
    parse.__name__ = "number"
    return parse


def _describe(lo, hi, lo_open: bool = False) -> str:
    parts = ([f"{'>' if lo_open else '>='} {lo}"] if lo is not None else []) + ([f"<= {hi}"] if hi is not None else [])
    return "must be " + " and ".join(parts)


def size_arg():
    """``--size``: an image width in the scene schema's limits (:data:`host.scene.MAX_IMAGE_SIZE`)."""
    from host.scene import MAX_IMAGE_SIZE
    return int_range(1, MAX_IMAGE_SIZE)


def cube_size_arg():
    """``--cube-size``: texels per reflectance-cube face edge in the preset schema's limits
    (:data:`fxmodel.pipeline.presets.TOP_KEYS`, the same as a preset file's ``cube_size``)."""
    from fxmodel.pipeline.presets import TOP_KEYS
    _, lo, hi = TOP_KEYS["cube_size"]
    return int_range(lo, hi)


#: Help of ``--size`` for the commands that keep the scene's aspect ratio.
SIZE_HELP = "image width in pixels; the height keeps the scene's aspect ratio (default: the scene's own size)"
