"""Co-simulation of the frame in SDRAM (``board/sdram_frame.py``) against cocotbext-axi's ``AxiRam`` with random
wait states: frames copied in with random gaps are shown whole, in order, each at least once, every word equal to
the frame store's model (black outside the frame), the buffers in memory holding the copies, every burst the
layout's; a memory too slow for the display is caught (``underrun``, the picture not the copy)."""

from __future__ import annotations

import numpy as np
import pytest

from board.sdram_frame import FrameLayout
from board.video import VideoTiming
from cosim.sdram_frame import run

pytestmark = pytest.mark.cosim

#: A small mode: 40 x 12 active in 52 x 18 clocks.
MODE = VideoTiming(40, 4, 4, 4, 12, 1, 1, 4, pixel_hz=1_000_000)


def frames(layout, n, seed):
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 1 << 16, (layout.height, layout.width)) for _ in range(n)]


CASES = [
    (FrameLayout(36, 10, burst=8), dict(p_pause=0.3, p_valid=0.7, seed=3)),
    (FrameLayout(40, 12, base=4096, burst=16), dict(p_pause=0.5, seed=4, dram_ns=7, pixel_ns=30)),
    (FrameLayout(5, 3, burst=4), dict(p_valid=0.3, seed=5)),
]


@pytest.mark.parametrize("layout, kw", CASES)
def test_frames_shown_whole_in_order_and_exact(layout, kw):
    fr = frames(layout, 3, kw["seed"])
    res = run(layout, MODE, fr, **kw)
    assert res["copied"] == 3 and not res["error"] and not res["underrun"], res
    assert res["in_order"] and res["all_shown"], res["shown"]
    assert res["shown"][-1] == 2
    assert res["memory_ok"] and res["bursts_ok"] and res["aw_equal"], res


def test_a_picture_copied_a_tile_at_a_time():
    """A 40 x 12 picture in 16 x 8 tiles (a grid of three by two, the last column and row cut by the picture's
    edge), each tile copied at its place, only the last of a picture showing it: every displayed frame is one
    whole picture, in order, the buffers hold the last two, every burst at its tile's place."""
    layout, tile = FrameLayout(40, 12, burst=8), (16, 8)
    rng = np.random.default_rng(12)
    pictures = [rng.integers(0, 1 << 16, (16, 48)) for _ in range(3)]
    res = run(layout, MODE, pictures, tile=tile, p_pause=0.3, p_valid=0.7, seed=12)
    assert res["copied"] == 3 * 6 and not res["error"] and not res["underrun"], res
    assert res["in_order"] and res["all_shown"] and res["shown"][-1] == 2, res["shown"]
    assert res["memory_ok"] and res["bursts_ok"] and res["aw_equal"], res


def test_a_memory_too_slow_for_the_display_is_caught():
    """Wait states on three clocks of four and a memory clock below the pixel clock: the scan-out falls behind."""
    layout = FrameLayout(36, 10, burst=8)
    res = run(layout, MODE, frames(layout, 2, 9), p_pause=0.75, dram_ns=60, pixel_ns=10, seed=9)
    assert res["underrun"]
    assert not res["all_shown"] or not res["in_order"] or None in res["shown"]


def test_frames_through_litedrams_simulation_core():
    """LiteDRAM's simulation core (its controller and SDRAM model, ``bumpmap litedram``) behind the frame, its init
    sequence run over the control port: the frames written and read back bit for bit, whole and in order."""
    pytest.importorskip("litedram")
    layout = FrameLayout(36, 10, burst=8)
    res = run(layout, MODE, frames(layout, 3, 11), p_valid=0.8, seed=11, litedram=True, sim="verilator")
    assert res["ready_ns"] is not None
    assert res["copied"] == 3 and not res["error"] and not res["underrun"], res
    assert res["in_order"] and res["all_shown"] and res["shown"][-1] == 2, res["shown"]
