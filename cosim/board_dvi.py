"""Co-simulation harness of the DVI output (``board/dvi.py``'s :class:`~board.dvi.DisplayTest`): the testbench
``cosim.board_dvi_tb`` records the serial lanes (every edge of the five-times clock) or the encoders' words (every
pixel clock); here they are cut into 10-bit symbols at the clock lane's rising edge (as a DVI receiver's clock
recovery does), decoded (:func:`board.video.tmds_decode`, DVI 1.0 section 3.2) and compared with the golden model's
symbols and picture, and the video timing is measured from the decoded syncs alone.
"""

from __future__ import annotations

import hashlib

import numpy as np

from board.dvi import CLOCK_WORD, DisplayTest
from board.video import VideoTiming, frame_lanes, pattern_rgb, tmds_decode
from fxmodel.core.paths import source_digest

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job

__all__ = ["run", "symbols_from_serial", "decode", "measure"]


def _build(timing: VideoTiming, sim: str):
    key = hashlib.sha1(repr(timing).encode() + source_digest(("board",))).hexdigest()[:12]
    return component_build("display_test", key, sim, lambda: DisplayTest(timing))


def symbols_from_serial(bits: np.ndarray) -> np.ndarray:
    """Serial samples ``(N, 4)`` (lanes 0-2, lane 3 the clock; one row per bit time) -> symbols ``(K, 3)``: a
    symbol starts where the clock lane shows its word (five ones, then five zeros), bit 0 first."""
    clk = bits[:, 3]
    want = [(CLOCK_WORD >> i) & 1 for i in range(10)]
    starts = [i for i in range(len(clk) - 9) if clk[i:i + 10].tolist() == want]
    if not starts or any(b - a != 10 for a, b in zip(starts, starts[1:])):
        raise AssertionError(f"the clock lane is not one word every 10 bits: starts {starts[:5]}...")
    weights = 1 << np.arange(10)
    return np.array([[int(bits[s:s + 10, lane] @ weights) for lane in range(3)] for s in starts], dtype=np.int64)


def decode(symbols: np.ndarray) -> np.ndarray:
    """Symbols ``(K, 3)`` -> ``(K, 6)``: ``de, hsync, vsync, r, g, b`` per pixel clock (the syncs from lane 0's
    control tokens, held through active video as a receiver holds them)."""
    out, hs, vs = [], 0, 0
    for s0, s1, s2 in symbols.tolist():
        (de, b, c0), (de1, g, c1), (de2, r, c2) = tmds_decode(s0), tmds_decode(s1), tmds_decode(s2)
        if not de == de1 == de2 or c1 or c2:
            raise AssertionError(f"lanes disagree on de or carry control bits: {s0:#x} {s1:#x} {s2:#x}")
        if not de:
            hs, vs = c0 & 1, c0 >> 1
        out.append((de, hs, vs, r, g, b))
    return np.array(out, dtype=np.int64).reshape(-1, 6)


def _runs(x: np.ndarray, value: int) -> list[tuple[int, int]]:
    """``(start, length)`` of every run of ``value`` in ``x`` that is closed on both sides."""
    mask = np.concatenate([[0], (x == value).astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(mask))
    runs = [(int(a), int(b - a)) for a, b in zip(edges[::2], edges[1::2])]
    return [r for r in runs if r[0] > 0 and r[0] + r[1] < len(x)]


def measure(pix: np.ndarray, t: VideoTiming) -> dict:
    """The video timing read from decoded pixels alone: line period (hsync start to start), hsync width, active
    pixels per line, lines per frame, vsync width in clocks, frame period (first active pixel to the next frame's)."""
    de, hs, vs = pix[:, 0], pix[:, 1], pix[:, 2]
    h_act, v_act = int(t.h_sync_pos), int(t.v_sync_pos)
    hruns, vruns, druns = _runs(hs, h_act), _runs(vs, v_act), _runs(de, 1)
    frame_starts = [s for s, _ in druns if s >= t.h_total and not de[s - t.h_total:s].any()]
    return {"line_periods": sorted({b[0] - a[0] for a, b in zip(hruns, hruns[1:])}),
            "hsync_widths": sorted({n for _, n in hruns}), "active_widths": sorted({n for _, n in druns}),
            "vsync_widths": sorted({n for _, n in vruns}),
            "frame_periods": sorted({b - a for a, b in zip(frame_starts, frame_starts[1:])}),
            "lines_per_frame": sorted({sum(1 for s, _ in druns if a <= s < b)
                                       for a, b in zip(frame_starts, frame_starts[1:])})}


def run(timing: VideoTiming, *, serial: bool, clocks: int, sim: str | None = None) -> dict:
    """Simulate :class:`~board.dvi.DisplayTest` for ``clocks`` pixel clocks; return the decoded pixels ``pix``
    ``(K, 6)``, the symbols, the first symbol of a frame (``start``), the model's frame symbols ``want`` and the
    simulation's times."""
    sim = simulator(sim)
    top, bdir, src = _build(timing, sim)
    job = job_folder(bdir, "serial" if serial else "words", {"serial": serial, "clocks": clocks})
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.board_dvi_tb",
                                                {"serial": serial, "clocks": clocks}, "samples.npy")
    raw = np.load(out)
    remove_job(job)
    if serial:
        symbols = symbols_from_serial(raw)
    else:
        symbols = np.stack([(raw >> (10 * k)) & 0x3FF for k in range(3)], axis=1).astype(np.int64)
    pix = decode(symbols)
    start = int(np.flatnonzero(pix[:, 0])[0])          # reset leaves the counters in the vertical blanking
    return {"pix": pix, "symbols": symbols, "start": start, "want": np.array(frame_lanes(timing), dtype=np.int64),
            "build_seconds": build_seconds, "seconds": seconds, "simulator": sim}


def expected_picture(t: VideoTiming) -> np.ndarray:
    """The picture the display test shows, ``(v_active, h_active, 3)`` bytes."""
    return np.array([[pattern_rgb(x, y) for x in range(t.h_active)] for y in range(t.v_active)], dtype=np.int64)
