"""The frame in SDRAM's layout and bandwidth (``board/sdram_frame.py``): every pixel of both buffers at its own
address, bursts covering each line once and never crossing a 4 KB page (exact integers, hypothesis), bad layouts
refused, and the bandwidth from exact arithmetic. The RTL against an AXI memory and LiteDRAM's core is
``cosim/test_sdram_frame.py``."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from board.litedram import ADDR_BITS
from board.sdram_frame import FrameLayout, SdramFrame, bandwidth
from board.video import SMALL, VGA_640x480


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 700), st.integers(1, 500), st.sampled_from([1, 2, 4, 16, 64, 128, 256]), st.integers(0, 3))
def test_bursts_cover_every_pixel_once_inside_4k_pages(width, height, burst, base_pitches):
    L = FrameLayout(width, height, base=base_pitches * FrameLayout(width, height).pitch, burst=burst)
    assert L.pitch & (L.pitch - 1) == 0 and L.pitch >= 2 * width and L.buffer_bytes >= L.pitch * height
    for b in (0, 1):
        bursts = L.burst_list(b)
        assert len(bursts) == L.bursts
        covered = []
        for addr, beats in bursts:
            assert 1 <= beats <= burst and addr // 4096 == (addr + 2 * beats - 1) // 4096
            covered += range(addr, addr + 2 * beats, 2)
        want = [L.address(b, y, x) for y in range(height) for x in range(width)]
        assert covered == want
    # the two buffers do not overlap and fit the chip
    assert L.address(0, height - 1, width - 1) < L.address(1, 0, 0)
    assert L.address(1, height - 1, width - 1) + 2 <= 1 << ADDR_BITS


def test_bad_layouts_are_refused():
    with pytest.raises(ValueError, match="burst"):
        FrameLayout(10, 10, burst=48)
    with pytest.raises(ValueError, match="width"):
        FrameLayout(0, 10)
    with pytest.raises(ValueError, match="base"):
        FrameLayout(10, 10, base=6)
    with pytest.raises(ValueError, match="exceed the SDRAM"):
        FrameLayout(640, 480, base=1 << ADDR_BITS)
    with pytest.raises(ValueError, match="exceeds the display"):
        SdramFrame(FrameLayout(20, 4), SMALL)
    with pytest.raises(ValueError, match="fifo_depth"):
        SdramFrame(FrameLayout(16, 4, burst=16), SMALL, fifo_depth=16)


def test_bandwidth_is_the_frame_bytes_at_each_rate():
    L = FrameLayout(640, 480)
    b = bandwidth(L, VGA_640x480, 60)
    frame_bytes = 640 * 480 * 2
    scan = Fraction(frame_bytes) * VGA_640x480.pixel_hz / VGA_640x480.frame_clocks
    assert b["frame_bytes"] == frame_bytes
    assert b["scanout_MBps"] == round(float(scan / 10 ** 6), 2)
    assert b["copy_MBps"] == round(frame_bytes * 60 / 1e6, 2)
    assert b["total_MBps"] == round(float((scan + frame_bytes * 60) / 10 ** 6), 2)
