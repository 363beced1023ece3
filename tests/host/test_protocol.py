"""The UART command protocol (``host/protocol.py``): the CRC against its published check value, frames and the
reference parser's error state, the packing of triangle records and uploads."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from host.protocol import (
    ACK,
    CLEAR_FRAME,
    LENGTHS,
    MAX_PAYLOAD,
    SYNC,
    Cmd,
    Err,
    crc16,
    frame,
    frame_start,
    parse,
    upload_frames,
)


def test_crc_check_value():
    assert crc16(b"123456789") == 0x29B1                  # CRC-16/CCITT-FALSE's catalogued check value


@given(st.sampled_from([Cmd.TEXTURE, Cmd.CUBE]), st.binary(min_size=6, max_size=300))
def test_a_frame_parses_back_to_its_command(cmd, payload):
    data = frame(cmd, payload)
    assert data[0] == SYNC and int.from_bytes(data[2:4], "little") == len(payload)
    assert parse(data, 8).commands == [(cmd, payload)]


@given(st.binary(min_size=6, max_size=40), st.integers(0, 10_000), st.integers(0, 7))
def test_a_single_bit_flip_is_never_accepted(payload, where, bit):
    """CRC-16 detects every single-bit error: the flipped frame is refused (an error), or, with its length field
    hit, waits for bytes that are not its own; a good frame after it is then swallowed, never a wrong upload
    accepted."""
    data = bytearray(frame(Cmd.TEXTURE, payload))
    data[where % len(data)] ^= 1 << bit
    res = parse(bytes(data), 8)
    assert res.commands == []
    assert res.error != 0 or where % len(data) in (2, 3)          # 2, 3: the length field
    res = parse(bytes(data) + frame(Cmd.TEXTURE, payload), 8)
    assert all(p == payload for _, p in res.commands) and len(res.commands) <= 1


def test_error_state_holds_until_clear():
    bad = bytearray(frame(Cmd.SWAP))
    bad[-1] ^= 0x40
    res = parse(bytes(bad) + frame(Cmd.SWAP), 8)
    assert (res.commands, res.replies, res.error) == ([], [0x80 | Err.CRC], Err.CRC)
    res = parse(bytes(bad) + frame(Cmd.SWAP) + CLEAR_FRAME + frame(Cmd.SWAP), 8)
    assert (res.commands, res.replies, res.error) == ([(Cmd.SWAP, b"")], [0x80 | Err.CRC, ACK, ACK], 0)


def test_lengths_are_checked_per_command():
    assert parse(frame(Cmd.TRIANGLE, bytes(7)), 8).error == Err.LENGTH
    assert parse(frame(Cmd.SWAP, b"x"), 8).error == Err.LENGTH
    assert parse(bytes([SYNC, 0x55, 0, 0]), 8).error == Err.COMMAND
    assert LENGTHS(8)[Cmd.TEXTURE] == (6, MAX_PAYLOAD)


@given(st.integers(1, 0xFFFF), st.integers(1, 0xFFFF), st.integers(1, 0xFFFF), st.integers(1, 0xFFFF))
def test_frame_start_is_refused_unless_it_names_the_tile(w, h, tw, th):
    """FRAME_START carries its frame's width and height; a board drawing a ``tw x th`` tile accepts it only when
    they are equal (else SIZE, the error state, no command), and a board without a tile accepts any."""
    data = frame_start(w, h) + frame(Cmd.SWAP)
    assert data[4:8] == w.to_bytes(2, "little") + h.to_bytes(2, "little")
    res = parse(data, 8, (tw, th))
    if (w, h) == (tw, th):
        assert (res.commands, res.replies, res.error) == ([(Cmd.FRAME_START, data[4:8]), (Cmd.SWAP, b"")],
                                                          [ACK, ACK], 0)
    else:
        assert (res.commands, res.replies, res.error) == ([], [0x80 | Err.SIZE], Err.SIZE)
    assert parse(data, 8).commands == [(Cmd.FRAME_START, data[4:8]), (Cmd.SWAP, b"")]


def test_frame_start_needs_its_size():
    assert parse(frame(Cmd.FRAME_START), 8, (4, 4)).error == Err.LENGTH            # the old, empty FRAME_START
    for w, h in ((0, 1), (1, 0x10000), (2.0, 2)):
        with pytest.raises(ValueError, match="FRAME_START"):
            frame_start(w, h)


def test_uploads_are_chunked_with_their_first_word():
    frames = upload_frames(Cmd.TEXTURE, 1, range(10), 24, chunk=12)     # 4 words of 3 bytes a frame
    cmds = parse(b"".join(frames), 8).commands
    assert [int.from_bytes(p[1:5], "little") for _, p in cmds] == [0, 4, 8]
    words = [int.from_bytes(p[5 + 3 * k:8 + 3 * k], "little") for _, p in cmds for k in range((len(p) - 5) // 3)]
    assert words == list(range(10)) and all(p[0] == 1 for _, p in cmds)
    with pytest.raises(ValueError, match="memory 2"):
        upload_frames(Cmd.CUBE, 2, [1], 8)


@given(st.integers(0, 255), st.sampled_from([None, "chip", "sdram"]), st.booleans())
def test_a_texture_frame_of_the_other_form_than_the_boards_maps_is_refused(memory, maps, cube):
    """Bit 7 of a TEXTURE frame's memory byte says its words are the maps-in-SDRAM form (``SDRAM_FORM``): a board
    whose maps are the other form refuses the frame (MAPS, after its CRC, no command, nothing after it taken) and a
    board without maps (``None``) takes either. CUBE frames are never refused so (the cubes stay on chip)."""
    from host.protocol import MAPS_FORMS
    data = frame(Cmd.CUBE if cube else Cmd.TEXTURE, bytes([memory]) + bytes(7)) + frame(Cmd.SWAP)
    res = parse(data, 8, (4, 4), maps=maps)
    refused = not cube and maps is not None and (memory >= 0x80) != (maps == "sdram")
    assert res.error == (Err.MAPS if refused else 0)
    assert len(res.commands) == (0 if refused else 2)
    assert res.replies == ([0x80 | Err.MAPS] if refused else [ACK, ACK])
    assert MAPS_FORMS == {"chip": 0, "sdram": 0x80}
    bad = bytearray(data)                                   # a corrupted frame is a CRC error first
    bad[-3 - len(frame(Cmd.SWAP))] ^= 1
    assert parse(bytes(bad), 8, (4, 4), maps=maps).error == Err.CRC


def test_upload_frames_carry_their_form():
    for maps, first in (("chip", 1), ("sdram", 0x81)):
        cmds = parse(b"".join(upload_frames(Cmd.TEXTURE, 1, range(3), 32, maps=maps)), 8, maps=maps).commands
        assert [p[0] for _, p in cmds] == [first]
    with pytest.raises(ValueError, match="cubes stay on chip"):
        upload_frames(Cmd.CUBE, 0, [1], 8, maps="sdram")
    with pytest.raises(ValueError, match="maps="):
        upload_frames(Cmd.TEXTURE, 0, [1], 8, maps="dram")
    with pytest.raises(ValueError, match="maps="):
        parse(b"", 8, maps="dram")


@given(st.integers(0, (1 << 6) - 1))
def test_status_is_answered_with_the_board_state(bits):
    """STATUS's answer is ``STATE_ANSWER | state``: never ACK nor an error byte, and its bits name the state."""
    from host.protocol import STATE_BITS, state_names
    assert len(STATE_BITS) == 6 and sorted(STATE_BITS.values()) == list(range(6))
    res = parse(frame(Cmd.STATUS) + frame(Cmd.SWAP), 8, board_state=bits)
    answer = res.replies[0]
    assert res.replies[1:] == [ACK] and answer != ACK and not answer & 0x80
    assert state_names(answer) == [n for n, b in STATE_BITS.items() if bits >> b & 1]
    with pytest.raises(ValueError, match="not an answer to STATUS"):
        state_names(answer | 0x80)
    with pytest.raises(ValueError, match="board_state"):
        parse(b"", 8, board_state=1 << 6)


