"""The board's engine system (``board/frame.py``): the display's color format (RGB565 and its expansion to bytes)
against exact integer arithmetic over every word, the displayed picture's layout, and the checks on what the
system is built from. The whole system, host bytes to DVI words, is ``cosim/test_board_system.py`` (slow)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from board.frame import EngineSystem, display_frame, expand565, rgb565
from board.video import SMALL, VGA_640x480


def test_every_rgb565_word_expands_and_narrows_back_to_itself():
    words = np.arange(1 << 16)
    rgb = expand565(words)
    assert np.array_equal(rgb565(rgb), words)
    r, g, b = words >> 11, words >> 5 & 63, words & 31
    # each channel's bits repeated from the top: the expanded byte's high bits are the channel, and it is exact at
    # both ends (0 -> 0, all ones -> 255)
    assert np.array_equal(rgb[:, 0] >> 3, r) and np.array_equal(rgb[:, 1] >> 2, g)
    assert np.array_equal(rgb[:, 2] >> 3, b)
    assert np.array_equal(rgb[:, 0], (r << 3) | (r >> 2)) and np.array_equal(rgb[:, 1], (g << 2) | (g >> 4))
    assert rgb[0].tolist() == [0, 0, 0] and rgb[-1].tolist() == [255, 255, 255]


def test_narrowing_truncates_each_channel():
    c = np.random.default_rng(1).integers(0, 256, (1000, 3))
    w = rgb565(c)
    assert np.array_equal(w >> 11, c[:, 0] // 8) and np.array_equal(w >> 5 & 63, c[:, 1] // 4)
    assert np.array_equal(w & 31, c[:, 2] // 8)


def test_the_frame_sits_at_the_top_left_with_black_around_it():
    color = np.full((3, 5, 4), 200)
    pic = display_frame(color, 8, 6)
    assert pic.shape == (6, 8, 3)
    assert (pic[:3, :5] == expand565(rgb565(np.array([200, 200, 200])))).all()
    assert not pic[3:].any() and not pic[:, 5:].any()


def test_the_system_needs_the_tile_on_chip_and_inside_the_display():
    from board.frame import board_engine
    params = board_engine(size=16)[0]
    with pytest.raises(ValueError, match="on chip"):
        EngineSystem(dataclasses.replace(params, rop=dataclasses.replace(params.rop, on_chip=False)), VGA_640x480, 25)
    with pytest.raises(ValueError, match="exceeds"):
        EngineSystem(params, SMALL, 25)
    assert EngineSystem(params, VGA_640x480, 25).record_len == -(-sum(p.fmt.width for p in
                                                                      params.raster.record) // 8)
