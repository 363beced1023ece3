"""Where the project's files are: the repository root, the shipped scenes and presets, the build folder, and the
digest of the sources that build caches are keyed by. Every module that needs one of these asks here, so a
checkout, an installed copy and a relocated build folder all work the same way.
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

__all__ = ["ROOT", "SCENES", "presets_dir", "build_dir", "source_digest"]

#: The repository root (the folder holding ``fxmodel/``, ``scenes/`` and ``presets/``).
ROOT = Path(__file__).resolve().parents[2]

#: The shipped scene files.
SCENES = ROOT / "scenes"


def presets_dir() -> Path:
    """The folder of pipeline preset files: ``$FXMODEL_PRESETS`` if set, else ``presets/`` at the repository root."""
    env = os.environ.get("FXMODEL_PRESETS")
    return Path(env) if env else ROOT / "presets"


def build_dir(*parts: str) -> Path:
    """A folder under the build directory: ``$BUMPMAP_BUILD`` if set, else ``build/`` at the repository root
    (``make clean`` removes it). Absolute, so simulator subprocesses started elsewhere agree."""
    env = os.environ.get("BUMPMAP_BUILD")
    return (Path(env).resolve() if env else ROOT / "build").joinpath(*parts)


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
