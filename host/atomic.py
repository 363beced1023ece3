"""Outputs written atomically: every PNG, JSON report, ``.npy`` array and text file a tool writes goes through here.

Each writer fills a temporary file in the target's folder, flushes it to disk and renames it over the target
(:func:`fxmodel.core.paths.atomic_writer`), so an interrupted run (SIGINT, SIGTERM, SIGKILL) leaves either the
previous complete file or the new complete one, never a truncated or mixed file. JSON is strict
(``allow_nan=False``): a report with ``inf`` or ``NaN`` fails loudly here instead of writing text that strict
parsers reject.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from fxmodel.core.paths import atomic_writer, refuse_special_file

__all__ = ["atomic_write_bytes", "atomic_write_text", "atomic_save_png", "atomic_savefig", "atomic_json",
           "atomic_save_npy",
           "strict_json", "check_output_file", "check_output_not_input", "check_output_dir"]


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (the folder is created); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_writer(path, "wb") as fh:
        fh.write(data)
    return path


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_save_png(path, img: np.ndarray) -> Path:
    """Write the image ``img`` (``(H, W, 3)`` or ``(H, W)`` bytes) as a PNG atomically; returns the path."""
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.asarray(img)).save(buf, format="PNG")
    return atomic_write_bytes(path, buf.getvalue())


def atomic_savefig(path, fig, **kwargs) -> Path:
    """Write a matplotlib figure as a PNG atomically (``kwargs`` go to ``fig.savefig``); returns the path."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **kwargs)
    return atomic_write_bytes(path, buf.getvalue())


def atomic_save_npy(path, array: np.ndarray) -> Path:
    """Write ``array`` as a ``.npy`` file atomically (no pickles); returns the path."""
    buf = io.BytesIO()
    np.save(buf, np.asarray(array), allow_pickle=False)
    return atomic_write_bytes(path, buf.getvalue())


def strict_json(obj, indent: int | None = 2) -> str:
    """``obj`` as strict JSON text: ``inf`` and ``NaN`` raise ``ValueError`` (``allow_nan=False``)."""
    return json.dumps(obj, indent=indent, allow_nan=False)


def atomic_json(path, obj, indent: int | None = 2) -> Path:
    """Write ``obj`` as strict JSON (:func:`strict_json`, a newline at the end) atomically; returns the path."""
    return atomic_write_text(path, strict_json(obj, indent) + "\n")


def check_output_file(path, what: str = "output", inputs=()) -> Path:
    """Refuse, before any work, an output file that cannot be written: the path is a directory or another
    non-regular file (a device such as ``/dev/null``, a FIFO: the rename of :func:`atomic_writer` would replace
    it), its folder is a file or is not writable (a missing folder is created), or it is the same file as one of
    ``inputs`` (the run would overwrite what it reads). Raises ``OSError`` with one line naming it."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{what} {path}: is a directory, expected a file name")
    refuse_special_file(path, what)
    check_output_not_input(path, what, inputs)
    check_output_dir(path.parent, f"folder of the {what}")
    return path


def check_output_not_input(path, what: str, inputs) -> None:
    """Refuse an output ``path`` that is the same file as one of ``inputs`` (``None`` entries are skipped), by
    identity (a hard link or another spelling of the path included). Raises ``OSError`` naming both."""
    path = Path(path)
    for src in inputs:
        if src is None:
            continue
        try:
            same = os.path.samefile(path, src)
        except OSError:                         # either is missing: not the same existing file
            same = False
        if same:
            raise OSError(f"{what} {path}: is the input {src}, which the run reads; give another output path")


def check_output_dir(path, what: str = "output folder") -> Path:
    """Refuse, before any work, an output folder that is a file or cannot be created or written to (it is
    created if missing). Raises ``OSError`` with one line naming it."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{what} {path}: is a file, expected a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"{what} {path}: cannot create it: {exc.strerror or exc}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise PermissionError(f"{what} {path}: not writable")
    return path
