"""Cache keys shared by the build flows: a digest of the sources that turn a parameter object into Verilog.

``params_key(params)`` is the key ``cosim/harness.py`` uses for its build folders (same definition: the
parameter object's ``repr`` plus every ``*.py`` below ``fxmodel/`` and ``rtl/``,
:func:`fxmodel.core.paths.source_digest`); the FPGA flow (``tools/fpga.py``) uses it as its first-level cache key. A
parameter object must have a deterministic, complete ``repr`` (frozen dataclasses do).
"""

from __future__ import annotations

import hashlib

from fxmodel.core.paths import source_digest

__all__ = ["params_key", "text_key"]


def params_key(params, extra: str = "") -> str:
    """12 hex digits naming ``params`` under the current sources (and ``extra``, e.g. flow settings)."""
    return hashlib.sha1(repr(params).encode() + source_digest() + extra.encode()).hexdigest()[:12]


def text_key(*parts: str) -> str:
    """12 hex digits naming some text (e.g. generated Verilog plus tool settings)."""
    h = hashlib.sha1()
    for part in parts:
        h.update(part.encode() + b"\0")
    return h.hexdigest()[:12]
