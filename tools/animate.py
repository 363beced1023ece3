"""``bumpmap animate``: a scene's animation (``[animation]``, ``host/scene_animation.py``) drawn by the model as the
board shows it (the engine's frame through the display's RGB565, ``board/frame.py``) into an animated picture
(imageio), and the frames per second the board sustains at 640 x 480 for every shipped scene: the engine's
clocks a frame from the model (the scan converter's clocks, which the RTL matches clock for clock: ``make sim``),
at the engine's placed clock (``docs/board/bitstream.json``), against what the UART link carries a frame (the
triangles, and the cube uploads when the lights move) and the display's frame rate; and the SDRAM bandwidth the
frame would use (scan-out and the finished tiles' write-back, ``board/budget.py``) against its 200 MB/s.
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

__all__ = ["add_arguments", "run", "scene_rates"]

#: The display mode the rates are for, and the SDRAM's peak (one x16 SDR chip at 100 MHz: board/budget.py).
WIDTH, HEIGHT, SDRAM_PEAK_MBPS = 640, 480, 200.0


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scene", default="tin-plane", help="the animated scene (name in scenes/ or a .toml path)")
    ap.add_argument("--preset", default="default", help="pipeline preset (built in or presets/<name>.toml)")
    add_size_argument(ap)
    ap.add_argument("--out", type=Path, default=Path("build/animate"), help="output folder")
    ap.add_argument("--gif", type=Path, help="the animated picture (default OUT/<scene>.gif)")
    ap.add_argument("--rates", nargs="*", default=None, metavar="SCENE",
                    help="scenes of the frames-per-second table, each with its preset (host/shipped.py; default: "
                         "every shipped scene)")
    ap.add_argument("--baud", type=int_range(300, 12_000_000), default=1_000_000, help="the UART's rate")
    add_record_option(ap, "the frames-per-second table")


def _engine_hz() -> tuple[float, str]:
    """The engine's clock: its target if the last bitstream met it, else its Fmax after routing; the PLL's target
    without a bitstream on record."""
    from board.top import ENGINE_HZ
    from fxmodel.core.paths import ROOT
    for name, what in (("bitstream", "placed and routed"),):
        try:
            clocks = json.loads((ROOT / "docs" / "board" / f"{name}.json").read_text())["clocks"]
        except (OSError, ValueError, KeyError):
            continue
        for clock, c in clocks.items():
            if "engine" in clock:
                met = c["met"]
                return (c["target_mhz"] if met else c["fmax_mhz"]) * 1e6, \
                    f"{what}: {'target met' if met else 'Fmax, target not met'}"
    return ENGINE_HZ, "the PLL's target (no placed engine clock on record)"


def _prepare(scene, size, preset):
    """``(frame, tframe, clamped)``: the model's set-up and engine (saturating inputs the preset cannot hold, for
    the clock count, when it must)."""
    from host.render import ClampError, from_triangles, prepare
    try:
        frame, clamped = prepare(scene, size=size, preset=preset), False
    except ClampError:
        frame, clamped = prepare(scene, size=size, preset=preset, allow_clamp=True), True
    return frame, from_triangles(frame, depth=True), clamped


def scene_rates(name: str, preset: str, engine_hz: float, baud: int) -> dict:
    """One scene's row: clocks a frame (every frame of its animation), frames per second of the engine, the link
    and the display, and the SDRAM bandwidth at the rate shown."""
    from board.top import PIXEL_HZ
    from board.video import VGA_640x480
    from host.protocol import Cmd, frame_start, triangle_frames, upload_frames
    from host.protocol import frame as proto_frame
    from host.scene import load_scene, scene_path
    from host.scene_animation import frames
    scene = load_scene(scene_path(name))
    clocks, link_bytes, clamped = [], [], False
    moving = scene.animation is not None and scene.animation.light_turn != 0
    for s in frames(scene):
        f, tf, c = _prepare(s, (WIDTH, HEIGHT), preset)
        clamped |= c
        clocks.append(int(tf.scan.clocks.sum()))
        n = sum(map(len, triangle_frames(tf.params.raster.record, tf.records.matrix())))
        n += len(frame_start(WIDTH, HEIGHT)) + len(proto_frame(Cmd.SWAP))
        if moving:                                      # the reflectance cubes follow the lights
            n += sum(len(b) for mem, nm in enumerate(("diffuse", "specular"))
                     for b in upload_frames(Cmd.CUBE, mem, getattr(f.params, nm).words,
                                            getattr(f.params, nm).word_bits))
        link_bytes.append(n)
    worst = max(clocks)
    engine_fps = engine_hz / worst
    link_fps = baud / 10 / max(link_bytes)
    display_hz = PIXEL_HZ / VGA_640x480.frame_clocks          # the board's pixel clock, not the standard's
    shown = min(engine_fps, link_fps, display_hz)
    frame_mb = WIDTH * HEIGHT * 2 / 1e6                 # RGB565
    scan = frame_mb * display_hz
    write = frame_mb * shown
    return {"scene": scene.name, "preset": preset, "frames": len(clocks), "triangles": len(tf.records),
            "clamped": clamped,
            "engine_clocks_per_frame_max": worst, "engine_clocks_per_frame_mean": round(float(np.mean(clocks))),
            "engine_fps": round(engine_fps, 1), "link_bytes_per_frame_max": max(link_bytes),
            "link_fps": round(link_fps, 1), "display_hz": round(display_hz, 2),
            "shown_fps": round(shown, 1), "sdram_MBps_scanout": round(scan, 1),
            "sdram_MBps_tile_writeback": round(write, 1), "sdram_MBps_total": round(scan + write, 1),
            "sdram_share_of_peak": round((scan + write) / SDRAM_PEAK_MBPS, 3)}


def _gif(args) -> dict:
    """The model's frames of ``args.scene`` as the board shows them, written as an animated GIF."""
    import imageio.v3 as iio

    from board.frame import display_frame
    from host.scene import load_scene, scene_path
    from host.scene_animation import frames
    scene = load_scene(scene_path(args.scene))
    pics = []
    for s in frames(scene):
        _, tf, _ = _prepare(s, args.size, args.preset)
        _, color, _, _, _ = tf.params.draw(tf.records.matrix())
        h, w = color.shape[:2]
        pics.append(display_frame(color, w, h).astype(np.uint8))
    path = args.gif or args.out / f"{scene.name}.gif"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.gif")
    iio.imwrite(tmp, np.stack(pics), duration=100, loop=0)
    tmp.replace(path)
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
        rows = [scene_rates(n, scene_preset(n), engine_hz, args.baud) for n in names]
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rec = {"animation": gif, "engine_mhz": engine_hz / 1e6, "engine_clock": source, "baud": args.baud,
           "mode": f"{WIDTH}x{HEIGHT}", "sdram_peak_MBps": SDRAM_PEAK_MBPS, "scenes": rows,
           "seconds": round(time.perf_counter() - t0, 1)}
    print(json.dumps(rec, indent=1))
    write_if_asked(args, rec, before)
    return 0
