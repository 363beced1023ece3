"""Co-simulation of the board's UART command link (``board/command.py``): the host protocol's bytes in through the
``rx`` line (cocotbext-uart), the commands the RTL parses and the replies it sends on ``tx`` equal those of the
reference parser :func:`host.protocol.parse`, through good frames of every command (STATUS answered with the board's
state on the link's input; a picture's tiles at their places in the grid, each ended by COPY) and each error (bad
CRC, unknown command, bad length, a FRAME_START of another size or outside the grid, an upload while a frame is
drawn, a TEXTURE frame of the other form than the board's maps, a stray byte), each cleared by the CLEAR frame."""

from __future__ import annotations

import random

from cosim.board_uart import run
from host.protocol import (
    ACK,
    CLEAR_FRAME,
    STATE_ANSWER,
    Cmd,
    Err,
    frame,
    frame_place,
    frame_start,
    parse,
    upload_frames,
)

RECORD_LEN = 13
TILE = (300, 7)                                         # a tile's width and height: FRAME_START must name them
GRID = (3, 258)                                         # the board's columns and rows of tiles
STATE = 0b101100                                        # the board's state bits (not busy), STATUS's answer


def _stream() -> tuple[bytes, list]:
    rng = random.Random(26)
    good = upload_frames(Cmd.TEXTURE, 1, [rng.randrange(1 << 24) for _ in range(6)], 24, chunk=9)
    good += upload_frames(Cmd.CUBE, 0, [rng.randrange(1 << 27) for _ in range(3)], 27)
    good += [frame_start(*TILE)]
    good += [frame(Cmd.TRIANGLE, bytes(rng.randrange(256) for _ in range(RECORD_LEN))) for _ in range(3)]
    good += [frame(Cmd.COPY), frame_start(*TILE, 2, 257), frame(Cmd.COPY)]       # a picture's tiles, in the grid
    good += upload_frames(Cmd.CUBE, 1, [9], 27)                                   # taken between tiles
    good += [frame_start(*TILE, 1, 0)]
    good += [frame(Cmd.SWAP), frame(Cmd.STATUS)]
    bad_crc = bytearray(frame(Cmd.TRIANGLE, bytes(RECORD_LEN)))
    bad_crc[-2] ^= 0x10
    errors = [bytes(bad_crc) + frame(Cmd.SWAP),                       # the SWAP after it is ignored
              bytes([0xA5, 0x09, 0, 0]),                              # unknown command
              frame(Cmd.TRIANGLE, bytes(RECORD_LEN - 1)),            # wrong record length
              frame_start(TILE[0], TILE[0]),                          # another frame's size (its height)
              frame_start(TILE[0] ^ 0x100, TILE[1]),                  # (its width's high byte)
              frame_start(*TILE, GRID[0], 0),                         # a column outside the grid
              frame_start(*TILE, 0, GRID[1]),                         # a row outside the grid (its high byte)
              frame_start(TILE[0], TILE[0], 1, 1),                    # another size at a place in the grid
              frame_start(*TILE) + upload_frames(Cmd.CUBE, 1, [5], 27)[0],   # an upload while a frame is drawn
              upload_frames(Cmd.TEXTURE, 0, [5], 32, maps="sdram")[0],      # the maps-in-SDRAM form to chip maps
              b"\x00"]                                                # a stray byte where a frame must start
    data = b"".join(good)
    for e in errors:
        data += e + CLEAR_FRAME + frame(Cmd.STATUS)
    return data, good


def test_commands_replies_and_errors_match_the_reference_parser(sim):
    data, good = _stream()
    want = parse(data, RECORD_LEN, TILE, STATE, GRID, maps="chip")
    codes = [r & 0x7F for r in want.replies if r & 0x80]
    assert codes == [Err.CRC, Err.COMMAND, Err.LENGTH] + [Err.SIZE] * 5 + [Err.BUSY, Err.MAPS, Err.SYNC]  # each meant
    assert len(want.commands) == len(good) + len(codes) + 1         # the STATUS after each CLEAR, a FRAME_START
    assert want.replies.count(STATE_ANSWER | STATE) == 1 + len(codes)
    assert parse(data, RECORD_LEN, TILE, STATE).replies != want.replies       # the grid's places are checked
    res = run(data, RECORD_LEN, TILE, STATE, grid=GRID, maps="chip", sim=sim)
    assert res["commands"] == want.commands
    assert res["places"] == [list(frame_place(p)[2:]) for c, p in want.commands if c == Cmd.FRAME_START]
    assert [1, 0] in res["places"] and [2, 257] in res["places"]
    assert res["replies"] == bytes(want.replies)
    assert (res["error"], res["code"]) == (0, 0)


