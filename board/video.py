"""Golden model of the display: the video timing (line and frame layout, sync levels), the TMDS 8b/10b encoding of
DVI 1.0 section 3.2 (running disparity, control tokens) and its decoding, and the test pattern the display test
shows. Plain Python integers, no Amaranth: the RTL (``board/dvi.py``) is checked against this bit for bit, and the
testbenches decode its lanes with :func:`tmds_decode`.

The model lives in ``board/`` rather than ``fxmodel/``: it is not part of the shading pipeline, only of the board
around it.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["VideoTiming", "VGA_640x480", "SMALL", "CTRL_TOKENS", "tmds_encode", "TmdsEncoder", "tmds_decode",
           "scan", "pattern_rgb", "frame_lanes"]

#: The four control tokens (DVI 1.0 section 3.2.2), indexed by ``C1 << 1 | C0``; bit 0 is sent first.
CTRL_TOKENS = (0b1101010100, 0b0010101011, 0b0101010100, 0b1010101011)


@dataclass(frozen=True)
class VideoTiming:
    """One video mode: per line ``h_active`` pixels, then ``h_front`` (front porch), ``h_sync``, ``h_back`` (back
    porch) pixel clocks; per frame the same for lines. ``h_sync_pos``/``v_sync_pos``: the sync pulse is high while
    active (positive polarity) or low (negative: 640 x 480 at 60 Hz). ``pixel_hz`` the nominal pixel clock."""

    h_active: int
    h_front: int
    h_sync: int
    h_back: int
    v_active: int
    v_front: int
    v_sync: int
    v_back: int
    h_sync_pos: bool = False
    v_sync_pos: bool = False
    pixel_hz: int = 25_175_000

    def __post_init__(self):
        for name in ("h_active", "h_front", "h_sync", "h_back", "v_active", "v_front", "v_sync", "v_back"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise ValueError(f"VideoTiming.{name}={v!r}: must be a positive integer")

    @property
    def h_total(self) -> int:
        return self.h_active + self.h_front + self.h_sync + self.h_back

    @property
    def v_total(self) -> int:
        return self.v_active + self.v_front + self.v_sync + self.v_back

    @property
    def frame_clocks(self) -> int:
        return self.h_total * self.v_total

    @property
    def frame_hz(self) -> float:
        return self.pixel_hz / self.frame_clocks

    def at(self, h: int, v: int) -> tuple[int, int, int]:
        """``(de, hsync, vsync)`` at counter position ``h`` (pixel clock in the line) and ``v`` (line); the sync
        values are the wire levels (the polarity applied)."""
        de = int(h < self.h_active and v < self.v_active)
        hs = self.h_active + self.h_front <= h < self.h_active + self.h_front + self.h_sync
        vs = self.v_active + self.v_front <= v < self.v_active + self.v_front + self.v_sync
        return de, int(hs == self.h_sync_pos), int(vs == self.v_sync_pos)


#: 640 x 480 at 60 Hz (the VESA/CEA mode every DVI monitor takes): 800 x 525 clocks, both syncs negative.
VGA_640x480 = VideoTiming(640, 16, 96, 48, 480, 10, 2, 33)

#: A tiny mode of the same shape for simulating the serial lanes clock by clock.
SMALL = VideoTiming(16, 2, 3, 3, 6, 1, 2, 1, pixel_hz=1_000_000)


def _ones(x: int) -> int:
    return bin(x).count("1")


def tmds_encode(d: int, cnt: int) -> tuple[int, int]:
    """One data byte ``d`` with the running disparity ``cnt`` -> ``(10-bit symbol, new cnt)`` (DVI 1.0, 3.2.2)."""
    n1 = _ones(d)
    xnor = n1 > 4 or (n1 == 4 and not d & 1)
    qm = d & 1
    for i in range(1, 8):
        bit = ((qm >> (i - 1)) ^ (d >> i)) & 1
        qm |= (bit ^ xnor) << i
    q8 = 0 if xnor else 1
    n1q = _ones(qm)
    n0q = 8 - n1q
    if cnt == 0 or n1q == n0q:
        word = ((1 - q8) << 9) | (q8 << 8) | (qm if q8 else qm ^ 0xFF)
        cnt += (n1q - n0q) if q8 else (n0q - n1q)
    elif (cnt > 0 and n1q > n0q) or (cnt < 0 and n0q > n1q):
        word = (1 << 9) | (q8 << 8) | (qm ^ 0xFF)
        cnt += 2 * q8 + n0q - n1q
    else:
        word = (q8 << 8) | qm
        cnt += -2 * (1 - q8) + n1q - n0q
    return word, cnt


class TmdsEncoder:
    """One lane's encoder with its state: :meth:`step` takes ``(de, data, c1c0)`` as the hardware does each pixel
    clock (data when ``de``, else a control token; the disparity is reset during blanking)."""

    def __init__(self):
        self.cnt = 0

    def step(self, de: int, data: int, ctrl: int) -> int:
        if de:
            word, self.cnt = tmds_encode(data, self.cnt)
            return word
        self.cnt = 0
        return CTRL_TOKENS[ctrl]


def tmds_decode(word: int) -> tuple[int, int, int]:
    """A 10-bit symbol -> ``(de, data, ctrl)``: ``de=0`` for a control token (``ctrl`` its ``C1 C0``), else the
    data byte. Raises ``ValueError`` for a symbol no encoder state produces."""
    if word in CTRL_TOKENS:
        return 0, 0, CTRL_TOKENS.index(word)
    q = word & 0xFF
    if word >> 9 & 1:
        q ^= 0xFF
    d = q & 1
    for i in range(1, 8):
        bit = ((q >> i) ^ (q >> (i - 1))) & 1
        d |= (bit if word >> 8 & 1 else bit ^ 1) << i
    if tmds_encode(d, 0)[0] != word and tmds_encode(d, 1)[0] != word and tmds_encode(d, -1)[0] != word:
        raise ValueError(f"TMDS symbol {word:#012b} is neither a control token nor a data symbol")
    return 1, d, 0


def pattern_rgb(x: int, y: int) -> tuple[int, int, int]:
    """The display test's picture: ``(r, g, b)`` bytes of pixel ``(x, y)`` (every bit of both counters shows)."""
    return x & 0xFF, (y + (x >> 8)) & 0xFF, ((x >> 1) ^ (y << 1)) & 0xFF


def scan(t: VideoTiming):
    """One frame in pixel clocks from the first active pixel: ``(x, y, de, hsync, vsync)`` each clock."""
    for v in range(t.v_total):
        for h in range(t.h_total):
            de, hs, vs = t.at(h, v)
            yield h, v, de, hs, vs


def frame_lanes(t: VideoTiming, pattern=pattern_rgb) -> list[tuple[int, int, int]]:
    """The three lanes' symbols ``(lane 0 blue + syncs, lane 1 green, lane 2 red)`` of one frame of ``pattern``,
    the encoders starting from their blanking state (disparity 0)."""
    enc = [TmdsEncoder() for _ in range(3)]
    out = []
    for x, y, de, hs, vs in scan(t):
        r, g, b = pattern(x, y) if de else (0, 0, 0)
        out.append((enc[0].step(de, b, vs << 1 | hs), enc[1].step(de, g, 0), enc[2].step(de, r, 0)))
    return out
