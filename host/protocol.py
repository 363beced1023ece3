"""The UART command protocol between the host tool (``bumpmap send``) and the board (``board/command.py``), and its
reference parser: the bytes both sides agree on (``docs/protocol.md`` describes them for a reader).

A frame is ``SYNC, CMD, LEN (2 bytes, little-endian), PAYLOAD (LEN bytes), CRC (2 bytes, little-endian)``; the CRC
is CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no reflection) over ``CMD, LEN, PAYLOAD``. The board
answers every good frame with :data:`ACK`; the first bad byte puts it in the error state, which it announces with one
byte ``0x80 | code`` and keeps (ignoring every byte) until it sees the :data:`CLEAR_FRAME`, answered with ``ACK``.
FRAME_START carries the tile's width and height, and a board whose tile has another size refuses it
(:data:`Err.SIZE`): the triangles the host set up for another frame would be drawn cut or misplaced, silently. A
picture larger than the board's tile is drawn a tile at a time (the host bins the triangles): FRAME_START may also
carry the tile's column and row in the picture's grid of tiles, which a board refuses outside its grid (SIZE);
COPY puts a finished tile into the back buffer at its place without showing it, and SWAP, after the picture's last
tile, copies that one and shows the whole picture.
STATUS is answered with the board's state instead of ``ACK``: ``STATE_ANSWER | bits`` (:data:`STATE_BITS`: a
frame not yet shown, and the sticky flags of what went wrong in the current frame or since the board was
configured). An upload while a frame is drawn is refused (:data:`Err.BUSY`): its words would change the texels of
the triangles being drawn. A TEXTURE frame says which form its words have (:data:`SDRAM_FORM`, bit 7 of its memory
byte: the maps in SDRAM or on chip) and a board whose maps are the other form refuses it (:data:`Err.MAPS`): its
words would be taken for the other form's and drawn as a wrong picture, silently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SYNC", "ACK", "STATE_ANSWER", "STATE_BITS", "FRAME_FLAGS", "state_names", "Cmd", "Err", "LENGTHS",
           "MAX_PAYLOAD", "crc16", "frame", "CLEAR_FRAME", "record_bytes",
           "triangle_frames", "upload_frames", "frame_start", "frame_place", "scene_frames", "picture_frames",
           "upload_frames_of", "Parsed", "parse", "MEMORIES", "ENDS_TILE", "SDRAM_FORM", "MAPS_FORMS",
           "ERROR_BITS", "check_maps"]

SYNC = 0xA5
ACK = 0x00
#: STATUS's answer: this byte or the board's state bits (``0x40`` to ``0x7F``: neither ``ACK`` nor an error).
STATE_ANSWER = 0x40
#: The board's state in STATUS's answer, bit by bit. ``busy``: a SWAP taken whose frame is not shown yet (its
#: triangles may still be drawn; the flags below are final once it clears). The flags are sticky: the frame's
#: (:data:`FRAME_FLAGS`) until the next FRAME_START, the others since the board was configured: ``overrun`` a
#: triangle record arrived while the previous one was still held (it was lost); ``upload_bad`` an upload's word
#: named no map or lay beyond its map (not written); ``outside`` the depth test dropped a fragment outside the
#: tile; ``z_saturated`` a depth saturated in its narrowing; ``store_error`` the frame store failed (in SDRAM: an
#: error response, a word lost, or the scan-out missed a word).
STATE_BITS = {"busy": 0, "overrun": 1, "upload_bad": 2, "outside": 3, "z_saturated": 4, "store_error": 5}
#: The flags of one frame: FRAME_START clears them (``overrun`` when it is taken, the depth test's two when the
#: tile is cleared, before the frame's first triangle), so STATUS after a SWAP tells of that frame alone.
FRAME_FLAGS = ("overrun", "outside", "z_saturated")
#: The largest payload of an upload frame (a 5-byte header and up to 4 KiB of words).
MAX_PAYLOAD = 5 + 4096


class Cmd:
    """Command codes."""

    TRIANGLE = 0x01      # one triangle record (the scan converter's input, RasterParams.record packed)
    TEXTURE = 0x02       # words into a texture memory: memory id (1 byte), first word (4 bytes), words
    CUBE = 0x03          # words into a reflectance cube memory: the same layout
    FRAME_START = 0x04   # the tile's width and height (2 bytes LE each), optionally its column and row in the
                         # picture's grid of tiles (2 bytes LE each, else 0, 0): clear the tile, draw into it
    SWAP = 0x05          # copy the tile into the back buffer at its place, show the back buffer from the next
                         # vertical blanking (double buffering)
    STATUS = 0x06        # ask for the board's state (answered STATE_ANSWER | STATE_BITS, not ACK)
    CLEAR = 0x07         # leave the error state
    COPY = 0x08          # copy the tile into the back buffer at its place, not shown yet (a picture's tiles but
                         # its last; SWAP copies the last and shows the picture)


class Err:
    """Error codes (the board sends ``0x80 | code`` on entering the error state)."""

    SYNC = 1             # a byte other than SYNC where a frame must start
    COMMAND = 2          # an unknown command code
    LENGTH = 3           # a length outside the command's range
    CRC = 4              # the CRC does not match
    FRAMING = 5          # the UART saw no stop bit
    SIZE = 6             # FRAME_START's width and height are not the board's tile's, or its column and row lie
                         # outside the board's grid of tiles
    BUSY = 7             # an upload (TEXTURE, CUBE) while a frame is drawn: after FRAME_START, before its picture
                         # is shown (the SWAP taken and STATUS no longer busy), unless a COPY ended the tile or a
                         # CLEAR the frame
    MAPS = 8             # a TEXTURE frame whose words are not the form of the board's maps (SDRAM_FORM in its
                         # memory byte for a board with its maps on chip, or not for one with its maps in SDRAM)


#: Bits of an error code (the RTL's ``code``).
ERROR_BITS = max(v for k, v in vars(Err).items() if k.isupper()).bit_length()


#: Memory ids of TEXTURE (0 the bump map, 1 the color texture) and CUBE (0 diffuse, 1 specular).
MEMORIES = {Cmd.TEXTURE: ("bump_map", "texture"), Cmd.CUBE: ("diffuse", "specular")}
#: Bit 7 of a TEXTURE frame's memory byte: its words are the 4-byte words of the map's span of the texture layout
#: (the board's maps in SDRAM behind the texel caches), not the texel memories' words (the maps on chip). The board
#: refuses a TEXTURE frame of the other form (:data:`Err.MAPS`): the two forms' words are not told apart otherwise.
SDRAM_FORM = 0x80
#: Where a board keeps its bump map and color texture: TEXTURE's memory byte carries :data:`SDRAM_FORM` for
#: ``sdram`` alone.
MAPS_FORMS = {"chip": 0, "sdram": SDRAM_FORM}


def check_maps(maps):
    """``maps`` if it is ``None`` (a board without maps) or a form of the board's maps (:data:`MAPS_FORMS`); else
    ``ValueError`` naming it."""
    if maps is not None and maps not in MAPS_FORMS:
        raise ValueError(f"maps={maps!r}: where the board's maps are, one of {sorted(MAPS_FORMS)}, or None")
    return maps


def LENGTHS(record_len: int) -> dict[int, tuple[int, int]]:  # noqa: N802 (a table, read like a constant)
    """``cmd -> (min, max)`` payload bytes, the triangle record ``record_len`` bytes long."""
    return {Cmd.TRIANGLE: (record_len, record_len), Cmd.TEXTURE: (6, MAX_PAYLOAD), Cmd.CUBE: (6, MAX_PAYLOAD),
            Cmd.FRAME_START: (4, 8), Cmd.SWAP: (0, 0), Cmd.STATUS: (0, 0), Cmd.CLEAR: (0, 0), Cmd.COPY: (0, 0)}

#: The commands that end a tile's drawing (an upload is taken again after them).
ENDS_TILE = (Cmd.SWAP, Cmd.COPY, Cmd.CLEAR)


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of ``b"123456789"``: 0x29B1)."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def frame(cmd: int, payload: bytes = b"") -> bytes:
    """One frame's bytes."""
    if not 0 <= len(payload) <= 0xFFFF:
        raise ValueError(f"payload of {len(payload)} bytes: a frame carries at most 65535")
    body = bytes([cmd]) + len(payload).to_bytes(2, "little") + bytes(payload)
    return bytes([SYNC]) + body + crc16(body).to_bytes(2, "little")


