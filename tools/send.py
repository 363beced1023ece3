"""``bumpmap send``: a scene drawn on the board. The host's set-up (:func:`host.render.prepare` and
:func:`host.render.from_triangles`: the triangle records of the scan converter, the preset's texel memories) is sent
over the UART as the protocol's frames (``host/protocol.py``, ``docs/protocol.md``): the four texel memories,
FRAME_START, the triangles, SWAP (with ``--frame sdram``, the bitstream with its frame in SDRAM: the display's
whole picture, each tile's FRAME_START at its place, its triangles and COPY, SWAP after the last); with
``--animate`` the frames of the scene's animation (``[animation]``,
``host/scene_animation.py``) in turn, each after the first with its reflectance cubes again when the lights move.
Each frame waits for the board's answer; an error byte stops the send (exit 1) after a CLEAR, naming the error.
After each SWAP it asks STATUS until the picture is shown and fails (exit 1) when one of the frame's flags is set
(a lost record, a fragment outside the tile, a depth saturated: FRAME_START cleared them) or one of the board's
sticky flags rose meanwhile (an upload's word not written, the frame store's error): the picture on the monitor is
then not the scene's. Sticky flags set before the run (they stay until the board is configured again) are named
as a warning. ``--dry-run FILE`` writes the bytes instead (the
co-simulation's input).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from board.frame import BOARD_PRESET, BOARD_SIZE, add_frame_argument, add_textures_argument
from host.args import int_range
from host.atomic import atomic_write_bytes, check_output_file
from host.protocol import Err

__all__ = ["add_arguments", "run", "scene_bytes"]

ERRORS = {Err.SYNC: "SYNC (a byte where a frame must start)", Err.COMMAND: "COMMAND (unknown command code)",
          Err.LENGTH: "LENGTH (a length outside the command's range)",
          Err.CRC: "CRC (the frame's checksum did not match)", Err.FRAMING: "FRAMING (the UART saw no stop bit)",
          Err.SIZE: "SIZE (FRAME_START's width and height are not the board's tile, or its place is outside the "
                    "board's grid of tiles: give --size and --frame the bitstream's)",
          Err.BUSY: "BUSY (an upload while a frame is drawn)",
          Err.MAPS: "MAPS (a TEXTURE frame whose words are not the form of the board's maps, on chip or in SDRAM: "
                    "give --textures as the bitstream was built)"}


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scene", default="tin-plane", help="scene name in scenes/ or a .toml path")
    ap.add_argument("--preset", default=BOARD_PRESET,
                    help="pipeline preset (built in or presets/<name>.toml; default %(default)s, the board's)")
    ap.add_argument("--size", type=int_range(1, 4096), default=BOARD_SIZE,
                    help="the image's edge in pixels (default %(default)s: the board's tile, board/frame.py "
                         "BOARD_SIZE; a bitstream built with another --size needs the same here)")
    ap.add_argument("--cube-size", type=int_range(2, 1024), default=None, help="texels per cube face edge")
    ap.add_argument("--port", help="serial port of the board (e.g. /dev/ttyUSB0; needs pyserial)")
    ap.add_argument("--baud", type=int_range(300, 12_000_000), default=1_000_000,
                    help="the board's rate (default %(default)s: board/ulx3s.py)")
    ap.add_argument("--timeout", type=float, default=1.0, help="seconds to wait for each answer")
    ap.add_argument("--shown-wait", type=float, default=2.0,
                    help="seconds to wait after SWAP for the picture to be shown (STATUS not busy)")
    ap.add_argument("--dry-run", type=Path, metavar="FILE", help="write the bytes to FILE instead of a port")
    ap.add_argument("--animate", action="store_true",
                    help="send the frames of the scene's [animation] in turn (default: its first frame)")
    add_frame_argument(ap, "the bitstream's frame store (bumpmap bitstream --frame; the triangles binned by "
                            "tile)")
    add_textures_argument(ap)


def scene_bytes(args) -> list[bytes]:
    """The frames of the scene (``args.scene``, ``args.preset``, ``args.size``, ``args.cube_size``; with
    ``args.frame`` ``sdram`` the display's picture a ``size`` tile at a time, :func:`board.frame.board_picture`;
    with ``args.textures`` the maps in SDRAM, sent as the words of their spans of the texture layout:
    :func:`host.protocol.upload_frames_of`)."""
    from board.frame import board_picture, board_textures
    from host.protocol import Cmd, picture_frames, scene_frames, upload_frames_of
    from host.render import from_triangles, prepare
    from host.scene import load_scene, scene_path
    from host.scene_animation import frames as animation_frames

    scene = load_scene(scene_path(args.scene))
    out = []
    for k, s in enumerate(animation_frames(scene) if getattr(args, "animate", False) else [scene]):
        textures = getattr(args, "textures", False)
        if getattr(args, "frame", "chip") == "sdram":
            params, frame, tiles = board_picture(s, args.preset, args.size, cube_size=args.cube_size)
            params = board_textures(params, textures, "sdram")
            sent = upload_frames_of(frame.params, params) + picture_frames(
                params.raster.record, [(place, recs.matrix()) for place, recs in tiles], (args.size, args.size))
        else:
            board_textures(None, textures, "chip")              # (refused: no SDRAM with the frame on chip)
            frame = prepare(s, size=(args.size, args.size), preset=args.preset,   # the on-chip tile
                            cube_size=args.cube_size)
            tframe = from_triangles(frame)
            sent = scene_frames(frame.params, tframe.params.raster.record, tframe.records.matrix(),
                                (frame.scene.width, frame.scene.height))
        if k and (scene.animation is None or scene.animation.light_turn == 0):
            sent = [f for f in sent if f[1] not in (Cmd.TEXTURE, Cmd.CUBE)]
        elif k:                                         # the maps stay; the cubes follow the lights
            sent = [f for f in sent if f[1] != Cmd.TEXTURE]
        out += sent
    return out


def _ask(port) -> int | None:
    """The board's answer to STATUS (``None``: no answer within the port's timeout)."""
    from host.protocol import Cmd, frame
    port.write(frame(Cmd.STATUS))
    answer = port.read(1)
    return answer[0] if answer else None


def _shown(port, before: set, k: int, wait: float) -> str | None:
    """After the SWAP frame ``k``: ask STATUS until the picture is shown (``busy`` clear, at most ``wait``
    seconds); ``None`` if it is with none of the frame's flags (``host.protocol.FRAME_FLAGS``) and no sticky flag
    that was not in ``before``, else the error's line."""
    from host.protocol import FRAME_FLAGS, state_names
    deadline = time.monotonic() + wait
    while True:
        answer = _ask(port)
        if answer is None:
            return f"no answer to STATUS after frame {k} within {port.timeout} s"
        try:
            names = state_names(answer)
        except ValueError as exc:
            return f"after frame {k}: {exc}"
        if "busy" not in names:
            break
        if time.monotonic() > deadline:
            return f"the picture of frame {k} (SWAP) was not shown within {wait} s: the board is still busy"
        time.sleep(0.01)
    new = [n for n in names if n in FRAME_FLAGS or n not in before]
    if new:
        return (f"the board drew the picture of frame {k} (SWAP) with " + ", ".join(new)
                + " (docs/protocol.md: the board's state)")
    return None


