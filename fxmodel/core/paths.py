"""Where the project's files are: the repository root, the shipped scenes and presets, the build folder, and the
digest of the sources that build caches are keyed by. Every module that needs one of these asks here, so a
checkout, an installed copy and a relocated build folder all work the same way.

:func:`atomic_writer` is the one way a file is written: into a temporary file beside it, flushed to disk, then
renamed over it, so a reader (or a run interrupted at any moment) sees the old complete file or the new one,
never a truncated mix (``host.atomic`` builds the PNG, JSON and ``.npy`` writers on it).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import tempfile
from pathlib import Path

__all__ = ["ROOT", "SCENES", "shipped_scenes", "presets_dir", "build_dir", "shown_path", "source_digest",
           "atomic_writer", "refuse_special_file"]

#: The repository root (the folder holding ``fxmodel/``, ``scenes/`` and ``presets/``).
ROOT = Path(__file__).resolve().parents[2]

#: The shipped scene files.
SCENES = ROOT / "scenes"


def shipped_scenes() -> list[str]:
    """The shipped scenes' names (``scenes/*.toml`` without the suffix), sorted: every command's default scene list."""
    return sorted(p.stem for p in SCENES.glob("*.toml"))


def presets_dir() -> Path:
    """The folder of pipeline preset files: ``$FXMODEL_PRESETS`` if set, else ``presets/`` at the repository root."""
    env = os.environ.get("FXMODEL_PRESETS")
    return Path(env) if env else ROOT / "presets"


def build_dir(*parts: str) -> Path:
    """A folder under the build directory: ``$BUMPMAP_BUILD`` if set, else ``build/`` at the repository root
    (``make clean`` removes it). Absolute, so simulator subprocesses started elsewhere agree."""
    env = os.environ.get("BUMPMAP_BUILD")
    return (Path(env).resolve() if env else ROOT / "build").joinpath(*parts)


def shown_path(path) -> str:
    """``path`` as reports print it: relative to the repository root when inside it (a record, or the README's
    transcript of one, then names no one machine's folders), else as given."""
    p = Path(path)
    return str(p.relative_to(ROOT)) if p.is_absolute() and p.is_relative_to(ROOT) else str(p)


@functools.cache
def source_digest(folders: tuple[str, ...] = ("fxmodel", "rtl")) -> bytes:
    """SHA-1 of every ``*.py`` below ``folders`` (relative path and contents, sorted). Taken once per process, so a
    cache key names the code that was imported even if the files change during a long run."""
    h = hashlib.sha1()
    for folder in folders:
        base = ROOT / folder
        for path in sorted(base.rglob("*.py")):
            h.update(path.relative_to(ROOT).as_posix().encode() + b"\0" + path.read_bytes())
    return h.digest()


def refuse_special_file(path, what: str = "") -> None:
    """Refuse an output ``path`` that exists and is not a regular file (a device such as ``/dev/null``, a FIFO,
    a socket): :func:`atomic_writer` renames a temporary file over its path, which would replace it (and a device
    node replaced by root stays broken). Raises ``OSError`` naming it (after ``what``, when given)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise OSError(f"{what + ' ' if what else ''}{path}: not a regular file (a device, a FIFO or a socket): an "
                      "output is written to a temporary file and renamed over its path, which would replace it")


@contextlib.contextmanager
def atomic_writer(path, mode: str = "wb", encoding: str | None = None):
    """Write ``path`` atomically: yields a file open on a temporary file in the same folder (``mode`` ``"wb"`` or
    ``"w"``); when the block ends without an exception the file is flushed, ``fsync``-ed and renamed over
    ``path`` (:func:`os.replace`), else removed and ``path`` left as it was. The folder must exist.

    Raises
    ------
    OSError
        The folder is missing or not writable, ``path`` is a directory (``IsADirectoryError``, checked first), or
        ``path`` is something else that is not a regular file (a device such as ``/dev/null``, a FIFO, a
        socket): renaming over it would replace it, and a device node replaced by root stays broken.
    """
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(21, "Is a directory", str(path))
    refuse_special_file(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:              # name the file asked for, not the temporary one
        raise type(exc)(exc.errno, exc.strerror, str(path)) from None
    try:
        with os.fdopen(fd, mode, encoding=encoding if "b" not in mode else None) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@functools.lru_cache(maxsize=1)
def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