@given(st.lists(st.sampled_from(["upload", "start", "swap", "clear", "status"]), max_size=12))
def test_uploads_only_outside_a_frame(ops):
    """An upload after FRAME_START, before SWAP or CLEAR ends the frame, is refused with BUSY (its words would
    change the texels of the triangles being drawn); everywhere else it is taken."""
    frames = {"upload": upload_frames(Cmd.CUBE, 0, [7], 27)[0], "start": frame_start(4, 4),
              "swap": frame(Cmd.SWAP), "clear": CLEAR_FRAME, "status": frame(Cmd.STATUS)}
    drawing, sent, refused = False, [], False
    for o in ops:                                   # the stream up to the first upload the board must refuse
        sent.append(o)
        if o == "upload" and drawing:
            refused = True
            break
        if o in ("start", "swap", "clear"):
            drawing = o == "start"
    res = parse(b"".join(frames[o] for o in sent), 8, (4, 4))
    assert res.error == (Err.BUSY if refused else 0)
    assert [c for c, _ in res.commands] == [frames[o][1] for o in sent[:len(sent) - refused]]


@given(st.integers(1, 0xFFFF), st.integers(1, 0xFFFF), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF),
       st.integers(1, 0xFFFF), st.integers(1, 0xFFFF))
def test_a_tile_is_taken_only_at_a_place_in_the_grid(w, h, col, row, cols, rows):
    """FRAME_START's place: its column and row (0, 0 in the 4-byte form) must lie in the board's grid of tiles,
    else SIZE; the place reads back from the payload."""
    from host.protocol import frame_place
    data = frame_start(w, h, col, row)
    payload = data[4:-2]
    assert len(payload) == (4 if col == row == 0 else 8) and frame_place(payload) == (w, h, col, row)
    res = parse(data, 8, (w, h), grid=(cols, rows))
    if col < cols and row < rows:
        assert (res.commands, res.replies, res.error) == ([(Cmd.FRAME_START, payload)], [ACK], 0)
    else:
        assert (res.commands, res.replies, res.error) == ([], [0x80 | Err.SIZE], Err.SIZE)
    assert parse(data, 8).error == 0                                  # a board without a frame takes any


