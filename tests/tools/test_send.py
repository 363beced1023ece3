"""``bumpmap send --dry-run``: the bytes it writes parse (:func:`host.protocol.parse`, the board's reference parser)
into the tin plane's set-up: every texel memory's words in order, FRAME_START, each triangle record with its
fields' bits, SWAP; bad arguments exit 2 with one line."""

from __future__ import annotations

import numpy as np

from host.protocol import MEMORIES, Cmd, parse, record_bytes
from host.render import from_triangles, prepare
from host.scene import scene_path
from tools.main import main


def _unpack(ports, payload: bytes) -> list[int]:
    word, row, shift = int.from_bytes(payload, "little"), [], 0
    for p in ports:
        bits = (word >> shift) & ((1 << p.fmt.width) - 1)
        row.append(bits - (1 << p.fmt.width) if p.fmt.signed and bits >> (p.fmt.width - 1) else bits)
        shift += p.fmt.width
    return row


def test_dry_run_bytes_are_the_scene_setup(tmp_path, capsys):
    out = tmp_path / "tin.bin"
    assert main(["send", "--frame", "chip", "--dry-run", str(out)]) == 0
    from board.frame import BOARD_PRESET, BOARD_SIZE
    frame = prepare(scene_path("tin-plane"), size=BOARD_SIZE, preset=BOARD_PRESET)   # the board's tile, on chip
    tframe = from_triangles(frame)
    ports = tframe.params.raster.record
    parsed = parse(out.read_bytes(), record_bytes(ports), (BOARD_SIZE, BOARD_SIZE))     # a board of BOARD_SIZE
    assert parsed.error == 0 and "tin-plane" in capsys.readouterr().out
    cmds = [c for c, _ in parsed.commands]
    n = len(tframe.records)
    assert cmds[-n - 2:] == [Cmd.FRAME_START] + [Cmd.TRIANGLE] * n + [Cmd.SWAP]
    rows = [_unpack(ports, p) for c, p in parsed.commands if c == Cmd.TRIANGLE]
    assert np.array_equal(np.array(rows), tframe.records.matrix())
    for cmd, names in MEMORIES.items():
        for mem, name in enumerate(names):
            s = getattr(frame.params, name)
            wb = (s.word_bits + 7) // 8
            chunks = [p for c, p in parsed.commands if c == cmd and p[0] == mem]
            words = [int.from_bytes(p[5 + k:5 + k + wb], "little") for p in chunks for k in range(0, len(p) - 5, wb)]
            assert words == s.upload_words, name


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert main(["send"]) == 2
    assert "--port" in capsys.readouterr().err
    assert main(["send", "--scene", "no-such-scene", "--dry-run", str(tmp_path / "x")]) == 2
    assert "no-such-scene" in capsys.readouterr().err


def test_another_size_is_refused_by_a_board_of_the_default_tile(tmp_path):
    """``--size`` other than the bitstream's: the board (its reference parser, a BOARD_SIZE tile) refuses the
    FRAME_START with SIZE instead of drawing the triangles set up for another frame cut off at its tile's edge."""
    from board.frame import BOARD_PRESET, BOARD_SIZE
    out = tmp_path / "big.bin"
    assert main(["send", "--frame", "chip", "--size", str(2 * BOARD_SIZE), "--dry-run", str(out)]) == 0
    tframe = from_triangles(prepare(scene_path("tin-plane"), size=2 * BOARD_SIZE, preset=BOARD_PRESET))
    parsed = parse(out.read_bytes(), record_bytes(tframe.params.raster.record), (BOARD_SIZE, BOARD_SIZE))
    from host.protocol import Err
    assert parsed.error == Err.SIZE and Cmd.FRAME_START not in [c for c, _ in parsed.commands]
    assert Cmd.TRIANGLE not in [c for c, _ in parsed.commands]      # every frame after it ignored, no CLEAR sent