def test_uploads_are_refused_while_the_board_is_busy(sim):
    """With ``busy`` in the board's state (a SWAP's picture not shown yet) every upload is refused with BUSY, before
    any of its words is passed on; other frames are taken."""
    upload = upload_frames(Cmd.TEXTURE, 0, [1, 2, 3], 24)[0]
    data = frame(Cmd.STATUS) + upload + CLEAR_FRAME + frame(Cmd.SWAP)
    want = parse(data, RECORD_LEN, TILE, 1)
    assert want.replies == [STATE_ANSWER | 1, 0x80 | Err.BUSY, ACK, ACK]
    res = run(data, RECORD_LEN, TILE, 1, sim=sim)
    assert res["commands"] == want.commands and res["replies"] == bytes(want.replies)


def test_a_board_with_its_maps_in_sdram_refuses_the_on_chip_form(sim):
    """A board built with its maps in SDRAM takes TEXTURE frames of their form (``SDRAM_FORM`` in the memory
    byte) and refuses the on-chip form with MAPS once its CRC matched; CUBE frames are taken as ever."""
    from host.protocol import SDRAM_FORM
    good = upload_frames(Cmd.TEXTURE, 1, [7, 8], 32, maps="sdram")[0]
    chip = upload_frames(Cmd.TEXTURE, 1, [7, 8], 32)[0]
    data = good + upload_frames(Cmd.CUBE, 0, [3], 27)[0] + chip + CLEAR_FRAME + frame(Cmd.STATUS)
    want = parse(data, RECORD_LEN, TILE, maps="sdram")
    assert want.replies == [ACK, ACK, 0x80 | Err.MAPS, ACK, STATE_ANSWER]
    assert want.commands[0][1][0] == SDRAM_FORM | 1
    res = run(data, RECORD_LEN, TILE, maps="sdram", sim=sim)
    assert res["commands"] == want.commands and res["replies"] == bytes(want.replies)


def test_the_error_state_is_sticky_without_clear(sim):
    bad = bytearray(frame(Cmd.STATUS))
    bad[-1] ^= 1
    data = frame(Cmd.STATUS) + bytes(bad) + frame(Cmd.STATUS) + frame(Cmd.SWAP)
    res = run(data, RECORD_LEN, sim=sim)
    assert res["commands"] == [(Cmd.STATUS, b"")]
    assert res["replies"] == bytes([STATE_ANSWER, 0x80 | Err.CRC])
    assert (res["error"], res["code"]) == (1, Err.CRC)


def test_the_tin_plane_triangles_through_the_link(sim):
    """The tin plane's FRAME_START, triangle records and SWAP as ``bumpmap send`` writes them (the texel uploads
    are left out: 260 kB would take minutes of UART time), parsed by the RTL with the engine's record length."""
    from host.protocol import record_bytes, triangle_frames
    from host.render import from_triangles, prepare
    from host.scene import scene_path

    prepared = prepare(scene_path("tin-plane"))
    tile = (prepared.scene.width, prepared.scene.height)
    tframe = from_triangles(prepared)
    ports = tframe.params.raster.record
    data = frame_start(*tile) + b"".join(triangle_frames(ports, tframe.records.matrix())) + frame(Cmd.SWAP)
    n = record_bytes(ports)
    want = parse(data, n, tile)
    res = run(data, n, tile, sim=sim)
    assert len(want.commands) == len(tframe.records) + 2 and want.error == 0
    assert res["commands"] == want.commands and res["replies"] == bytes(want.replies)
