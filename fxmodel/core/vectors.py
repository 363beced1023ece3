"""Test vectors as files for testbenches in any simulator: ``$readmemh`` text, or binary words for ``$fread``.

A *word* is the concatenation, most significant field first, of the input codes in port order followed by the
output codes in port order, each field the two's-complement bit pattern of its own width (:func:`layout`).

* :func:`write_readmemh`: one word a line in hex. The file opens with ``//`` comment lines naming the fields,
  their formats and bit ranges, so a reader needs nothing else.
* :func:`write_words`: the words back to back, each ``ceil(width / 8)`` bytes, most significant byte first (the
  leading pad bits zero), which is how ``$fread(mem, fd, start, count)`` fills a memory of ``width``-bit words in
  Verilator and Icarus. No header: a third of the bytes of the hex text for a 33-bit word, and nothing to parse.

Both are written vectorized in chunks (bit matrix to hex nibbles or bytes; one 64-bit word per vector when the
word fits), so the 2**24-vector exhaustive file of the reciprocal takes seconds, not minutes; Python's per-line
``format`` would take about a minute.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import atomic_writer

__all__ = ["layout", "write_readmemh", "read_readmemh", "pack_words", "write_words", "read_words"]

_HEX = np.frombuffer(b"0123456789abcdef", dtype=np.uint8)


def layout(fields: list[tuple[str, Fmt]]) -> list[tuple[str, Fmt, int, int]]:
    """``(name, fmt, msb, lsb)`` of each field in the packed word (first field at the top)."""
    total = sum(f.width for _, f in fields)
    out, top = [], total
    for name, fmt in fields:
        out.append((name, fmt, top - 1, top - fmt.width))
        top -= fmt.width
    return out


def _check_codes(fields, codes) -> np.ndarray:
    codes = np.asarray(codes)
    if codes.ndim != 2 or codes.shape[1] != len(fields):
        raise ValueError(f"codes must have shape (K, {len(fields)}), not {codes.shape}")
    return codes


def _bit_matrix(fields: list[tuple[str, Fmt]], block: np.ndarray, columns: int) -> np.ndarray:
    """The bits of each row's word, most significant first, right-aligned in ``columns`` (leading pad zero)."""
    bits = np.zeros((block.shape[0], columns), dtype=np.uint8)
    col = columns - sum(f.width for _, f in fields)
    for i, (_, fmt) in enumerate(fields):
        pattern = np.asarray(fmt.to_bits(block[:, i]), dtype=np.int64 if not fmt.wide else object)
        for j in range(fmt.width - 1, -1, -1):
            bits[:, col] = ((pattern >> j) & 1).astype(np.uint8)
            col += 1
    return bits


def pack_words(fields: list[tuple[str, Fmt]], codes: np.ndarray) -> np.ndarray:
    """The words of ``codes`` (shape ``(K, len(fields))``) as bytes ``(K, ceil(width / 8))``, most significant
    byte first: the layout of :func:`write_words`."""
    codes = _check_codes(fields, codes)
    total = sum(f.width for _, f in fields)
    nbytes = -(-total // 8)
    if any(f.wide for _, f in fields):
        return np.packbits(_bit_matrix(fields, codes, nbytes * 8), axis=1)
    # 64-bit limbs, least significant first; a field may straddle two
    limbs = np.zeros((-(-nbytes // 8), codes.shape[0]), dtype=np.uint64)
    for i, (_, fmt, _, lsb) in enumerate(layout(fields)):
        bits = np.asarray(fmt.to_bits(codes[:, i]), dtype=np.int64).astype(np.uint64)
        limb, off = divmod(lsb, 64)
        limbs[limb] |= bits << np.uint64(off)
        if off + fmt.width > 64:
            limbs[limb + 1] |= bits >> np.uint64(64 - off)
    data = np.ascontiguousarray(limbs[::-1].T, dtype=">u8").view(np.uint8).reshape(codes.shape[0], -1)
    return data[:, data.shape[1] - nbytes:]


def write_words(path, fields: list[tuple[str, Fmt]], codes: np.ndarray, chunk: int = 1 << 18) -> Path:
    """Write ``codes`` (shape ``(K, len(fields))``) to ``path`` as binary words for ``$fread`` (module
    docstring); return the path."""
    codes = _check_codes(fields, codes)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        for lo in range(0, codes.shape[0], chunk):
            fh.write(np.ascontiguousarray(pack_words(fields, codes[lo:lo + chunk])).tobytes())
    return path


def _split_words(words: list[int], fields: list[tuple[str, Fmt]]) -> np.ndarray:
    """Codes ``(K, len(fields))`` of packed words (Python integers)."""
    out = np.zeros((len(words), len(fields)), dtype=object)
    for i, (_, fmt, _msb, lsb) in enumerate(layout(fields)):
        mask = (1 << fmt.width) - 1
        out[:, i] = [int(v) for v in fmt.from_bits(np.array([(w >> lsb) & mask for w in words], dtype=object))]
    return out.astype(np.int64) if max(f.width for _, f in fields) <= 62 else out


def read_words(path, fields: list[tuple[str, Fmt]]) -> np.ndarray:
    """Read a file written by :func:`write_words` back into codes ``(K, len(fields))``."""
    total = sum(f.width for _, f in fields)
    nbytes = -(-total // 8)
    data = np.fromfile(path, dtype=np.uint8)
    if len(data) % nbytes:
        raise ValueError(f"{path}: {len(data)} bytes is not a whole number of {nbytes}-byte words")
    rows = data.reshape(-1, nbytes)
    words = [int.from_bytes(r.tobytes(), "big") for r in rows]
    return _split_words(words, fields)


def write_readmemh(path, fields: list[tuple[str, Fmt]], codes: np.ndarray, chunk: int = 1 << 16) -> Path:
    """Write ``codes`` (shape ``(K, len(fields))``) to ``path`` as packed hex words; return the path."""
    codes = _check_codes(fields, codes)
    total = sum(f.width for _, f in fields)
    digits = -(-total // 4)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_writer(path, "wb") as fh:
        fh.write(f"// {codes.shape[0]} vectors, {total} bits a word, fields from the most significant bit:\n"
                 .encode())
        for name, fmt, msb, lsb in layout(fields):
            fh.write(f"//   [{msb}:{lsb}] {name} {fmt}\n".encode())
        for lo in range(0, codes.shape[0], chunk):
            block = codes[lo:lo + chunk]
            bits = _bit_matrix(fields, block, digits * 4)
            nib = bits.reshape(block.shape[0], digits, 4) @ np.array([8, 4, 2, 1], dtype=np.uint8)
            text = np.empty((block.shape[0], digits + 1), dtype=np.uint8)
            text[:, :digits] = _HEX[nib]
            text[:, digits] = ord("\n")
            fh.write(text.tobytes())
    return path


def read_readmemh(path, fields: list[tuple[str, Fmt]]) -> np.ndarray:
    """Read a file written by :func:`write_readmemh` back into codes ``(K, len(fields))``."""
    words = [int(line, 16) for line in Path(path).read_text().split("\n") if line and not line.startswith("//")]
    return _split_words(words, fields)
