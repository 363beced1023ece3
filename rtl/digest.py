"""Cache keys shared by the build flows: a digest of the sources that turn a parameter object into Verilog.

``params_key(params)`` is the key ``cosim/harness.py`` uses for its build folders (same definition: the
parameter object's ``repr`` plus every ``*.py`` of ``fxmodel/`` and ``rtl/``); the FPGA flow (``tools/fpga.py``)
uses it as its first-level cache key. A parameter object must have a deterministic, complete ``repr`` (frozen
dataclasses do).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

__all__ = ["ROOT", "source_digest", "params_key", "text_key"]


@functools.lru_cache(maxsize=None)
def source_digest(folders=("fxmodel", "rtl")) -> bytes:
    """SHA-1 of every ``*.py`` (name and contents, sorted) in ``folders`` under the repository root. Taken once
    per process (as ``cosim/harness.py`` does), so a key names the code that was imported even if the files
    change during a long run."""
    h = hashlib.sha1()
    for folder in folders:
        for path in sorted((ROOT / folder).glob("*.py")):
            h.update(path.name.encode() + path.read_bytes())
    return h.digest()


def params_key(params, extra: str = "") -> str:
    """12 hex digits naming ``params`` under the current sources (and ``extra``, e.g. flow settings)."""
    return hashlib.sha1(repr(params).encode() + source_digest() + extra.encode()).hexdigest()[:12]


def text_key(*parts: str) -> str:
    """12 hex digits naming some text (e.g. generated Verilog plus tool settings)."""
    h = hashlib.sha1()
    for part in parts:
        h.update(part.encode() + b"\0")
    return h.hexdigest()[:12]
