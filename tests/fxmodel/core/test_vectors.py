"""Vector files (``fxmodel/core/vectors.py``): the binary words for ``$fread`` and the ``$readmemh`` text hold the
same packed words, checked against words built one Python integer at a time."""

from __future__ import annotations

import numpy as np
import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.core.vectors import layout, pack_words, read_readmemh, read_words, write_readmemh, write_words

FIELDS = {
    "recip32 word, 65 bits": [("w", Fmt(True, 16, 16)), ("mant", Fmt(True, 2, 23)), ("exp", Fmt(True, 6, 0)),
                              ("dbz", Fmt(False, 1, 0))],
    "fields straddling two limbs, 141 bits": [("a", Fmt(True, 30, 30)), ("b", Fmt(False, 60, 0)),
                                              ("c", Fmt(True, 49, 1)), ("d", Fmt(False, 1, 0))],
    "exactly 64 bits": [("a", Fmt(False, 0, 32)), ("b", Fmt(True, 31, 1))],
    "one bit": [("z", Fmt(False, 1, 0))],
    "a wide field, 83 bits": [("a", Fmt(True, 40, 40)), ("b", Fmt(False, 3, 0))],
}


def _codes(fields, rng, n=500):
    cols = []
    for _, f in fields:
        if f.wide:
            cols.append(np.array([int(x) for x in rng.integers(-2**62, 2**62, n)] + [f.min_code, f.max_code]
                                , dtype=object))
        else:
            codes = rng.integers(f.min_code, f.max_code, n, endpoint=True)
            cols.append(np.concatenate([codes, [f.min_code, f.max_code]]))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("name", list(FIELDS))
def test_binary_words_are_the_packed_words_most_significant_byte_first(name, tmp_path):
    fields = FIELDS[name]
    codes = _codes(fields, np.random.default_rng(len(name)))
    total = sum(f.width for _, f in fields)
    nbytes = -(-total // 8)
    want = b"".join(sum((int(c) & ((1 << f.width) - 1)) << lsb for c, (_, f, _, lsb) in zip(row, layout(fields)))
                    .to_bytes(nbytes, "big") for row in codes)
    assert pack_words(fields, codes).tobytes() == want
    path = write_words(tmp_path / "v.bin", fields, codes, chunk=97)
    assert path.read_bytes() == want
    assert (read_words(path, fields) == codes).all()
    assert (read_readmemh(write_readmemh(tmp_path / "v.hex", fields, codes, chunk=97), fields) == codes).all()


def test_bad_shapes_and_files_are_named(tmp_path):
    fields = FIELDS["one bit"]
    with pytest.raises(ValueError, match=r"shape \(K, 1\)"):
        write_words(tmp_path / "v.bin", fields, np.zeros((3, 2), dtype=np.int64))
    (tmp_path / "odd.bin").write_bytes(b"\0\1\2")
    with pytest.raises(ValueError, match="odd.bin: 3 bytes"):
        read_words(tmp_path / "odd.bin", FIELDS["exactly 64 bits"])
