"""The validating reader of scene files (:mod:`host.scene`): typed look-ups of TOML values that raise
:class:`~host.scene_types.SceneError` naming the file and the key path, and check each number against its limit."""

from __future__ import annotations

import json
import math
import reprlib
from pathlib import Path

import numpy as np

from host.scene_types import MAX_MAP_SIZE, SceneError

__all__ = ["Reader", "show_value"]


# ------------------------------------------------------------------------------------------------------------
# validation helpers
# ------------------------------------------------------------------------------------------------------------
def show_value(value) -> str:
    """A short TOML-like rendering of a bad value for an error message."""
    try:
        text = json.dumps(value, default=str, ensure_ascii=False)
    except (TypeError, ValueError, RecursionError):     # RecursionError: nested hundreds of levels deep
        text = reprlib.repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


class Reader:
    """Validation with messages ``<file>: <key path>: <problem>``."""

    def __init__(self, source: str):
        self.source = source
        self.png_sizes: dict[Path, tuple[int, int]] = {}    # each PNG :meth:`png` read: (width, height)

    def fail(self, key: str, msg: str):
        raise SceneError(f"{self.source}: {key}: {msg}" if key else f"{self.source}: {msg}")

    # -- tables ---------------------------------------------------------------------------------------------
    def table(self, v, key: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> dict:
        if not isinstance(v, dict):
            self.fail(key, f"expected a table, got {show_value(v)}")
        for k in v:
            if k not in allowed:
                self.fail(f"{key}.{k}" if key else k, f"unknown key (allowed: {', '.join(allowed)})")
        for k in required:
            if k not in v:
                self.fail(f"{key}.{k}" if key else k, "missing")
        return v

    def array_of_tables(self, v, key: str) -> list:
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
            self.fail(key, f"expected an array of tables ([[{key}]]), got {show_value(v)}")
        return v

    # -- scalars --------------------------------------------------------------------------------------------
    def number(self, v, key: str, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
        if not _is_num(v):
            self.fail(key, f"expected a number, got {show_value(v)}")
        x = float(v)
        if not math.isfinite(x):
            self.fail(key, f"expected a finite number, got {show_value(v)}")
        if lo is not None and (x < lo or (lo_open and x == lo)):
            self.fail(key, f"must be {'>' if lo_open else '>='} {lo:g}, got {show_value(v)}")
        if hi is not None and (x > hi or (hi_open and x == hi)):
            self.fail(key, f"must be {'<' if hi_open else '<='} {hi:g}, got {show_value(v)}")
        return x

    def integer(self, v, key: str, lo=None, hi=None) -> int:
        if not isinstance(v, int) or isinstance(v, bool):
            self.fail(key, f"expected an integer, got {show_value(v)}")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            rng = f"{lo} .. {hi}" if hi is not None else f">= {lo}"
            self.fail(key, f"must be an integer in {rng}, got {show_value(v)}")
        return int(v)

    def boolean(self, v, key: str) -> bool:
        if not isinstance(v, bool):
            self.fail(key, f"expected true or false, got {show_value(v)}")
        return v

    def string(self, v, key: str, choices: tuple[str, ...] | None = None) -> str:
        if not isinstance(v, str):
            self.fail(key, f"expected a string, got {show_value(v)}")
        if choices is not None and v not in choices:
            self.fail(key, f"expected one of {', '.join(repr(c) for c in choices)}, got {show_value(v)}")
        return v

    def vector(self, v, key: str, n: int, lo=None, hi=None, lo_open=False, nonzero=False, integer=False,
               mag=None):
        """``n`` numbers, each in ``[lo, hi]`` and, with ``mag``, of magnitude at most ``mag``."""
        if mag is not None:
            lo = -mag if lo is None else lo
            hi = mag if hi is None else min(hi, mag)
        what = "integers" if integer else "numbers"
        if not isinstance(v, list) or len(v) != n:
            self.fail(key, f"expected {n} {what}, got {show_value(v)}")
        for i, x in enumerate(v):
            ok = (isinstance(x, int) and not isinstance(x, bool)) if integer else _is_num(x)
            if not ok or (not integer and not math.isfinite(x)):
                self.fail(key, f"expected {n} {what}, got {show_value(v)} (element {i} is {show_value(x)})")
            if (lo is not None and (x < lo or (lo_open and x == lo))) or (hi is not None and x > hi):
                bound = []
                if lo is not None:
                    bound.append(f"{'>' if lo_open else '>='} {lo:g}")
                if hi is not None:
                    bound.append(f"<= {hi:g}")
                self.fail(key, f"every element must be {' and '.join(bound)}, got {show_value(v)}")
        out = tuple(int(x) if integer else float(x) for x in v)
        if nonzero and not any(out):
            self.fail(key, f"must not be the zero vector, got {show_value(v)}")
        return out

    def vectors(self, v, key: str, n: int, mag=None) -> np.ndarray:
        """A non-empty list of n-vectors as an array (K, n), each element of magnitude at most ``mag``."""
        if not isinstance(v, list) or not v:
            self.fail(key, f"expected a non-empty list of {n}-vectors, got {show_value(v)}")
        return np.array([self.vector(x, f"{key}[{i}]", n, mag=mag) for i, x in enumerate(v)], dtype=np.float64)

    def png(self, v, key: str, base: Path) -> Path:
        name = self.string(v, key)
        path = (base / name).resolve()
        try:
            import warnings

            from PIL import Image
            with warnings.catch_warnings():     # a huge size is refused below, by the map limit, not warned about
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(path) as im:    # reads the header only: the size is known before any decoding
                    fmt, size = im.format, im.size
                    if max(size) <= MAX_MAP_SIZE:
                        im.verify()             # the chunks and their checksums
                if max(size) <= MAX_MAP_SIZE:
                    with Image.open(path) as im:
                        im.load()               # and the pixels: a broken deflate stream with good checksums
        except FileNotFoundError:
            self.fail(key, f"file {show_value(name)} not found (looked for {path})")
        except Exception as exc:                                         # noqa: BLE001 -- reported, not hidden
            self.fail(key, f"cannot read {show_value(name)} as an image ({path}): {exc}")
        if fmt != "PNG":
            self.fail(key, f"{show_value(name)} is a {fmt} file, expected a PNG")
        if max(size) > MAX_MAP_SIZE:
            self.fail(key, f"{show_value(name)} is {size[0]} x {size[1]} pixels, more than the {MAX_MAP_SIZE} "
                           f"texels a map edge may have")
        self.png_sizes[path] = size
        return path