def test_the_picture_a_tile_at_a_time_for_the_board_with_its_frame_in_sdram(tmp_path):
    """By default (``--frame sdram``, ``board.frame.BOARD_FRAME``): every tile of the 640 x 480 picture's grid in
    raster order, each FRAME_START at its place with the records set up for that tile
    (``fxmodel.units.raster.setup`` with its origin) and COPY, SWAP after the last; a board of that grid takes it
    all, a board with its frame on chip (a grid of one tile) refuses the second tile's place."""
    from board.frame import BOARD_PRESET, BOARD_SIZE
    from board.video import VGA_640x480
    from host.engine_setup import frame_raster, frame_records
    from host.protocol import Err, frame_place
    out = tmp_path / "tiles.bin"
    assert main(["send", "--dry-run", str(out)]) == 0
    t = VGA_640x480
    frame = prepare(scene_path("tin-plane"), size=(t.h_active, t.v_active), preset=BOARD_PRESET)
    raster = frame_raster(frame)
    cols, rows = -(-t.h_active // BOARD_SIZE), -(-t.v_active // BOARD_SIZE)
    n = record_bytes(raster.record)
    parsed = parse(out.read_bytes(), n, (BOARD_SIZE, BOARD_SIZE), grid=(cols, rows))
    assert parsed.error == 0
    drawn = [c for c, _ in parsed.commands if c not in MEMORIES]
    assert drawn.count(Cmd.COPY) == cols * rows - 1 and drawn[-1] == Cmd.SWAP and drawn.count(Cmd.SWAP) == 1
    starts = [k for k, (c, _) in enumerate(parsed.commands) if c == Cmd.FRAME_START]
    assert [frame_place(parsed.commands[k][1])[2:] for k in starts] == [(c, r) for r in range(rows)
                                                                        for c in range(cols)]
    for k, s in enumerate(starts):                  # each tile's records: those of its place
        c, r = frame_place(parsed.commands[s][1])[2:]
        end = starts[k + 1] if k + 1 < len(starts) else len(parsed.commands)
        tile = [_unpack(raster.record, p) for c2, p in parsed.commands[s + 1:end] if c2 == Cmd.TRIANGLE]
        want = frame_records(frame, raster, (c * BOARD_SIZE, r * BOARD_SIZE, BOARD_SIZE, BOARD_SIZE))[0]
        assert np.array_equal(np.array(tile).reshape(-1, len(raster.record)), want.matrix())
    assert parse(out.read_bytes(), n, (BOARD_SIZE, BOARD_SIZE)).error == Err.SIZE


def test_the_maps_in_sdram_are_sent_as_their_spans_of_the_texture_layout(tmp_path, capsys):
    """``--textures``: each TEXTURE map's words are the 4-byte words of its span of the engine's texture layout,
    which hold every texel of the map at its blocked address (read back through the layout, independently of
    how the host cut them), from word 0 on; the cubes are sent as without it; with ``--frame chip`` it is
    refused."""
    import dataclasses

    from board.frame import BOARD_PRESET, BOARD_SIZE, board_picture
    from board.video import VGA_640x480
    from fxmodel.units.texcache import CHOSEN_CACHE
    from host.protocol import SDRAM_FORM, Err
    out = tmp_path / "tex.bin"
    assert main(["send", "--textures", "--dry-run", str(out)]) == 0
    params, frame, _ = board_picture("tin-plane", BOARD_PRESET, BOARD_SIZE)
    eng = dataclasses.replace(params, textures=CHOSEN_CACHE)
    layout = eng.texture_layout()
    t = VGA_640x480
    board = record_bytes(params.raster.record), (BOARD_SIZE, BOARD_SIZE)
    grid = (-(-t.h_active // BOARD_SIZE), -(-t.v_active // BOARD_SIZE))
    parsed = parse(out.read_bytes(), *board, grid=grid, maps="sdram")
    assert parsed.error == 0
    assert parse(out.read_bytes(), *board, grid=grid, maps="chip").error == Err.MAPS   # a board with them on chip
    for mem, name in enumerate(MEMORIES[Cmd.TEXTURE]):
        chunks = [p for c, p in parsed.commands if c == Cmd.TEXTURE and p[0] == SDRAM_FORM | mem]
        assert [int.from_bytes(p[1:5], "little") for p in chunks] == \
            [sum(len(q) - 5 for q in chunks[:k]) // 4 for k in range(len(chunks))]
        data = b"".join(p[5:] for p in chunks)
        start, size = layout.span(name)
        assert len(data) == size
        for k, (key, h, w) in enumerate(layout.surfaces):
            if key[0] != name:
                continue
            smp = getattr(frame.params, name)
            words = np.array(smp.level_words(key[1])).reshape(h, w)
            for y in range(h):
                for x in range(w):
                    a = int(layout.address(k, x, y)) - start
                    assert int.from_bytes(data[a:a + 4], "little") == words[y, x]
    for mem, name in enumerate(MEMORIES[Cmd.CUBE]):
        chunks = [p for c, p in parsed.commands if c == Cmd.CUBE and p[0] == mem]
        wb = (getattr(frame.params, name).word_bits + 7) // 8
        got = [int.from_bytes(p[5 + k:5 + k + wb], "little") for p in chunks for k in range(0, len(p) - 5, wb)]
        assert got == getattr(frame.params, name).upload_words
    capsys.readouterr()
    assert main(["send", "--textures", "--frame", "chip", "--dry-run", str(tmp_path / "x.bin")]) == 2
    assert "--textures" in capsys.readouterr().err


class _Board:
    """A board behind a serial port: every byte written so far goes through :func:`host.protocol.parse` (the
    reference the board's RTL is checked against), whose answers are read one by one; each STATUS answer carries
    the next of ``states`` (the last one repeated)."""

    def __init__(self, record_len: int, tile: tuple[int, int], states: list[int], maps: str = "chip"):
        self.record_len, self.tile, self.states, self.maps = record_len, tile, list(states), maps
        self.written, self.answered, self.timeout, self.asked = bytearray(), 0, 0.01, 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def write(self, data: bytes) -> None:
        self.written += data

    def read(self, n: int) -> bytes:
        from host.protocol import STATE_ANSWER
        replies = parse(bytes(self.written), self.record_len, self.tile, maps=self.maps).replies
        if self.answered >= len(replies):
            return b""
        r = replies[self.answered]
        self.answered += 1
        if r == STATE_ANSWER:
            self.asked += 1
            r |= self.states.pop(0) if len(self.states) > 1 else self.states[0]
        return bytes([r])


def _send_to(monkeypatch, capsys, states: list[int], *extra: str, maps: str = "chip"):
    import serial

    from board.frame import BOARD_PRESET
    from host.protocol import STATE_BITS
    size = 16
    ports = from_triangles(prepare(scene_path("tin-plane"), size=size, preset=BOARD_PRESET)).params.raster.record
    board = _Board(record_bytes(ports), (size, size), [sum(1 << STATE_BITS[n] for n in s) for s in states], maps)
    monkeypatch.setattr(serial, "Serial", lambda *a, **k: board)
    rc = main(["send", "--port", "fake", "--frame", "chip", "--size", str(size), *extra])
    return rc, board, capsys.readouterr().err


def test_send_waits_for_the_picture_and_checks_the_board_flags(monkeypatch, capsys):
    """After SWAP, ``send`` asks STATUS until the board is no longer busy and fails when a flag rose during the
    picture (a fake board: the reference parser's answers); sticky flags set before the run are a warning, the
    frame's flags (``FRAME_FLAGS``) an error whenever a picture is drawn with them."""
    rc, board, err = _send_to(monkeypatch, capsys, [[], ["busy"], ["busy"], []])
    assert (rc, board.asked, err) == (0, 4, "")                     # before the run, then three polls
    rc, board, err = _send_to(monkeypatch, capsys, [[], ["busy"], ["outside", "overrun"]])
    assert rc == 1 and "with overrun, outside" in err
    rc, board, err = _send_to(monkeypatch, capsys, [["upload_bad"]])
    assert rc == 0 and "warning" in err and "upload_bad" in err     # set before: cannot be seen rising again
    # the frame's flags: set before the run they are the last frame's (FRAME_START clears them), no warning;
    # set after this run's SWAP they are this frame's, an error even if they were set before
    rc, board, err = _send_to(monkeypatch, capsys, [["outside"], []])
    assert (rc, err) == (0, "")
    rc, board, err = _send_to(monkeypatch, capsys, [["z_saturated"], ["z_saturated"]])
    assert rc == 1 and "with z_saturated" in err
    rc, board, err = _send_to(monkeypatch, capsys, [[], ["busy"]], "--shown-wait", "0.05")
    assert rc == 1 and "not shown" in err


def test_send_stops_when_the_board_does_not_answer_status(monkeypatch, capsys):
    """A board configured with an older bitstream answers STATUS with ACK, not its state: send stops before
    sending anything, naming what it got."""
    rc, board, err = _send_to(monkeypatch, capsys, [[]])
    assert rc == 0
    monkeypatch.setattr(_Board, "read", lambda self, n: b"\x00")
    rc, board, err = _send_to(monkeypatch, capsys, [[]])
    assert rc == 1 and "got 0x00" in err and b"\xa5\x02" not in board.written    # no upload sent


def test_send_stops_at_a_board_whose_maps_are_elsewhere(monkeypatch, capsys):
    """A board built with its maps in SDRAM (``bumpmap bitstream --textures``) refuses the on-chip form's TEXTURE
    words (MAPS) instead of taking them as its 4-byte words: send names the error and the option, sends CLEAR and
    stops before the frame's triangles."""
    from host.protocol import CLEAR_FRAME
    rc, board, err = _send_to(monkeypatch, capsys, [[]], maps="sdram")
    assert rc == 1 and "MAPS" in err and "--textures" in err
    assert bytes(board.written).endswith(CLEAR_FRAME) and b"\xa5\x04" not in board.written    # no FRAME_START
