r"""Raster operations: the depth test and the frame buffer behind the engine (paper, section 4 and Fig. 5).

"To visit the pixels of adjacent triangles only once, the edge traverser was slightly modified. This is essential
for color blending" (section 4): the engine's colors go into a frame buffer. With overlapping geometry the
hardware must also decide which fragment is visible; this block does it with a depth buffer beside the colors.
This module is the bit-exact model of ``rtl/rop.py``; :class:`RopParams` drives model, RTL, tests and cost.

The rule (one fragment after another, in the order the engine emits them)
--------------------------------------------------------------------------
A fragment ``(x, y, z, r, g, b, flags)`` *passes* iff its depth code is **strictly greater** than the depth
stored at ``(x, y)``: larger ``Z = near / w_c`` is nearer (``fxmodel/units/raster.py`` interpolates it). On a tie the
fragment drawn **first** wins, the rule of the float front end's z-buffer (``host/frontend.py``: nearest
``1/w_c`` wins, ties keep the first triangle). A passing fragment writes its depth and its color; a failing one
writes nothing. Before the first fragment every pixel holds ``clear_depth`` and ``clear_color``; the default
``clear_depth = 0`` is "infinitely far" (only a fragment whose depth code is 0 can fail against it).

Depth word
----------
The scan converter's ``Z`` (``z_in``, a signed format: the raster's ``out_fmt("Z")``) is in ``[0, 1]`` at every
covered pixel (a convex combination of vertex values in ``(0, 1]``, within the interpolators' proven 3/4 ulp, and
rounded half-up, so never below 0). The stored word ``z_fmt`` is unsigned; by default ``z_in`` without its sign bit
(exact: every code of ``[0, 2)``). The narrowing from ``z_in`` to ``z_fmt`` is named: **rounding TRUNC**
(floor, monotone, so the order of two depths is kept or becomes a tie, never reversed) and **overflow
SATURATE**: a negative ``Z`` becomes 0 (infinitely far) and one above the format's top its largest code, each
counted (``stats["z_saturated"]``) and raised on the RTL's sticky ``status`` bit. A narrower ``z_fmt`` (fewer
fraction bits) trades depth precision for memory; the precision it resolves is ``z_fmt.ulp`` in ``Z``.

Frame buffer layout (memory port)
---------------------------------
One 8-byte little-endian word per pixel, row-major, at ``base + 8 (y width + x)``: bytes 0..3 the depth code
(zero-extended, ``z_fmt`` at most 32 bits), bytes 4, 5, 6 ``r, g, b``, byte 7 the fragment's ``flags``. Per
fragment the ROP **reads the 4 depth bytes** (one narrow AXI read, ``ARSIZE = 2``) and, if it passes, **writes
all 8 bytes** (one beat, ``AWSIZE = 3``). So the traffic per fragment is 4 bytes read, plus 8 bytes written per
passing fragment (:func:`draw`'s stats). Interleaving depth and color in one word makes every write a single
beat (one fragment per clock on one port); separate depth and color planes would need two write bursts per
fragment. A fragment outside the ``width x height`` frame (possible only if the ROP is fed by something other
than a scan converter set up for this frame) is dropped, counted (``stats["outside"]``) and flagged: no address
outside the frame is ever formed.

On chip (``on_chip=True``): the same words, ``z_fmt.width + 24 + flag_bits`` bits each, in one block-RAM
memory of ``width * height`` words instead of behind the port; the traffic figures count the same bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fxmodel.core.cost import DP16KD_SHAPES, Memory
from fxmodel.core.cost import estimate as _estimate
from fxmodel.core.fixed import Fmt
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import Port, require

__all__ = ["RopParams", "draw", "clear_frame", "clear_word", "write_frame", "read_frame", "Z_ROUNDING", "Z_OVERFLOW",
           "PIXEL_BYTES", "DEPTH_BYTES", "STATUS_BITS"]

#: The named narrowing of the scan converter's ``Z`` to the stored depth word.
Z_ROUNDING, Z_OVERFLOW = Rounding.TRUNC, Overflow.SATURATE
#: Bytes per pixel in memory (depth word, r, g, b, flags) and bytes of the depth read.
PIXEL_BYTES, DEPTH_BYTES = 8, 4
#: Bits of the RTL's sticky ``status`` output.
STATUS_BITS = {"outside": 0, "z_saturated": 1, "bus_error": 2}


@dataclass(frozen=True)
class RopParams:
    """Parameters of the raster-operations unit (depth test and frame buffer).

    Parameters
    ----------
    width, height : int
        The frame, at most ``max_size`` each (the scan converter's viewport).
    max_size : int
        The scan converter's ``RasterParams.max_size``: ``x`` and ``y`` arrive in its ``pixel_fmt``.
    z_in : Fmt
        The scan converter's ``Z`` output format (``RasterParams.out_fmt("Z")``), signed.
    z_fmt : Fmt or None
        The stored depth word, unsigned, at most 32 bits, with at most ``z_in``'s fraction bits; ``None``: ``z_in``
        without its sign bit (exact). Narrowing: :data:`Z_ROUNDING`, :data:`Z_OVERFLOW` (module docstring).
    flag_bits : int
        Bits of the fragment's ``flags`` stored in byte 7 (at most 8): the engine's 5.
    on_chip : bool
        Frame buffer in block RAM (small frames) instead of behind the AXI4 port.
    data_bits, addr_bits : int
        AXI4 data bus width (a power of two, 64..1024) and address width.
    base : int
        Byte address of pixel (0, 0), a multiple of 8; the frame must end within ``2**addr_bits``.
    outstanding : int
        Fragments in flight at once (read issued, write not yet acknowledged): the scoreboard's slots.
    clear_depth : int
        Depth code of an empty pixel (0: infinitely far).
    clear_color : tuple of 3 int
        ``r, g, b`` of an empty pixel (its flags are 0).
    hazard : bool
        ``True`` (always, in use): the same-pixel hazard is handled (scoreboard stall on the port, forwarding on
        chip). ``False`` exists only to show that the hazard test can fail.
    """

    NAME: ClassVar[str] = "rop"
    PRESETS: ClassVar[dict]

    width: int = 256
    height: int = 256
    max_size: int = 2048
    z_in: Fmt = Fmt(True, 2, 22)
    z_fmt: Fmt | None = None
    flag_bits: int = 5
    on_chip: bool = False
    data_bits: int = 64
    addr_bits: int = 32
    base: int = 0
    outstanding: int = 16
    clear_depth: int = 0
    clear_color: tuple = (0, 0, 0)
    hazard: bool = True

    def __post_init__(self):
        ints = ("width", "height", "max_size", "flag_bits", "data_bits", "addr_bits", "base", "outstanding",
                "clear_depth")
        for name in ints:
            value = getattr(self, name)
            require(isinstance(value, int) and not isinstance(value, bool), name, value, "must be an int")
        require(2 <= self.max_size <= 1 << 14, "max_size", self.max_size, "must be in 2..16384")
        require(1 <= self.width <= self.max_size, "width", self.width, f"must be in 1..max_size={self.max_size}")
        require(1 <= self.height <= self.max_size, "height", self.height, f"must be in 1..max_size={self.max_size}")
        require(isinstance(self.z_in, Fmt) and self.z_in.signed and self.z_in.int_bits >= 2, "z_in", self.z_in,
                "must be a signed Fmt with at least one integer bit besides the sign (the raster's Z format)")
        if self.z_fmt is None:
            object.__setattr__(self, "z_fmt", Fmt(False, self.z_in.int_bits - 1, self.z_in.frac_bits))
        require(isinstance(self.z_fmt, Fmt) and not self.z_fmt.signed, "z_fmt", self.z_fmt, "must be an unsigned Fmt")
        require(self.z_fmt.width <= 8 * DEPTH_BYTES, "z_fmt", self.z_fmt,
                f"at most {8 * DEPTH_BYTES} bits (the depth bytes of a pixel word)")
        require(self.z_fmt.frac_bits <= self.z_in.frac_bits, "z_fmt", self.z_fmt,
                f"at most z_in's {self.z_in.frac_bits} fraction bits (narrowing only)")
        require(1 <= self.flag_bits <= 8, "flag_bits", self.flag_bits, "must be in 1..8 (byte 7 of the word)")
        require(isinstance(self.on_chip, bool), "on_chip", self.on_chip, "must be a bool")
        require(isinstance(self.hazard, bool), "hazard", self.hazard, "must be a bool")
        require(self.data_bits in (64, 128, 256, 512, 1024), "data_bits", self.data_bits,
                "must be a power of two in 64..1024 (a pixel word is one 64-bit lane)")
        require(12 <= self.addr_bits <= 64, "addr_bits", self.addr_bits, "must be in 12..64")
        require(self.base >= 0 and self.base % PIXEL_BYTES == 0, "base", self.base,
                f"must be a non-negative multiple of {PIXEL_BYTES}")
        require(self.base + self.frame_bytes <= 1 << self.addr_bits, "base", self.base,
                f"the frame ({self.frame_bytes} bytes) must end within 2**addr_bits = {1 << self.addr_bits}")
        require(2 <= self.outstanding <= 256, "outstanding", self.outstanding, "must be in 2..256")
        require(0 <= self.clear_depth <= self.z_fmt.max_code, "clear_depth", self.clear_depth,
                f"must be a code of z_fmt {self.z_fmt}")
        require(isinstance(self.clear_color, tuple) and len(self.clear_color) == 3
                and all(isinstance(c, int) and 0 <= c <= 255 for c in self.clear_color), "clear_color",
                self.clear_color, "must be a tuple of three ints in 0..255")

    # -- derived ------------------------------------------------------------------------------------------
    @property
    def pixel_fmt(self) -> Fmt:
        """``x`` and ``y``: the scan converter's ``pixel_fmt`` for ``max_size``."""
        return Fmt.integer(0, self.max_size - 1)

    @property
    def flags_fmt(self) -> Fmt:
        return Fmt(False, self.flag_bits, 0)

    @property
    def inputs(self) -> tuple:
        """The fragment: ``x, y`` (``pixel_fmt``), ``z`` (``z_in``), ``r, g, b`` bytes, ``flags``."""
        pf, u8 = self.pixel_fmt, Fmt(False, 8, 0)
        return (Port("x", pf, "column"), Port("y", pf, "row"), Port("z", self.z_in, "depth Z = near / w_c"),
                Port("r", u8), Port("g", u8), Port("b", u8), Port("flags", self.flags_fmt, "stored in byte 7"))

    @property
    def word_bits(self) -> int:
        """Bits of one on-chip frame-buffer word: depth, r, g, b, flags."""
        return self.z_fmt.width + 24 + self.flag_bits

    @property
    def slice_bits(self) -> int:
        """Bits of each slice of the on-chip frame (the last may be narrower): the widest ECP5 block-RAM port
        (``DP16KD_SHAPES``) whose depth holds the whole frame, so that no block's output is multiplexed with
        another's (a read multiplexer across the device's block-RAM rows was the board's critical path); the
        whole word when no port is that deep."""
        fits = [w for d, w in DP16KD_SHAPES if d >= self.pixels]
        return min(max(fits), self.word_bits) if fits else self.word_bits

    @property
    def pixels(self) -> int:
        return self.width * self.height

    @property
    def frame_bytes(self) -> int:
        """Bytes of the frame in memory (:data:`PIXEL_BYTES` per pixel)."""
        return PIXEL_BYTES * self.width * self.height

    @property
    def latency(self) -> int | None:
        """On chip: cycles from a fragment accepted to its write in the memory (fragment registered as delivered,
        its index and depth registered, its address registered beside each block RAM, the read, the word registered
        beside each block RAM, stored depth registered, compare, write port's registers beside each block RAM:
        ``rtl/rop.py``); behind the port it depends on the memory (``None``)."""
        return 8 if self.on_chip else None

    @property
    def readout_latency(self) -> int | None:
        """On chip: cycles from an address on the read-out's ``fb.addr`` to its word on ``fb.data`` (the address
        registered beside each block RAM, the read, the word registered beside each block RAM); ``None`` behind
        the port."""
        return 3 if self.on_chip else None

    def products(self) -> tuple:
        """None: the pixel address ``y width + x`` is shifted copies of ``y`` (``rtl.fixed.const_mul``)."""
        return ()

    def memories(self) -> tuple:
        """On chip: the frame buffer (``width * height`` words of :attr:`word_bits`, one read port, written), in
        slices of :attr:`slice_bits`."""
        if not self.on_chip:
            return ()
        n, rest = divmod(self.word_bits, self.slice_bits)
        return tuple(Memory(self.pixels, bits, read_ports=1, rom=False, count=count, kind="frame",
                            name="frame buffer") for bits, count in ((self.slice_bits, n), (rest, 1)) if bits)

    def cost(self) -> dict:
        return _estimate(self)

    def info(self) -> dict:
        return {"unit": self.NAME,
                "params": {"width": self.width, "height": self.height, "max_size": self.max_size,
                           "on_chip": self.on_chip, "data_bits": self.data_bits, "addr_bits": self.addr_bits,
                           "base": self.base, "outstanding": self.outstanding, "clear_depth": self.clear_depth,
                           "clear_color": list(self.clear_color)},
                "inputs": [p.fmt.describe(p.name) for p in self.inputs],
                "depth": {"in": str(self.z_in), "stored": str(self.z_fmt), "rounding": Z_ROUNDING.name,
                          "overflow": Z_OVERFLOW.name, "resolution": float(self.z_fmt.ulp),
                          "rule": "pass iff z > stored (larger Z = near/w_c is nearer); ties: first drawn wins"},
                "memory": {"pixel_bytes": PIXEL_BYTES, "layout": "bytes 0-3 depth, 4 r, 5 g, 6 b, 7 flags",
                           "read_bytes_per_fragment": DEPTH_BYTES, "write_bytes_per_passed_fragment": PIXEL_BYTES,
                           "frame_bytes": self.frame_bytes},
                "status_bits": STATUS_BITS, "latency": self.latency, "cost": self.cost()}

    # -- model helpers ------------------------------------------------------------------------------------
    def depth_codes(self, z):
        """``z`` codes (``z_in``) -> stored depth codes and the saturation flags (the named narrowing)."""
        return narrow(np.asarray(z, dtype=np.int64), self.z_in.frac_bits, self.z_fmt, Z_ROUNDING, Z_OVERFLOW,
                      "rop depth")


def clear_frame(params: RopParams):
    """``(depth (H, W), color (H, W, 4))`` of an empty frame: ``clear_depth``, ``clear_color`` and flags 0."""
    P = params
    depth = np.full((P.height, P.width), P.clear_depth, dtype=np.int64)
    color = np.zeros((P.height, P.width, 4), dtype=np.int64)
    color[..., :3] = P.clear_color
    return depth, color


def clear_word(params: RopParams) -> int:
    """The on-chip frame's word of an empty pixel (:func:`clear_frame`): the depth in the low ``z_fmt.width`` bits,
    then ``r, g, b`` and ``flags`` a byte each (:attr:`RopParams.word_bits`)."""
    depth, color = clear_frame(params)
    return int(depth[0, 0]) | sum(int(c) << (params.z_fmt.width + 8 * k) for k, c in enumerate(color[0, 0]))


def _columns(params: RopParams, frags) -> list:
    if isinstance(frags, dict):
        cols = [np.asarray(frags[p.name], dtype=np.int64) for p in params.inputs]
    else:
        mat = np.asarray(frags, dtype=np.int64).reshape(-1, len(params.inputs))
        cols = [mat[:, i] for i in range(len(params.inputs))]
    return [p.fmt.check(c, what=f"rop input {p.name}") for p, c in zip(params.inputs, cols)]


def draw(params: RopParams, frags, fb=None):
    """Draw fragments into a frame, one after another: the model of ``rtl/rop.py``.

    A fragment passes iff its depth code (``z`` narrowed to ``z_fmt``: TRUNC, SATURATE) is strictly greater than
    the stored one (larger ``Z`` is nearer); on a tie the fragment drawn first wins, like the float front end's
    z-buffer. A passing fragment writes its depth, ``r, g, b`` and ``flags``; fragments outside the frame are
    dropped and counted.

    Parameters
    ----------
    params : RopParams
    frags : array_like (K, 7) or dict
        Fragments in drawing order, columns (or keys) ``x, y, z, r, g, b, flags`` as codes of ``params.inputs``.
    fb : tuple (depth, color), optional
        The frame before drawing (:func:`clear_frame` by default); not modified.

    Returns
    -------
    depth : ndarray (H, W) int64
    color : ndarray (H, W, 4) int64 -- r, g, b, flags
    stats : dict
        ``fragments``, ``passed``, ``failed``, ``outside``, ``z_saturated``, ``bytes_read`` (4 per fragment in
        the frame), ``bytes_written`` (8 per passing fragment).
    """
    P = params
    x, y, z, r, g, b, fl = _columns(P, frags)
    depth, color = clear_frame(P) if fb is None else (np.array(fb[0], dtype=np.int64), np.array(fb[1], dtype=np.int64))
    zc, zsat = P.depth_codes(z)
    inside = (x < P.width) & (y < P.height)
    flat_d = depth.reshape(-1)
    flat_c = color.reshape(-1, 4)
    idx = np.where(inside, y * P.width + x, -1)
    rgbf = np.stack([r, g, b, fl], axis=1)
    passed = 0
    # sequential by definition (a later fragment sees an earlier one's write); a plain loop over Python ints
    for k, (i, d) in enumerate(zip(idx.tolist(), zc.tolist())):
        if i >= 0 and d > flat_d[i]:
            flat_d[i] = d
            flat_c[i] = rgbf[k]
            passed += 1
    n_in = int(inside.sum())
    stats = {"fragments": int(len(x)), "passed": passed, "failed": n_in - passed, "outside": int(len(x) - n_in),
             "z_saturated": int(np.count_nonzero(zsat & inside)),
             "bytes_read": DEPTH_BYTES * n_in, "bytes_written": PIXEL_BYTES * passed}
    return depth, color, stats


def write_frame(params: RopParams, depth, color) -> bytes:
    """The memory image (``frame_bytes`` from ``base``) of a frame, in the layout of the module docstring."""
    P = params
    words = np.zeros((P.height, P.width, PIXEL_BYTES), dtype=np.uint8)
    words[..., :DEPTH_BYTES] = np.asarray(depth, dtype="<u4").reshape(P.height, P.width, 1).view(np.uint8)
    words[..., DEPTH_BYTES:] = np.asarray(color, dtype=np.int64)
    return words.tobytes()


def read_frame(params: RopParams, image) -> tuple:
    """Decode a frame from a memory image (bytes from ``base``, at least ``frame_bytes``): ``(depth (H, W),
    color (H, W, 4))`` as int64 codes. Raises ``ValueError`` if the image is short or a depth word is not a code
    of ``z_fmt`` (a corrupt image)."""
    P = params
    buf = np.frombuffer(bytes(image), dtype=np.uint8)
    require(buf.size >= P.frame_bytes, "image", f"{buf.size} bytes", f"needs {P.frame_bytes} bytes "
            f"({P.width} x {P.height} pixels of {PIXEL_BYTES})")
    words = buf[:P.frame_bytes].reshape(P.height, P.width, PIXEL_BYTES)
    depth = words[..., :DEPTH_BYTES].copy().view("<u4")[..., 0].astype(np.int64)
    bad = np.flatnonzero(depth.ravel() > P.z_fmt.max_code)
    require(bad.size == 0, "image", f"pixel {bad[:1].tolist()}", f"depth word exceeds z_fmt {P.z_fmt}")
    color = words[..., DEPTH_BYTES:].astype(np.int64)
    return depth, color


#: ``default``: a 256 x 256 frame behind the AXI4 port (the raster's default ``Z``, stored without its sign bit);
#: ``on_chip``: a 64 x 64 frame in block RAM; ``small``: 16 x 12 behind the port with a 16-bit depth word (7
#: fraction bits dropped) and 4 slots, for quick RTL tests.
RopParams.PRESETS = {
    "default": RopParams(),
    "on_chip": RopParams(width=64, height=64, on_chip=True),
    "small": RopParams(width=16, height=12, max_size=256, z_fmt=Fmt(False, 1, 15), outstanding=4),
}
