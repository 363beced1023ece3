"""The display's golden model (``board/video.py``) against DVI 1.0 section 3.2: every symbol decodes back to its
byte from every reachable disparity, the running disparity stays bounded (DC balance), control tokens, and the
video timing's layout of 640 x 480 at 60 Hz."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from board.video import CTRL_TOKENS, SMALL, TmdsEncoder, VGA_640x480, VideoTiming, scan, tmds_decode, tmds_encode


def _reachable() -> set[int]:
    """Every running disparity an encoder reaches from 0 (the closure over all 256 bytes)."""
    seen, todo = {0}, [0]
    while todo:
        cnt = todo.pop()
        for d in range(256):
            nxt = tmds_encode(d, cnt)[1]
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


REACHABLE = sorted(_reachable())


def _disparity(word: int) -> int:
    return 2 * bin(word).count("1") - 10


def test_reachable_disparities_are_few_and_bounded():
    """The encoder's state space is finite and within the +-10 of a 10-bit symbol's imbalance; even values only."""
    assert REACHABLE == sorted(set(REACHABLE))
    assert max(map(abs, REACHABLE)) <= 10 and all(c % 2 == 0 for c in REACHABLE)


@pytest.mark.parametrize("cnt", REACHABLE)
def test_every_byte_round_trips_from_every_state(cnt):
    for d in range(256):
        word, nxt = tmds_encode(d, cnt)
        assert tmds_decode(word) == (1, d, 0)
        assert nxt == cnt + _disparity(word), "cnt must be the running disparity of the symbols sent"
        assert word not in CTRL_TOKENS


def test_control_tokens_decode_and_bad_symbols_are_refused():
    for c, tok in enumerate(CTRL_TOKENS):
        assert tmds_decode(tok) == (0, 0, c)
    data = {tmds_encode(d, c)[0] for d in range(256) for c in REACHABLE}
    bad = next(w for w in range(1024) if w not in data and w not in CTRL_TOKENS)
    with pytest.raises(ValueError, match="neither"):
        tmds_decode(bad)


@given(st.lists(st.integers(0, 255), min_size=1, max_size=400))
def test_running_disparity_of_the_stream_is_bounded(data):
    """DC balance: counted from the symbols alone (not the encoder's state), the ones minus zeros of every prefix
    of an active period stay within [-10, 10]; and the transmitted symbols minimise transitions (at most 5 in
    bits 0-8 of a data symbol, against 7 in the control tokens)."""
    enc, total = TmdsEncoder(), 0
    for d in data:
        word = enc.step(1, d, 0)
        total += _disparity(word)
        assert abs(total) <= 10
        assert total == enc.cnt
        assert bin((word ^ (word >> 1)) & 0xFF).count("1") <= 5


def test_vga_640x480_layout():
    t = VGA_640x480
    assert (t.h_total, t.v_total, t.frame_clocks) == (800, 525, 420_000)
    assert abs(t.frame_hz - 59.94) < 0.01
    rows = list(scan(t))
    assert sum(r[2] for r in rows) == 640 * 480
    line0 = [r[3] for r in rows[:800]]
    assert line0.count(0) == 96 and line0.index(0) == 640 + 16          # negative hsync after the front porch
    assert [r[4] for r in rows[::800]].count(0) == 2                     # two lines of negative vsync


def test_bad_timing_is_refused():
    with pytest.raises(ValueError, match="h_sync"):
        VideoTiming(16, 2, 0, 3, 6, 1, 2, 1)
    assert SMALL.frame_clocks == 24 * 10
