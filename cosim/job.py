"""Job folders of the co-simulation: where one simulator run keeps its inputs, logs and results.

A job folder is made fresh by the run that uses it (:func:`job_folder`), inside the ``jobs`` folder of a build
folder (itself under :func:`fxmodel.core.paths.build_dir`). Its name is a readable label, made safe (letters,
digits, ``_.-`` only), the digest of everything that defines the job, and a unique suffix: two runs never share
one, whatever their labels say. :func:`remove_job` deletes only a folder this process made here, so no name
that came from a scene file or the command line can ever be what is deleted.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import tempfile
from pathlib import Path

__all__ = ["job_folder", "remove_job", "safe_label"]

#: Folders made by :func:`job_folder` in this process: the only ones :func:`remove_job` deletes.
_MADE: set[Path] = set()


def safe_label(label: str | None, limit: int = 40) -> str:
    """``label`` as a file-name part: runs of anything but letters, digits, ``_``, ``.`` and ``-`` become ``_``,
    no leading dot, at most ``limit`` characters (``job`` if nothing is left)."""
    text = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(label or "")).lstrip(".")[:limit]
    return text or "job"


def job_folder(bdir: Path, label: str | None, definition) -> Path:
    """A new, empty folder for one run under ``bdir / "jobs"``: ``<safe label>-<digest>-<unique>``, ``digest``
    the SHA-256 (16 hex digits) of ``definition`` (JSON of everything that defines the job)."""
    root = Path(bdir) / "jobs"
    root.mkdir(parents=True, exist_ok=True)
    digest = hashlib.sha256(json.dumps(definition, sort_keys=True, default=repr).encode()).hexdigest()[:16]
    path = Path(tempfile.mkdtemp(prefix=f"{safe_label(label)}-{digest}-", dir=root))
    if path.parent != root:                                   # (cannot happen: the prefix has no separator)
        raise AssertionError(f"job folder {path} is not inside {root}")
    _MADE.add(path)
    return path


def remove_job(path: Path):
    """Delete the job folder ``path`` and what it holds, if this process made it (:func:`job_folder`)."""
    path = Path(path)
    if path in _MADE:
        shutil.rmtree(path, ignore_errors=True)
        _MADE.discard(path)