def test_a_picture_is_sent_tile_by_tile_and_shown_once():
    """``picture_frames``: each tile's FRAME_START at its place, its triangles, COPY; the last tile ends with SWAP,
    and an upload between tiles (after a COPY) is taken."""
    from types import SimpleNamespace

    from host.protocol import frame_place, picture_frames, record_bytes
    ports = [SimpleNamespace(fmt=SimpleNamespace(width=w)) for w in (12, 9, 15)]      # a record's fields
    n = record_bytes(ports)
    rec = np.array([[5, -3, 100]], np.int64)
    tiles = [((c, r), rec if (c + r) % 2 else rec[:0]) for r in range(2) for c in range(3)]
    frames = picture_frames(ports, tiles, (16, 8))
    res = parse(b"".join(frames), n, (16, 8), grid=(3, 2))
    assert res.error == 0
    cmds = [c for c, _ in res.commands]
    assert cmds.count(Cmd.COPY) == 5 and cmds.count(Cmd.SWAP) == 1 and cmds[-1] == Cmd.SWAP
    assert cmds.count(Cmd.TRIANGLE) == 3
    assert [frame_place(p)[2:] for c, p in res.commands if c == Cmd.FRAME_START] == [t for t, _ in tiles]
    between = frames[:2] + upload_frames(Cmd.CUBE, 0, [7], 27) + frames[2:]          # after the first COPY
    assert parse(b"".join(between), n, (16, 8), grid=(3, 2)).error == 0
    assert parse(b"".join(frames), n, (16, 8), grid=(2, 2)).error == Err.SIZE          # column 2 outside
    with pytest.raises(ValueError, match="no tile"):
        picture_frames(ports, [], (16, 8))
    with pytest.raises(ValueError, match="col"):
        frame_start(4, 4, -1, 0)