#: The frame that leaves the error state (the board looks for these six bytes anywhere in the stream).
CLEAR_FRAME = frame(Cmd.CLEAR)


def _size_bytes(width: int, height: int) -> bytes:
    return width.to_bytes(2, "little") + height.to_bytes(2, "little")


def frame_start(width: int, height: int, col: int = 0, row: int = 0) -> bytes:
    """The FRAME_START frame of a ``width x height`` tile (each 1..65535, two bytes little-endian) at column
    ``col`` and row ``row`` of the picture's grid of tiles (each 0..65535; the 4-byte form when both are 0)."""
    for name, v, lo in (("width", width, 1), ("height", height, 1), ("col", col, 0), ("row", row, 0)):
        if not (isinstance(v, int) and lo <= v <= 0xFFFF):
            raise ValueError(f"FRAME_START {name}={v!r}: an int in {lo}..65535")
    place = _size_bytes(col, row) if col or row else b""
    return frame(Cmd.FRAME_START, _size_bytes(width, height) + place)


def frame_place(payload: bytes) -> tuple[int, int, int, int]:
    """``(width, height, col, row)`` of a FRAME_START's payload (4 or 8 bytes)."""
    w, h, c, r = (int.from_bytes(payload[k:k + 2], "little") for k in range(0, 8, 2))
    return w, h, (c if len(payload) == 8 else 0), (r if len(payload) == 8 else 0)


