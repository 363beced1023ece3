"""The board's bandwidth arithmetic (``docs/board.md``): what one x16 SDR SDRAM gives, what scan-out of the display
takes, what the engine's depth test and frame buffer would take at one fragment a clock, and what remains, for the
two frame-buffer strategies (on-chip tiles, or the frame buffer in SDRAM at a reduced rate).

``bumpmap board-budget OUT.json`` writes the record the docs quote (re-run it after changing a figure here).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from fxmodel.units.rop import DEPTH_BYTES, PIXEL_BYTES

from .video import VGA_640x480, VideoTiming

__all__ = ["budget", "add_arguments", "run", "write_text_atomic"]

#: DP16KD block RAMs of the LFE5U-85F, and the bits of one (18 Kbit).
DP16KD_COUNT, DP16KD_BITS = 208, 18 * 1024


def budget(timing: VideoTiming = VGA_640x480, *, sdram_mhz: float = 100.0, sdram_bytes: int = 2,
           engine_mhz: float = 110.0, color_bytes: int = 2, tile: int = 32, z_bits: int = 16,
           color_bits: int = 16) -> dict:
    """The figures, in MB/s (10**6 bytes), Mpixel/s and block RAMs. ``color_bytes``: bytes a pixel in the scanned
    frame (16-bit color); ``tile``, ``z_bits``, ``color_bits``: an on-chip tile's edge and words."""
    peak = sdram_mhz * sdram_bytes
    frame_px = timing.h_active * timing.v_active
    scan = frame_px * timing.frame_hz * color_bytes / 1e6
    compact = 2 * 2 + color_bytes                 # 16-bit depth read and write, 16-bit color write
    rop = DEPTH_BYTES + PIXEL_BYTES               # the engine's ROP today: 4-byte depth read, 8-byte word write
    tile_bits = tile * tile * (z_bits + color_bits)
    free = peak - scan
    return {
        "mode": f"{timing.h_active}x{timing.v_active} at {timing.frame_hz:.2f} Hz",
        "sdram_peak_MBps": peak,
        "scanout_MBps": round(scan, 1),
        "scanout_share_of_peak": round(scan / peak, 3),
        "engine_Mpx_per_s": engine_mhz,
        "bytes_per_fragment_compact": compact,
        "bytes_per_fragment_rop_today": rop,
        "drawing_MBps_compact": engine_mhz * compact,
        "drawing_MBps_rop_today": engine_mhz * rop,
        "sdram_left_after_scanout_MBps": round(free, 1),
        "direct_fb_Mpx_per_s_compact_at_peak": round(free / compact, 1),
        "direct_fb_Mpx_per_s_rop_today_at_peak": round(free / rop, 1),
        "direct_fb_share_of_engine_rate_compact": round(free / compact / engine_mhz, 3),
        "tile_edge": tile,
        "tile_bits": tile_bits,
        "tile_dp16kd": -(-tile_bits // DP16KD_BITS),
        "tile_dp16kd_double_buffered": 2 * -(-tile_bits // DP16KD_BITS),
        "dp16kd_total": DP16KD_COUNT,
        "tiles_per_frame": -(-timing.h_active // tile) * -(-timing.v_active // tile),
        "tile_writeback_MB_per_frame": round(frame_px * color_bytes / 1e6, 3),
        "tile_writeback_MBps_at_60fps": round(frame_px * color_bytes * timing.frame_hz / 1e6, 1),
    }


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (a temporary file in the same folder, then a rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap budget``, :mod:`tools.main`)."""
    ap.add_argument("out", type=Path, help="the JSON record to write")
    ap.add_argument("--engine-mhz", type=float, default=110.0, help="the engine's clock (default %(default)s)")
    ap.add_argument("--tile", type=int, default=32, help="on-chip tile edge in pixels (default %(default)s)")


def run(args: argparse.Namespace) -> int:
    if args.engine_mhz <= 0 or args.tile < 1:
        print("error: --engine-mhz and --tile must be positive", file=sys.stderr)
        return 2
    record = {"command": f"bumpmap board-budget {args.out} --engine-mhz {args.engine_mhz:g} --tile {args.tile}",
              **budget(engine_mhz=args.engine_mhz, tile=args.tile)}
    write_text_atomic(args.out, json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))
    return 0