def _send(frames: list[bytes], args) -> int:
    from host.protocol import ACK, CLEAR_FRAME, FRAME_FLAGS, Cmd, state_names
    try:
        import serial
    except ModuleNotFoundError:
        print("error: --port needs pyserial (pip install -e '.[board]')", file=sys.stderr)
        return 2
    try:
        port = serial.Serial(args.port, args.baud, timeout=args.timeout)
    except (serial.SerialException, ValueError) as exc:
        print(f"error: --port {args.port}: {exc}", file=sys.stderr)
        return 2
    with port:
        port.write(CLEAR_FRAME)                 # leave an error state a previous run may have left
        port.read(1)
        answer = _ask(port)
        try:
            before = None if answer is None else set(state_names(answer)) - {"busy", *FRAME_FLAGS}
        except ValueError:                      # not a STATUS answer: an older bitstream answers ACK
            before = None
        if before is None:
            got = "nothing" if answer is None else f"{answer:#04x}"
            print(f"error: the board did not answer STATUS with its state (got {got} within {args.timeout} s): is "
                  f"it configured with a bitstream of this checkout (make bitstream), and is --port {args.port} its "
                  f"UART?", file=sys.stderr)
            return 1
        if before:
            print(f"warning: the board's sticky flags {', '.join(sorted(before))} were set before this run (since "
                  f"it was configured): this run cannot see them rise again; load the bitstream again to clear them",
                  file=sys.stderr)
        for k, data in enumerate(frames):
            port.write(data)
            answer = port.read(1)
            if not answer:
                print(f"error: no answer to frame {k} within {args.timeout} s", file=sys.stderr)
                return 1
            if answer[0] != ACK:
                code = answer[0] & 0x7F
                print(f"error: the board refused frame {k}: {ERRORS.get(code, code)}; sent CLEAR", file=sys.stderr)
                port.write(CLEAR_FRAME)
                return 1
            if data[1] == Cmd.SWAP:
                err = _shown(port, before, k, args.shown_wait)
                if err:
                    print(f"error: {err}", file=sys.stderr)
                    return 1
    return 0


def run(args: argparse.Namespace) -> int:
    """Send a scene to the board over the UART (or write its bytes with --dry-run)."""
    from host.scene import SceneError
    if not args.port and not args.dry_run:
        print("error: give --port PORT or --dry-run FILE", file=sys.stderr)
        return 2
    try:
        if args.dry_run:                # before any work; not over the scene file it reads
            from host.scene import scene_path
            check_output_file(args.dry_run, "--dry-run file", inputs=[scene_path(args.scene)])
        frames = scene_bytes(args)
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    total = sum(map(len, frames))
    print(f"{args.scene}: {len(frames)} frames, {total} bytes, {total * 10 / args.baud:.2f} s at {args.baud} baud")
    if args.dry_run:
        atomic_write_bytes(args.dry_run, b"".join(frames))
        print(f"wrote {args.dry_run}")
        return 0
    return _send(frames, args)
