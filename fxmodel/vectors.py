"""Test vectors as ``$readmemh`` files: one packed word a line, for testbenches in any simulator.

Each line is the concatenation, most significant field first, of the input codes in port order followed by the
output codes in port order, each field the two's-complement bit pattern of its own width. The file opens with
``//`` comment lines naming the fields, their formats and bit ranges, so a reader needs nothing else.

Written vectorized (bit matrix to hex nibbles) in chunks, so the 2**24-vector exhaustive file of the reciprocal
takes seconds, not minutes; Python's per-line ``format`` would take about a minute.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .fixed import Fmt

__all__ = ["layout", "write_readmemh", "read_readmemh"]

_HEX = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)


def layout(fields: list[tuple[str, Fmt]]) -> list[tuple[str, Fmt, int, int]]:
    """``(name, fmt, msb, lsb)`` of each field in the packed word (first field at the top)."""
    total = sum(f.width for _, f in fields)
    out, top = [], total
    for name, fmt in fields:
        out.append((name, fmt, top - 1, top - fmt.width))
        top -= fmt.width
    return out


def write_readmemh(path, fields: list[tuple[str, Fmt]], codes: np.ndarray, chunk: int = 1 << 16) -> Path:
    """Write ``codes`` (shape ``(K, len(fields))``) to ``path`` as packed hex words; return the path."""
    codes = np.asarray(codes)
    if codes.ndim != 2 or codes.shape[1] != len(fields):
        raise ValueError(f"codes must have shape (K, {len(fields)}), not {codes.shape}")
    total = sum(f.width for _, f in fields)
    digits = -(-total // 4)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        fh.write(f"// {codes.shape[0]} vectors, {total} bits a word, fields from the most significant bit:\n"
                 .encode())
        for name, fmt, msb, lsb in layout(fields):
            fh.write(f"//   [{msb}:{lsb}] {name} {fmt}\n".encode())
        for lo in range(0, codes.shape[0], chunk):
            block = codes[lo:lo + chunk]
            bits = np.zeros((block.shape[0], digits * 4), dtype=np.uint8)
            col = digits * 4 - total                       # leading pad bits stay zero
            for i, (_, fmt) in enumerate(fields):
                pattern = np.asarray(fmt.to_bits(block[:, i]), dtype=np.int64)
                for j in range(fmt.width - 1, -1, -1):
                    bits[:, col] = (pattern >> j) & 1
                    col += 1
            nib = bits.reshape(block.shape[0], digits, 4) @ np.array([8, 4, 2, 1], dtype=np.uint8)
            text = np.empty((block.shape[0], digits + 1), dtype=np.uint8)
            text[:, :digits] = _HEX[nib]
            text[:, digits] = ord("\n")
            fh.write(text.tobytes())
    return path


def read_readmemh(path, fields: list[tuple[str, Fmt]]) -> np.ndarray:
    """Read a file written by :func:`write_readmemh` back into codes ``(K, len(fields))``."""
    words = [int(line, 16) for line in Path(path).read_text().split("\n") if line and not line.startswith("//")]
    out = np.zeros((len(words), len(fields)), dtype=object)
    for i, (_, fmt, msb, lsb) in enumerate(layout(fields)):
        mask = (1 << fmt.width) - 1
        out[:, i] = [int(v) for v in fmt.from_bits(np.array([(w >> lsb) & mask for w in words], dtype=object))]
    return out.astype(np.int64) if max(f.width for _, f in fields) <= 62 else out
