"""The SDRAM bandwidth of the frame in SDRAM (``board/sdram_frame.py``, ``docs/board.md``): the scan-out reads the
front buffer once a display frame, a copy writes the back buffer once a frame drawn; against the core's peak on
the board (one 16-bit word a clock of the SDRAM's clock, ``board.top.DRAM_HZ``, half the chip's rated 100 MHz).
For today's frame (the tile, 128 x 128) and a whole 640 x 480 frame, at the worst case of a new frame every display
frame; and the line FIFO's reserve (paper, section 4: the frame buffer the display reads).

``bumpmap sdram-bandwidth OUT.json`` writes the record the docs quote (``docs/board/sdram-bandwidth.json``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .budget import write_text_atomic
from .litedram import DATA_BITS, SDRAM_HZ
from .sdram_frame import FIFO_DEPTH, FrameLayout, bandwidth
from .sdram_system import BURST
from .video import VGA_640x480

__all__ = ["record", "add_arguments", "run"]


def record(sizes=((128, 128), (640, 480)), timing=VGA_640x480) -> dict:
    """The bandwidth of each frame size against the peak, the bursts and the line FIFO's reserve."""
    from .top import DRAM_HZ
    peak = DRAM_HZ * DATA_BITS // 8
    fifo = FIFO_DEPTH
    rows = []
    for w, h in sizes:
        L = FrameLayout(w, h, burst=min(BURST, 1 << (w - 1).bit_length()))
        b = bandwidth(L, timing, timing.frame_hz)
        rows.append({"width": w, "height": h, **b, "share_of_peak": round(b["total_MBps"] * 1e6 / peak, 3),
                     "bursts_per_frame": L.bursts, "burst_beats": L.burst})
    return {"mode": f"{timing.h_active}x{timing.v_active} at {timing.frame_hz:.2f} Hz",
            "sdram_clock_MHz": DRAM_HZ / 1e6, "chip_clock_MHz": SDRAM_HZ / 1e6, "sdram_peak_MBps": peak / 1e6,
            "copies_per_s": round(timing.frame_hz, 2), "frames": rows,
            "line_fifo_words": fifo, "line_fifo_us_at_pixel_clock": round(fifo / timing.pixel_hz * 1e6, 1),
            "line_fifo_lines_640": round(fifo / timing.h_active, 2)}


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap sdram-bandwidth``, :mod:`tools.main`)."""
    ap.add_argument("out", type=Path, help="the JSON record to write")


def run(args: argparse.Namespace) -> int:
    rec = {"command": f"bumpmap sdram-bandwidth {args.out}", **record()}
    write_text_atomic(args.out, json.dumps(rec, indent=1) + "\n")
    print(json.dumps(rec, indent=1))
    return 0
