"""``bumpmap animate``: a scene's animation (``[animation]``, ``host/scene_animation.py``) drawn by the model as the
board shows it (the engine's frame through the display's RGB565, ``board/frame.py``) into an animated picture
(imageio), and the frames per second the board with its frame in SDRAM sustains at 640 x 480 for every shipped
scene, the picture a tile at a time (``bumpmap send --frame sdram``): the engine's clocks a picture
(:func:`picture_clocks`: each tile's triangles from the model's scan converter, which the RTL matches clock for
clock, ``make sim``, and each tile's clear and copy), at the engine's placed clock
(``docs/board/bitstream-sdram.json``), against what the UART link carries a picture (each tile's FRAME_START,
triangles and COPY, and the cube uploads when the lights move) and the display's frame rate; and the SDRAM
bandwidth the frame uses (scan-out and the tiles' write-back) against its 200 MB/s.
``--record`` keeps the table (``docs/records/animation.json``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from board.frame import add_size_argument
from host.args import int_range

from .record import add_record_option, machine, write_if_asked

__all__ = ["add_arguments", "run", "scene_rates", "picture_clocks"]

#: The display mode the rates are for, and the SDRAM's peak (one x16 SDR chip at 100 MHz: board/budget.py).
WIDTH, HEIGHT, SDRAM_PEAK_MBPS = 640, 480, 200.0


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scene", default="tin-plane", help="the animated scene (name in scenes/ or a .toml path)")
    ap.add_argument("--preset", default="default", help="pipeline preset (built in or presets/<name>.toml)")
    add_size_argument(ap)
    ap.add_argument("--out", type=Path, default=Path("build/animate"), help="output folder")
    ap.add_argument("--gif", type=Path, help="the animated picture (default OUT/<scene file's stem>.gif)")
    ap.add_argument("--rates", nargs="*", default=None, metavar="SCENE",
                    help="scenes of the frames-per-second table, each with its preset (host/shipped.py; default: "
                         "every shipped scene)")
    ap.add_argument("--baud", type=int_range(300, 12_000_000), default=1_000_000, help="the UART's rate")
    add_record_option(ap, "the frames-per-second table")


def _engine_hz() -> tuple[float, str]:
    """The engine's clock: its target if the last bitstream met it, else its Fmax after routing; the PLL's target
    without a bitstream on record."""
    from board.top import engine_hz
    from fxmodel.core.paths import ROOT
    for name, what in (("bitstream-sdram", "placed and routed, the frame in SDRAM"),):
        try:
            clocks = json.loads((ROOT / "docs" / "board" / f"{name}.json").read_text())["clocks"]
        except (OSError, ValueError, KeyError):
            continue
        for clock, c in clocks.items():
            if "engine" in clock:
                met = c["met"]
                return (c["target_mhz"] if met else c["fmax_mhz"]) * 1e6, \
                    f"{what}: {'target met' if met else 'Fmax, target not met'}"
    return engine_hz("sdram"), "the PLL's target (no placed engine clock on record)"


def _prepare(scene, size, preset):
    """``(frame, tframe, clamped)``: the model's set-up and engine (saturating inputs the preset cannot hold, for
    the clock count, when it must)."""
    from host.render import ClampError, from_triangles, prepare
    try:
        frame, clamped = prepare(scene, size=size, preset=preset), False
    except ClampError:
        frame, clamped = prepare(scene, size=size, preset=preset, allow_clamp=True), True
    return frame, from_triangles(frame, depth=True), clamped


def picture_clocks(params, tiles, engine_hz: float, dram_hz: float) -> dict:
    """The engine's clocks for one picture drawn a tile at a time (``tiles`` as :func:`board.frame.picture_tiles`'s,
    ``params`` the tile's engine) on the board with its frame in SDRAM: for each tile its clear, its triangles and
    its copy. The triangles' clocks are the scan converter's (the model's, which the RTL matches clock for clock);
    a clear and a copy each wait :data:`board.cdc.QUIET` quiet clocks and walk the tile's pixels and the read-out's
    latency (``board.frame.TileCopy``), and a copy's words leave at most one an SDRAM clock (its FIFO's read side),
    so a copy takes at least the tile's pixels at the SDRAM's clock: a lower bound on the board's clocks (the
    SDRAM's refreshes and the scan-out's share of its port come on top)."""
    import math

    from board.cdc import QUIET
    from fxmodel.units.raster import scan
    rop = params.rop
    walk = QUIET + rop.pixels + rop.readout_latency + 1
    copy = max(walk, QUIET + math.ceil(rop.pixels * engine_hz / dram_hz))
    draw = sum(int(scan(params.raster, recs).clocks.sum()) for _, recs in tiles)
    return {"clocks": draw + len(tiles) * (walk + copy), "draw": draw, "clear_and_copy": len(tiles) * (walk + copy)}


def scene_rates(name: str, preset: str, engine_hz: float, baud: int, size: int) -> dict:
    """One scene's row on the board with its frame in SDRAM, the 640 x 480 picture a ``size`` tile at a time:
    clocks a picture (every frame of its animation, :func:`picture_clocks`), frames per second of the engine, the
    link (each tile's FRAME_START, triangles and COPY, SWAP after the last: ``bumpmap send --frame sdram``) and
    the display, and the SDRAM bandwidth at the rate shown."""
    from board.frame import picture_tiles
    from board.top import DRAM_HZ, PIXEL_HZ
    from board.video import VGA_640x480
    from host.engine_setup import frame_records
    from host.protocol import Cmd, picture_frames, upload_frames
    from host.render import ClampError, prepare
    from host.scene import load_scene, scene_path
    from host.scene_animation import frames
    scene = load_scene(scene_path(name))
    clocks, link_bytes, records, clamped = [], [], [], False
    moving = scene.animation is not None and scene.animation.light_turn != 0
    for s in frames(scene):
        try:
            f = prepare(s, size=(WIDTH, HEIGHT), preset=preset)
        except ClampError:
            f, clamped = prepare(s, size=(WIDTH, HEIGHT), preset=preset, allow_clamp=True), True
        params, tiles = picture_tiles(f, size)
        clocks.append(picture_clocks(params, tiles, engine_hz, DRAM_HZ))
        records.append(sum(len(r) for _, r in tiles))
        n = sum(map(len, picture_frames(params.raster.record, [(p, r.matrix()) for p, r in tiles], (size, size))))
        if moving:                                      # the reflectance cubes follow the lights
            n += sum(len(b) for mem, nm in enumerate(("diffuse", "specular"))
                     for b in upload_frames(Cmd.CUBE, mem, getattr(f.params, nm).words,
                                            getattr(f.params, nm).word_bits))
        link_bytes.append(n)
    worst = max(clocks, key=lambda c: c["clocks"])
    engine_fps = engine_hz / worst["clocks"]
    link_fps = baud / 10 / max(link_bytes)
    display_hz = PIXEL_HZ / VGA_640x480.frame_clocks          # the board's pixel clock, not the standard's
    shown = min(engine_fps, link_fps, display_hz)
    frame_mb = WIDTH * HEIGHT * 2 / 1e6                 # RGB565
    scan = frame_mb * display_hz
    write = len(tiles) * size * size * 2 / 1e6 * shown  # whole tiles, the last row's lines past the picture too
    return {"scene": scene.name, "preset": preset, "frames": len(clocks),
            "triangles": len(frame_records(f, params.raster)[0]), "tiles": len(tiles), "tile_records_max": max(records),
            "clamped": clamped,
            "engine_clocks_per_frame_max": worst["clocks"], "engine_clocks_drawing": worst["draw"],
            "engine_clocks_clear_and_copy": worst["clear_and_copy"],
            "engine_clocks_per_frame_mean": round(float(np.mean([c["clocks"] for c in clocks]))),
            "engine_fps": round(engine_fps, 1), "link_bytes_per_frame_max": max(link_bytes),
            "link_fps": round(link_fps, 1), "display_hz": round(display_hz, 2),
            "shown_fps": round(shown, 1), "sdram_MBps_scanout": round(scan, 1),
            "sdram_MBps_tile_writeback": round(write, 1), "sdram_MBps_total": round(scan + write, 1),
            "sdram_share_of_peak": round((scan + write) / SDRAM_PEAK_MBPS, 3)}


def _gif(args) -> dict:
    """The model's frames of ``args.scene`` as the board shows them, written as an animated GIF."""
    import imageio.v3 as iio

    from board.frame import display_frame
    from host.atomic import atomic_write_bytes, check_output_file
    from host.scene import load_scene, scene_path
    from host.scene_animation import frames
    file = scene_path(args.scene)
    # named by the scene FILE (from the command line), never by its `name` (the file's contents: "../../x")
    path = check_output_file(args.gif or args.out / f"{file.stem}.gif", "--gif file", inputs=[file])
    scene = load_scene(file)
    pics = []
    for s in frames(scene):
        _, tf, _ = _prepare(s, (args.size, args.size), args.preset)     # --size: the board's square frame
        _, color, _, _, _ = tf.params.draw(tf.records.matrix())
        h, w = color.shape[:2]
        pics.append(display_frame(color, w, h).astype(np.uint8))
    atomic_write_bytes(path, iio.imwrite("<bytes>", np.stack(pics), extension=".gif", duration=100, loop=0))
    return {"scene": scene.name, "preset": args.preset, "frames": len(pics), "size": args.size, "gif": str(path)}


def run(args: argparse.Namespace) -> int:
    from fxmodel.core.paths import shipped_scenes
    from host.scene import SceneError
    from host.shipped import scene_preset
    before = machine()
    t0 = time.perf_counter()
    engine_hz, source = _engine_hz()
    try:
        gif = _gif(args)
        names = args.rates if args.rates is not None else shipped_scenes()
        rows = [scene_rates(n, scene_preset(n), engine_hz, args.baud, args.size) for n in names]
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rec = {"animation": gif, "engine_mhz": engine_hz / 1e6, "engine_clock": source, "baud": args.baud,
           "tile": args.size,
           "mode": f"{WIDTH}x{HEIGHT}", "sdram_peak_MBps": SDRAM_PEAK_MBPS, "scenes": rows,
           "seconds": round(time.perf_counter() - t0, 1)}
    print(json.dumps(rec, indent=1))
    write_if_asked(args, rec, before)
    return 0