def record_bytes(ports) -> int:
    """Bytes of one packed triangle record (``RasterParams.record``: the fields' bits, the first in the low bits)."""
    return (sum(p.fmt.width for p in ports) + 7) // 8


def triangle_frames(ports, rows) -> list[bytes]:
    """One TRIANGLE frame per record: codes ``(T, fields)`` in ``ports`` order, each field's two's-complement bits
    packed from the low bits (the scan converter's payload layout), little-endian."""
    n = record_bytes(ports)
    out = []
    for row in np.asarray(rows, dtype=np.int64).reshape(-1, len(ports)).tolist():
        word, shift = 0, 0
        for p, c in zip(ports, row):
            word |= (int(c) & ((1 << p.fmt.width) - 1)) << shift
            shift += p.fmt.width
        out.append(frame(Cmd.TRIANGLE, word.to_bytes(n, "little")))
    return out


def upload_frames(cmd: int, memory: int, words, word_bits: int, chunk: int = 4096, maps: str = "chip") -> list[bytes]:
    """TEXTURE or CUBE frames writing ``words`` (ints of ``word_bits``) from word 0 of memory ``memory``: each
    payload ``memory, first word (4 bytes LE), words (ceil(word_bits / 8) bytes LE each)``, at most ``chunk``
    bytes of words a frame. ``maps`` (TEXTURE alone): the form of the words (:data:`MAPS_FORMS`), whose bit the
    memory byte carries."""
    if cmd not in MEMORIES or not 0 <= memory < len(MEMORIES[cmd]):
        raise ValueError(f"upload command {cmd:#x} memory {memory}: TEXTURE or CUBE with memory 0 or 1")
    if maps not in MAPS_FORMS or (maps != "chip" and cmd != Cmd.TEXTURE):
        raise ValueError(f"upload command {cmd:#x} maps={maps!r}: one of {sorted(MAPS_FORMS)}, and 'chip' but for "
                         f"TEXTURE (the cubes stay on chip)")
    wb = (word_bits + 7) // 8
    per = max(1, min(chunk, MAX_PAYLOAD - 5) // wb)
    words = [int(w) for w in words]
    out = []
    for first in range(0, len(words), per):
        data = b"".join(w.to_bytes(wb, "little") for w in words[first:first + per])
        out.append(frame(cmd, bytes([MAPS_FORMS[maps] | memory]) + first.to_bytes(4, "little") + data))
    return out


@dataclass
class Parsed:
    """What the board does with a byte stream: the commands it accepts ``(cmd, payload)``, the bytes it answers,
    and whether it ends in the error state (its code)."""

    commands: list
    replies: list
    error: int = 0


def state_names(answer: int) -> list[str]:
    """The :data:`STATE_BITS` set in a STATUS answer, by name (``ValueError`` for a byte that is no such answer)."""
    if answer & ~((1 << len(STATE_BITS)) - 1) != STATE_ANSWER:
        raise ValueError(f"{answer:#04x} is not an answer to STATUS ({STATE_ANSWER:#04x} and state bits)")
    return [name for name, bit in STATE_BITS.items() if answer >> bit & 1]


def parse(data: bytes, record_len: int, tile: tuple[int, int] | None = None, board_state: int = 0,
          grid: tuple[int, int] = (1, 1), maps: str | None = None) -> Parsed:
    """The board's parser (``board/command.py``) in Python: the reference its RTL is checked against. ``tile``:
    the ``(width, height)`` the board draws; a FRAME_START naming another size, or a column and row outside
    ``grid`` (the board's ``(columns, rows)`` of tiles), is refused (:data:`Err.SIZE`), after its CRC matched.
    ``None`` (a board without a frame): any FRAME_START is accepted. ``board_state``: the board's
    :data:`STATE_BITS`, held for the whole stream, which a STATUS is answered with; with ``busy`` set, every upload
    is refused (:data:`Err.BUSY`), as is one after a FRAME_START not yet ended by SWAP, COPY or CLEAR. ``maps``
    (``chip`` or ``sdram``, :data:`MAPS_FORMS`): where the board keeps its bump map and texture; a TEXTURE frame
    of the other form is refused (:data:`Err.MAPS`), after its CRC matched. ``None`` (a board without them): any
    form is accepted."""
    check_maps(maps)
    if not 0 <= board_state < 1 << len(STATE_BITS):
        raise ValueError(f"board_state={board_state!r}: {len(STATE_BITS)} bits (STATE_BITS)")
    if not (len(grid) == 2 and all(isinstance(g, int) and 1 <= g <= 0xFFFF for g in grid)):
        raise ValueError(f"grid={grid!r}: (columns, rows), ints in 1..65535")
    lengths = LENGTHS(record_len)
    out = Parsed([], [])
    state, buf, need, window = "sync", bytearray(), 0, bytearray()

    def fail(code):
        nonlocal state
        out.error, state = code, "error"
        out.replies.append(0x80 | code)
        window.clear()

    drawing = False                         # after FRAME_START, until SWAP, COPY or CLEAR
    busy = bool(board_state >> STATE_BITS["busy"] & 1)
    for b in data:
        if state == "error":
            window.append(b)
            del window[:-len(CLEAR_FRAME)]
            if bytes(window) == CLEAR_FRAME:
                out.error, state, drawing = 0, "sync", False
                out.replies.append(ACK)
            continue
        if state == "sync":
            if b != SYNC:
                fail(Err.SYNC)
                continue
            state, buf = "head", bytearray()
        elif state == "head":
            buf.append(b)
            if len(buf) == 1 and b not in lengths:
                fail(Err.COMMAND)
            elif len(buf) == 1 and b in MEMORIES and (drawing or busy):
                fail(Err.BUSY)
            elif len(buf) == 3:
                need = int.from_bytes(buf[1:3], "little")
                lo, hi = lengths[buf[0]]
                if not lo <= need <= hi:
                    fail(Err.LENGTH)
                else:
                    state = "body" if need else "crc"
        elif state in ("body", "crc"):
            buf.append(b)
            if state == "body" and len(buf) == 3 + need:
                state = "crc"
            elif state == "crc" and len(buf) == 3 + need + 2:
                if crc16(bytes(buf[:3 + need])) != int.from_bytes(buf[-2:], "little"):
                    fail(Err.CRC)
                elif buf[0] == Cmd.FRAME_START and tile is not None and not _placed(buf[3:3 + need], tile, grid):
                    fail(Err.SIZE)
                elif buf[0] == Cmd.TEXTURE and maps is not None and buf[3] & SDRAM_FORM != MAPS_FORMS[maps]:
                    fail(Err.MAPS)
                else:
                    out.commands.append((buf[0], bytes(buf[3:3 + need])))
                    if buf[0] == Cmd.FRAME_START or buf[0] in ENDS_TILE:
                        drawing = buf[0] == Cmd.FRAME_START
                    out.replies.append(STATE_ANSWER | board_state if buf[0] == Cmd.STATUS else ACK)
                    state = "sync"
    return out


def _placed(payload: bytes, tile: tuple[int, int], grid: tuple[int, int]) -> bool:
    """A FRAME_START's payload names the board's ``tile`` at a place inside its ``grid``."""
    w, h, c, r = frame_place(payload)
    return (w, h) == tuple(tile) and c < grid[0] and r < grid[1]


def scene_frames(pipeline, raster_ports, records, size: tuple[int, int]) -> list[bytes]:
    """The frames that draw one prepared frame of ``size`` ``(width, height)`` on the board: the four texel
    memories of ``pipeline`` (a :class:`~fxmodel.pipeline.pixel.PipelineParams`: bump map and texture by TEXTURE,
    the diffuse and specular cubes by CUBE, each map's words in the order its memories hold them,
    ``SamplerParams.upload_words``), then the one tile: :func:`picture_frames` with ``records`` at ``(0, 0)``."""
    return upload_frames_of(pipeline) + picture_frames(raster_ports, [((0, 0), records)], size)


def upload_frames_of(pipeline, engine=None) -> list[bytes]:
    """The TEXTURE and CUBE frames of ``pipeline``'s four texel memories (:func:`scene_frames`). With ``engine``
    (an :class:`~fxmodel.pipeline.engine.EngineParams` whose ``textures`` is set: the board with its bump map and
    texture in SDRAM) each TEXTURE map is sent as the 4-byte words of its span of the engine's texture layout
    (:meth:`~fxmodel.units.texcache.Layout.span`, :meth:`~fxmodel.units.texcache.Layout.image`: its levels,
    blocked, padding included), word ``k`` for byte ``4 k`` of the span."""
    out = []
    image = layout = None
    if engine is not None and engine.textures is not None:
        layout = engine.texture_layout()
        image = layout.image(engine.texture_words())
    for cmd, names in MEMORIES.items():
        for mem, name in enumerate(names):
            if cmd == Cmd.TEXTURE and image is not None:
                start, size = layout.span(name)
                chunk = image[start - layout.base:start - layout.base + size]
                words = [int.from_bytes(chunk[k:k + 4], "little") for k in range(0, size, 4)]
                out += upload_frames(cmd, mem, words, 32, maps="sdram")
                continue
            sampler = getattr(pipeline, name)
            out += upload_frames(cmd, mem, sampler.upload_words, sampler.word_bits)
    return out


def picture_frames(raster_ports, tiles, size: tuple[int, int]) -> list[bytes]:
    """The frames that draw a picture a tile at a time: for each ``((col, row), records)`` of ``tiles`` (the
    records set up for that tile, codes ``(T, fields)`` in ``raster_ports`` order), FRAME_START of the ``size``
    ``(width, height)`` tile at ``(col, row)``, one TRIANGLE per record, and COPY, but SWAP after the last tile
    (which shows the picture)."""
    if not tiles:
        raise ValueError("picture_frames: no tile (a picture has at least one)")
    out = []
    for k, ((col, row), records) in enumerate(tiles):
        out += [frame_start(*size, col, row), *triangle_frames(raster_ports, records),
                frame(Cmd.SWAP if k == len(tiles) - 1 else Cmd.COPY)]
    return out
