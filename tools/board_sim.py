"""``bumpmap board-sim`` (``make board-sim``): the end-to-end simulation of the board (``cosim/board_system.py``):
the host tool's bytes through the UART, the engine, its on-chip tile, the frame store and the DVI display, the
decoded frame compared with the model's on every pixel and the video timing checked; ``--record`` keeps the result
(``docs/records/board-sim.json``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from board.frame import (
    BOARD_PRESET,
    add_frame_argument,
    add_size_argument,
    add_textures_argument,
    board_engine,
    board_picture,
    board_textures,
    tiled_color,
)
from cosim.board_system import simulate, split_frames
from host.protocol import Cmd

__all__ = ["add_arguments", "run"]

from .record import add_record_option, machine, write_if_asked


def add_arguments(ap) -> None:
    """``bumpmap board-sim``: the end-to-end simulation of the board drawing a scene."""
    ap.add_argument("--scene", default="tin-plane", help="scene name in scenes/ or a .toml path")
    ap.add_argument("--preset", default=BOARD_PRESET,
                    help="pipeline preset (built in or presets/<name>.toml; default %(default)s, the board's)")
    add_size_argument(ap)
    ap.add_argument("--bytes", type=Path, metavar="FILE",
                    help="the host's bytes (bumpmap send --dry-run FILE, same scene, preset and size); default: "
                         "the same frames made here")
    ap.add_argument("--sim", default="verilator", choices=("verilator", "icarus"), help="simulator")
    add_frame_argument(ap, "the frame store (SDRAM: LiteDRAM's simulation core)")
    add_textures_argument(ap)
    ap.add_argument("--uploads", action="store_true",
                    help="send the TEXTURE and CUBE frames too, into texel memories that start at zero, the UART "
                         "faster in simulation (with --frame chip; without it the memories hold the scene's tables "
                         "and the uploads are left out)")
    ap.add_argument("--out", type=Path, default=Path("build/board-sim"), help="output folder (the decoded PNG)")
    add_record_option(ap, "the result")


def run(args) -> int:
    """Draw the scene through the simulated board and compare the decoded DVI frame with the model's."""
    import sys

    from host.images import save_png
    from host.protocol import picture_frames, scene_frames, triangle_frames, upload_frames_of
    from host.scene import SceneError

    if args.uploads and args.frame != "chip":
        print("error: --uploads: simulated with --frame chip only", file=sys.stderr)
        return 2
    before = machine()
    t0 = time.perf_counter()
    tiled = args.frame == "sdram"
    try:
        if tiled:                               # the display's picture a tile at a time (bumpmap send --frame)
            params, frame, tiles = board_picture(args.scene, args.preset, args.size)
            params = board_textures(params, args.textures, args.frame)
            per_tile = [(place, recs.matrix()) for place, recs in tiles]
            mat = np.concatenate([m for _, m in per_tile])
            made = upload_frames_of(frame.params, params) + picture_frames(params.raster.record, per_tile,
                                                                           (args.size, args.size))
        else:
            board_textures(None, args.textures, args.frame)         # (refused with the frame on chip)
            params, frame, tframe = board_engine(args.scene, args.preset, args.size)
            mat = tframe.records.matrix()
            made = scene_frames(frame.params, params.raster.record, mat, (params.rop.width, params.rop.height))
        data = args.bytes.read_bytes() if args.bytes else b"".join(made)
        tri = [f for f in split_frames(data) if f[1] == Cmd.TRIANGLE]
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if tri != triangle_frames(params.raster.record, mat):
        print(f"error: {args.bytes}: its TRIANGLE frames are not the records of {args.scene} at --size {args.size} "
              f"with --preset {args.preset} and --frame {args.frame}", file=sys.stderr)
        return 2
    grid = f", {len(tiles)} tiles" if tiled else ""
    print(f"{frame.scene.name}: {len(mat)} triangles, {params.rop.width}x{params.rop.height} tile{grid}, "
          f"{len(data)} bytes from the host, RTL on {args.sim}")
    picture = tiled_color(params, tiles, (frame.scene.width, frame.scene.height)) if tiled else None
    rep = simulate(params, mat, data, sim=args.sim, frame=args.frame, uploads=args.uploads, picture=picture)
    out = args.out / frame.scene.name
    save_png(out / "model.png", rep.pop("want").astype(np.uint8))
    if "picture" in rep:
        save_png(out / "dvi.png", rep.pop("picture").astype(np.uint8))
    rep.update(scene=frame.scene.name, preset=args.preset, tile=[params.rop.width, params.rop.height],
               picture_size=[frame.scene.width, frame.scene.height], tiles=len(tiles) if tiled else 1,
               triangles=len(mat), wall_seconds=round(time.perf_counter() - t0, 1))
    from host.atomic import atomic_json
    atomic_json(out / "report.json", rep)
    ok = rep["shown"] and rep["mismatches"] == 0 and rep["timing_ok"] and rep["acks_ok"] and rep["state_ok"] \
        and not any(rep[k] for k in ("error", "overrun", "rop_status", "underrun", "mem_error", "upload_bad"))
    print(json.dumps({k: v for k, v in rep.items() if k not in ("timing", "timing_expected")}, indent=1))
    print(("  decoded DVI frame == model's frame on every pixel, video timing as the mode's" if ok else
           "  FAIL: the decoded frame, the timing or the link differ (report above)") + f"; output {out}")
    write_if_asked(args, rep, before)
    return 0 if ok else 1
