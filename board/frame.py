"""The engine on the board (``docs/board.md``): triangle records from the UART link handed to the engine's clock
domain, the engine drawing into its on-chip tile (the depth test's block RAM, ``rtl/rop.py`` with ``on_chip``),
the finished tile copied into the display's double-buffered frame store in the display's color format (RGB565),
and the display scanning the front buffer out (paper, section 4 and Fig. 5: the engine's colors go to a frame
buffer, which the display reads).

Clock domains: ``sync`` is the pixel clock (the UART link, the display, the frame store's read port), ``engine``
the engine's (the engine, the tile, the copy, the frame store's write port). What crosses:

- a TRIANGLE frame's record: assembled in ``sync`` as its bytes arrive (a shift register), moved at the frame's
  ``done`` (CRC matched) into a holding register, announced by a toggle (two-register synchroniser); the engine
  reads the holding register as its input (unchanged until the acknowledgement, a toggle back sent when the scan
  converter takes the record, has reached ``sync``). A record that arrives while the previous one is still held
  sets ``overrun`` (sticky until the next FRAME_START): the host waits for each frame's ACK, and one record takes
  longer on the UART (about 3 ms at 1 MBd) than the engine needs for a frame-sized triangle, so it does not happen
  in use;
- SWAP: a toggle to ``engine``; there, once the engine has been quiet (no record waiting, the scan converter and the
  depth test idle) for :data:`QUIET` clocks (more than the pipeline's latency), the tile is read out through the
  depth test's read port, each pixel narrowed to RGB565 (:func:`rgb565`: TRUNC of each channel's low bits) and
  written to the back buffer; a toggle back tells ``sync``, which shows that buffer from the next vertical
  blanking (no tearing) and acknowledges with a toggle, before which no other copy starts.

The frame is ``width x height`` pixels at the top left of the 640 x 480 picture, black around it (the reduced frame
of this stage: the tile holds the whole frame; ``docs/board.md``). The picture's model is :func:`display_frame`.
"""

from __future__ import annotations

import numpy as np
from amaranth import Cat, Const, DomainRenamer, Module, Mux, Signal
from amaranth.lib import memory, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from fxmodel.units.rop import STATUS_BITS as ROP_STATUS_BITS
from host.args import int_range
from host.protocol import STATE_BITS, Cmd
from rtl.fixed import const_mul

from .cdc import QUIET, toggle_sync
from .sdram_frame import tile_grid
from .upload import UploadWriter

__all__ = ["rgb565", "expand565", "display_frame", "board_engine", "board_grid", "board_picture", "picture_tiles",
           "tiled_color",
           "EngineSystem", "BoardSim", "QUIET",
           "BOARD_PRESET", "BOARD_SIZE", "MAX_BOARD_SIZE", "add_size_argument", "FRAMES", "BOARD_FRAME",
           "add_frame_argument", "add_textures_argument", "board_textures",
           "TileCopy"]


#: The board's pipeline preset (``presets/tin-plane-board.toml``: the fitted tin plane's, 29-texel reflectance
#: cubes): the ``default`` preset's engine (64-texel cubes) with the tile and the frame store used nearly all the
#: ECP5-85F's block RAMs and multipliers and did not route (``docs/board.md``).
BOARD_PRESET = "tin-plane-board"

#: The board's frame edge in pixels (the on-chip tile holds the whole frame): the default of every board command
#: (``bumpmap bitstream``, ``send``, ``board-sim``, ``animate``), so that the host's records fit the board's tile.
BOARD_SIZE = 128
#: The largest frame edge the on-chip tile takes (its block RAM).
MAX_BOARD_SIZE = 256


def add_size_argument(ap) -> None:
    """``--size``, the frame's edge in pixels (the on-chip tile), of the commands that build or simulate the board."""
    ap.add_argument("--size", type=int_range(1, MAX_BOARD_SIZE), default=BOARD_SIZE,
                    help=f"the frame's edge in pixels (the on-chip tile, at most {MAX_BOARD_SIZE}: block RAM; "
                         "default %(default)s)")


#: The board's frame stores: ``chip``, block RAM (the picture is one tile, at the display's top left); ``sdram``,
#: SDRAM behind LiteDRAM's core (the display's whole picture, double-buffered, drawn a tile at a time).
FRAMES = ("chip", "sdram")
#: The frame store of every board command unless ``--frame`` says otherwise (``bumpmap bitstream``, ``send``,
#: ``board-sim``, so ``make bitstream`` and ``make board-sim``): the whole picture in SDRAM, the board's design
#: (``docs/board.md``). One default for all three, so that the host sends the tiles the board it built expects.
BOARD_FRAME = "sdram"


def add_frame_argument(ap, what: str = "the frame store") -> None:
    """``--frame`` (:data:`FRAMES`, default :data:`BOARD_FRAME`) of the commands that build, drive or simulate the
    board; ``what`` names it in the command's terms."""
    ap.add_argument("--frame", choices=FRAMES, default=BOARD_FRAME,
                    help=f"{what}: sdram, the display's 640 x 480 picture a --size tile at a time in SDRAM behind "
                         "LiteDRAM's core (default); chip, block RAM, the picture one tile at the display's top left")


def add_textures_argument(ap) -> None:
    """``--textures`` of the commands that build, drive or simulate the board: the maps in SDRAM."""
    ap.add_argument("--textures", action="store_true",
                    help="the bump map and the color texture in SDRAM behind the engine's texel caches (the chosen "
                         "cache, fxmodel.units.texcache.CHOSEN_CACHE; with --frame sdram; TEXTURE frames load "
                         "them: docs/board.md, Textures in SDRAM)")


def board_textures(params, textures: bool, frame: str):
    """The board's engine ``params`` with its maps in SDRAM behind the chosen texel cache when ``textures``
    (:data:`fxmodel.units.texcache.CHOSEN_CACHE`), else as it is; ``ValueError`` for the maps in SDRAM with the
    frame on chip (the SDRAM is there only with the frame in it)."""
    if not textures:
        return params
    if frame != "sdram":
        raise ValueError("--textures: the maps in SDRAM need the frame in SDRAM (--frame sdram)")
    import dataclasses

    from fxmodel.units.texcache import CHOSEN_CACHE
    return dataclasses.replace(params, textures=CHOSEN_CACHE)


def rgb565(color: np.ndarray) -> np.ndarray:
    """``(..., 3)`` bytes -> RGB565 words (each channel's high 5, 6, 5 bits: TRUNC; red in the high bits)."""
    c = np.asarray(color, dtype=np.int64)
    return (c[..., 0] >> 3) << 11 | (c[..., 1] >> 2) << 5 | (c[..., 2] >> 3)


def expand565(word: np.ndarray) -> np.ndarray:
    """RGB565 words -> ``(..., 3)`` bytes as the display sends them (each channel's bits repeated from the top:
    31 -> 255, 0 -> 0)."""
    w = np.asarray(word, dtype=np.int64)
    r, g, b = w >> 11 & 31, w >> 5 & 63, w & 31
    return np.stack([r << 3 | r >> 2, g << 2 | g >> 4, b << 3 | b >> 2], axis=-1)


def display_frame(color: np.ndarray, h_active: int = 640, v_active: int = 480) -> np.ndarray:
    """The picture the display shows, ``(v_active, h_active, 3)`` bytes: the engine's frame ``color`` ``(H, W,
    >=3)`` through RGB565 at the top left, black around it."""
    h, w = color.shape[:2]
    out = np.zeros((v_active, h_active, 3), dtype=np.int64)
    out[:h, :w] = expand565(rgb565(color[..., :3]))
    return out


def board_grid(rop, timing, frame: str = "chip") -> tuple[int, int]:
    """The board's ``(columns, rows)`` of tiles: one with the frame on chip (the frame store holds the tile), the
    display's picture covered by ``rop.width x rop.height`` tiles with the frame in SDRAM (the last column and row
    cut by the picture's edge)."""
    return (1, 1) if frame == "chip" else tile_grid(timing.h_active, timing.v_active, rop.width, rop.height)


def board_engine(scene: str = "tin-plane", preset: str = BOARD_PRESET, size: int = BOARD_SIZE):
    """``(params, frame, tframe)``: the engine of the board for a scene (name or path) drawn at ``size`` x ``size``
    (the tile): the set-up's engine (:func:`host.render.from_triangles` with its depth test) with the frame buffer on
    chip, the texel memories holding the scene's tables."""
    import dataclasses

    from fxmodel.pipeline.engine import EngineParams
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    frame = prepare(scene_path(scene), size=(size, size), preset=preset)
    tframe = from_triangles(frame, depth=True)
    p = tframe.params
    return EngineParams(raster=p.raster, pipeline=p.pipeline, rop=dataclasses.replace(p.rop, on_chip=True)), \
        frame, tframe


def board_picture(scene="tin-plane", preset: str = BOARD_PRESET, size: int = BOARD_SIZE, timing=None,
                  cube_size: int | None = None):
    """``(params, frame, tiles)``: a scene (name, path or :class:`~host.scene.Scene`) prepared at the display's
    picture size (``timing``, default 640 x 480) and set up a ``size x size`` tile at a time, as the board with its
    frame in SDRAM draws it (:func:`picture_tiles`)."""
    from host.render import prepare
    from host.scene import scene_path

    from .video import VGA_640x480
    t = VGA_640x480 if timing is None else timing
    src = scene_path(scene) if isinstance(scene, str) else scene
    frame = prepare(src, size=(t.h_active, t.v_active), preset=preset, cube_size=cube_size)
    params, tiles = picture_tiles(frame, size)
    return params, frame, tiles


def picture_tiles(frame, size: int):
    """``(params, tiles)`` of a prepared ``frame`` (the whole picture) drawn a ``size x size`` tile at a time:
    ``params`` the engine of one tile (the depth test on chip, cleared to the scene's background), ``tiles``
    ``[((col, row), records)]`` in raster order of the grid (:func:`host.render.frame_records` with each tile's
    place), every tile of the grid, those no triangle touches with no record (they are cleared and copied all the
    same)."""
    import dataclasses

    from fxmodel.pipeline.engine import EngineParams
    from host.engine_setup import frame_raster, frame_records, frame_rop
    raster = frame_raster(frame)
    rop = dataclasses.replace(frame_rop(frame, raster, size, size), on_chip=True)
    params = EngineParams(raster=raster, pipeline=frame.params, rop=rop)
    cols, rows = tile_grid(frame.scene.width, frame.scene.height, size, size)
    tiles = [((c, r), frame_records(frame, raster, (c * size, r * size, size, size))[0])
             for r in range(rows) for c in range(cols)]
    return params, tiles


def tiled_color(params, tiles, picture: tuple[int, int]) -> np.ndarray:
    """The picture ``(height, width, 3)`` the engine ``params`` draws a tile at a time (``tiles`` as
    :func:`board_picture`'s): each tile's frame (:meth:`fxmodel.pipeline.engine.EngineParams.draw`, from its cleared
    tile) at its place, cut by the picture's edge."""
    tw, th = params.rop.width, params.rop.height
    cols = 1 + max(c for (c, _), _ in tiles)
    rows = 1 + max(r for (_, r), _ in tiles)
    out = np.zeros((rows * th, cols * tw, 3), dtype=np.int64)
    for (c, r), recs in tiles:
        _, color, _, _, _ = params.draw(recs)
        out[r * th:(r + 1) * th, c * tw:(c + 1) * tw] = color[..., :3]
    return out[:picture[1], :picture[0]]


class EngineSystem(wiring.Component):
    """Link (``sync``) -> engine with its on-chip tile (``engine``) -> frame store -> display (``sync``).

    Parameters
    ----------
    params : EngineParams
        With ``rop`` on chip: the tile is the frame (``rop.width x rop.height``).
    timing : VideoTiming
    divisor : int
        Pixel clocks a UART bit.
    frame : str
        The frame store: ``chip`` (block RAM) or ``sdram`` (``board/sdram_system.py``).
    blank : bool
        The texel memories start at zero instead of holding the scene's tables: an upload must fill them
        (TEXTURE and CUBE frames, ``board/upload.py``, write them either way).

    With ``params.textures`` (the bump map and the texture in SDRAM behind the engine's texel caches, ``docs/board.md``,
    "Textures in SDRAM"; the frame must be in SDRAM too) TEXTURE frames write the maps into the SDRAM through port
    ``tex`` and the caches read them there; the SDRAM starts without them, so they must be uploaded.

    Ports: ``rx``, ``tx`` (the UART), ``words`` (the three TMDS lanes' 10-bit words, lane 0 low), ``error`` (the
    link's sticky error), ``upload_bad`` (sticky: an upload's word named no map or lay beyond its map, not
    written), ``good`` (a pulse per good frame), ``overrun`` (sticky until FRAME_START: a record arrived
    while the last was held), ``front`` (the buffer shown), ``status`` (the depth test's sticky flags, ``engine``;
    the tile's clear at FRAME_START clears them).
    """

    def __init__(self, params, timing, divisor: int, frame: str = "chip", blank: bool = False):
        from rtl.engine import Engine
        from rtl.sampler import TexelWrites

        from .command import CommandLink
        from .dvi import Display
        if params.rop is None or not params.rop.on_chip:
            raise ValueError("EngineSystem needs the engine with its depth test on chip (RopParams.on_chip)")
        if timing.h_active < params.rop.width or timing.v_active < params.rop.height:
            raise ValueError(f"the {params.rop.width}x{params.rop.height} frame exceeds the display's "
                             f"{timing.h_active}x{timing.v_active}")
        if frame not in ("chip", "sdram"):
            raise ValueError(f"frame={frame!r}: the frame store is 'chip' (block RAM) or 'sdram'")
        self.params, self.timing, self.divisor, self.frame = params, timing, divisor, frame
        self.record_bits = sum(p.fmt.width for p in params.raster.record)
        self.record_len = -(-self.record_bits // 8)
        self._writes = TexelWrites(params.pipeline, blank)
        self.textures = params.textures is not None
        if self.textures and frame != "sdram":
            raise ValueError("the maps in SDRAM (EngineParams.textures) need the frame in SDRAM (frame='sdram')")
        if self.textures:
            from .texture_port import TEXTURE_ADDR_BITS
            self._engine = Engine(params, self._writes, tex_addr_bits=TEXTURE_ADDR_BITS, tex_flush=True)
        else:
            self._engine = Engine(params, self._writes)
        self.tex_error = Signal(name="tex_error")
        self.grid = board_grid(params.rop, timing, frame)
        self.place_bits = tuple(max(0, (n - 1).bit_length()) for n in self.grid)
        self._link = CommandLink(divisor, self.record_len, (params.rop.width, params.rop.height), self.grid,
                                 maps="sdram" if self.textures else "chip")
        self._display = Display(timing, latency=3)
        self._copy = TileCopy(params.rop, self._engine.fb.signature, place_bits=sum(self.place_bits),
                              wait_every_copy=frame == "sdram")
        self._picture_status = Signal(self._engine.status.shape(), name="picture_status")
        ports = {"rx": In(1, init=1), "tx": Out(1, init=1), "words": Out(30), "error": Out(1), "upload_bad": Out(1),
                 "good": Out(1), "overrun": Out(1), "front": Out(1), "status": Out(self._engine.status.shape())}
        if frame == "sdram":                    # the frame in SDRAM: its AXI4 port and flags (board/sdram_system.py)
            from .sdram_system import members
            ports |= members(self.textures)
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        P = self.params.rop
        pixels = P.width * P.height
        m.submodules.link = link = self._link
        eng = self._engine
        m.submodules.engine = DomainRenamer("engine")(eng)          # the engine's own clock
        m.submodules.display = disp = self._display
        m.d.comb += [link.rx.eq(self.rx), self.tx.eq(link.tx), self.error.eq(link.error), self.good.eq(link.done),
                     self.status.eq(self._picture_status)]
        # -- TEXTURE, CUBE: each word into its texel memory, in the engine's clock (board/upload.py)
        spans = None
        if self.textures:
            from .sdram_system import texture_spans
            spans = texture_spans(self.params)
        m.submodules.upload = up = UploadWriter(self._writes, sdram=spans)
        if self.textures:
            from .sdram_system import elaborate_textures
            m.d.comb += self.tex_error.eq(elaborate_textures(self, m, eng, up))
        m.d.comb += [up.cmd.eq(link.cmd), up.index.eq(link.index), up.data.eq(link.data),
                     up.data_valid.eq(link.data_valid), self.upload_bad.eq(up.bad)]
        # -- FRAME_START, SWAP: toggles to the engine's clock; the tile's clear and copy (TileCopy), whichever
        # the frame store
        # (and COPY), with FRAME_START's place in the grid of tiles, held in ``sync`` until the next FRAME_START
        swap_req, copy_req, start_req = Signal(), Signal(), Signal()
        place = Signal(sum(self.place_bits))
        with m.If(link.done & (link.cmd == Cmd.SWAP)):
            m.d.sync += swap_req.eq(~swap_req)
        with m.If(link.done & (link.cmd == Cmd.COPY)):
            m.d.sync += copy_req.eq(~copy_req)
        with m.If(link.done & (link.cmd == Cmd.FRAME_START)):
            m.d.sync += [start_req.eq(~start_req),
                         place.eq(Cat(link.col[:self.place_bits[0]], link.row[:self.place_bits[1]]))]
        m.submodules.copy = tc = DomainRenamer("engine")(self._copy)
        self._record(m, link, eng, tc.stall)
        wiring.connect(m, tc.fb, eng.fb)
        m.d.comb += [tc.swap.eq(toggle_sync(m, "swap", swap_req, "engine")),
                     tc.copy.eq(toggle_sync(m, "copy", copy_req, "engine")),
                     tc.start.eq(toggle_sync(m, "start", start_req, "engine")), tc.place.eq(place),
                     tc.active.eq(eng.i.valid | eng.busy | eng.rop_busy | (eng.fetch_busy if self.textures else 0))]
        # the depth test's flags over the picture's tiles: its own are cleared with each tile, these with the
        # picture's first (place 0, 0), during that tile's clear (the depth test's clear is registered: cleared
        # every clock of the walk, they end it clear)
        first = tc.clearing & (tc.tile_place == 0)
        m.d.engine += self._picture_status.eq(Mux(first, 0, self._picture_status | eng.status))
        self._state(m, link)
        if self.frame == "sdram":
            from .sdram_system import elaborate_frame
            elaborate_frame(self, m, tc, disp)
            return m
        # frame store: two buffers of RGB565, the buffer's index in the address's top bit
        store = memory.Memory(shape=16, depth=2 * pixels, init=[])
        m.submodules.store = store
        wr = store.write_port(domain="engine")
        rd = store.read_port(domain="sync")
        shown = Signal()
        m.d.comb += [tc.shown.eq(toggle_sync(m, "shown", shown, "engine")),
                     wr.addr.eq(tc.w_addr), wr.data.eq(tc.w_data), wr.en.eq(tc.w_en)]
        copied = tc.copied
        # -- display: the front buffer at the top left, black around it (three clocks: address, memory, the
        # expanded color registered)
        copied_seen = toggle_sync(m, "copied", copied, "sync")
        flip = Signal()
        with m.If(copied_seen):
            m.d.sync += flip.eq(1)
        t = self.timing
        with m.If(flip & (disp.x == 0) & (disp.y == t.v_active)):
            m.d.sync += [self.front.eq(~self.front), flip.eq(0), shown.eq(~shown)]
        inside = (disp.x < P.width) & (disp.y < P.height)
        index = (const_mul(disp.y, P.width) + disp.x)[:len(rd.addr) - 1]
        raddr, in1, in2 = Signal.like(rd.addr), Signal(), Signal()
        m.d.sync += [raddr.eq(Cat(Mux(inside, index, 0), self.front)), in1.eq(inside), in2.eq(in1)]
        m.d.comb += rd.addr.eq(raddr)
        px = rd.data
        r, g, b = px[11:16], px[5:11], px[0:5]
        m.d.sync += [disp.r.eq(Mux(in2, Cat(r[2:], r), 0)), disp.g.eq(Mux(in2, Cat(g[4:], g), 0)),
                     disp.b.eq(Mux(in2, Cat(b[2:], b), 0))]
        m.d.comb += self.words.eq(disp.words)
        return m


    def _state(self, m: Module, link) -> None:
        """The board's state, which STATUS is answered with (``host.protocol.STATE_BITS``), on the link's
        ``state`` in ``sync``: ``busy`` from a SWAP until the buffer shown changes (``front``), and the sticky
        flags, those of other clocks through two registers each (each flag is a bit of its own, which changes at
        most twice a frame: cleared at FRAME_START's tile clear, set by a fragment; so bit by bit is enough; those
        of a frame are set before its engine is quiet, long before its copy ends and ``busy`` falls)."""
        bits = {}
        due, front_then = Signal(), Signal()
        with m.If(due & (self.front != front_then)):
            m.d.sync += due.eq(0)
        with m.If(link.done & (link.cmd == Cmd.SWAP)):
            m.d.sync += [due.eq(1), front_then.eq(self.front)]
        bits["busy"], bits["overrun"], bits["upload_bad"] = due, self.overrun, self.upload_bad
        store_error = (self.mem_error | self.underrun) if self.frame == "sdram" else Const(0)
        status = self._picture_status
        for name, flag in (("outside", status[ROP_STATUS_BITS["outside"]]),
                           ("z_saturated", status[ROP_STATUS_BITS["z_saturated"]]), ("store_error", store_error)):
            bits[name] = Signal(name=f"state_{name}")
            m.submodules[f"state_{name}_ff"] = FFSynchronizer(flag, bits[name], o_domain="sync")
        state = [None] * len(STATE_BITS)
        for name, bit in STATE_BITS.items():
            state[bit] = bits[name]
        m.d.comb += link.state.eq(Cat(*state))

    def _record(self, m: Module, link, eng, stall):
        """The record, ``sync`` -> ``engine`` (module docstring); returns ``rec_valid`` (the engine's input
        valid; a record arriving while ``stall`` waits)."""
        nbytes = self.record_len
        shift, hold = Signal(8 * nbytes), Signal(8 * nbytes)
        req, ack, pending = Signal(), Signal(), Signal()
        with m.If(link.data_valid & (link.cmd == Cmd.TRIANGLE)):
            m.d.sync += shift.eq(Cat(shift[8:], link.data))
        ack_seen = toggle_sync(m, "rec_ack", ack, "sync")
        with m.If(ack_seen):
            m.d.sync += pending.eq(0)
        with m.If(link.done & (link.cmd == Cmd.FRAME_START) & (link.col == 0) & (link.row == 0)):
            m.d.sync += self.overrun.eq(0)                          # a flag of the picture (FRAME_FLAGS)
        with m.If(link.done & (link.cmd == Cmd.TRIANGLE)):
            with m.If(pending & ~ack_seen):
                m.d.sync += self.overrun.eq(1)
            with m.Else():
                m.d.sync += [hold.eq(shift), req.eq(~req), pending.eq(1)]
        # the engine reads the record straight from the holding register, which stays unchanged until the
        # acknowledgement (sent when the scan converter takes the record) is back in ``sync``; the record's bits
        # settled at least the synchroniser's two clocks before ``rec_valid`` rises
        # a record arriving while ``stall`` (a clear wanted) waits until the clear is done; one offered already
        # stays offered (it came before FRAME_START). The engine's input valid is a register: a gate in front of
        # it was the engine clock's critical path (into the scan converter's record-wide clock enable)
        req_seen = toggle_sync(m, "rec_req", req, "engine")
        rec_valid, arrived = Signal(), Signal()
        with m.If(req_seen):
            m.d.engine += arrived.eq(1)
        with m.If((arrived | req_seen) & ~stall & ~rec_valid):
            m.d.engine += [rec_valid.eq(1), arrived.eq(0)]
        with m.If(rec_valid & eng.i.ready):
            m.d.engine += [rec_valid.eq(0), ack.eq(~ack)]
        m.d.comb += [eng.i.valid.eq(rec_valid), eng.i.payload.eq(hold[:self.record_bits])]
        return rec_valid


class TileCopy(wiring.Component):
    """The tile's clear and copy (one clock domain, ``sync``; the engine's on the board). SWAP (``swap``, a pulse):
    once the engine has been quiet (``active`` low) for ``quiet`` clocks, the tile is read out through ``fb``, each
    word narrowed to RGB565 and written (``w_en``, ``w_addr``, ``w_data``, from registers) into the back buffer of
    the frame store (the buffer's index in the address's top bit); ``copied`` toggles when done, and no other copy
    starts before ``shown`` (a pulse: the display shows it). COPY (``copy``, a pulse): the same copy without
    showing it (a picture's tile but its last): ``copied`` does not toggle, and the next copy waits for ``shown``
    only with ``wait_every_copy`` (the frame in SDRAM, where ``shown`` is the copy's last write, not the display).
    FRAME_START (``start``): ``stall`` rises (the engine takes no record) and, once quiet and no copy waiting, the
    tile is read out with ``fb.clear`` (every word to the clear value, nothing written to the store); ``stall``
    falls when the clear is done. The tile's place (``place``, held from before ``start``, taken with it) is the
    tile's when its clear begins, and offered with each copy of the tile (``copy_place``, with ``copy_show``: the
    copy is a SWAP's), held from before the copy's first word until the next copy begins; ``tile_place`` is the
    tile's place, ``clearing`` high while the clear's walk reads the tile. ``room`` (default
    high): the copy's walk steps only while it is high (a FIFO behind the writes with room for the words in
    flight, ``params.readout_latency + 1``; the frame in SDRAM, ``board/sdram_system.py``); the clear's walk
    ignores it.

    Parameters
    ----------
    params : RopParams
        The tile (on chip).
    fb : wiring.Signature
        The depth test's read-out (``rtl.rop``), which this drives.
    quiet : int
        Clocks of quiet before a copy or clear (beyond the pixel pipeline's latency).
    """

    def __init__(self, params, fb: wiring.Signature, quiet: int = QUIET, place_bits: int = 0,
                 wait_every_copy: bool = False):
        self.params, self.quiet, self.wait_every_copy = params, quiet, wait_every_copy
        pixels = params.pixels
        super().__init__({"swap": In(1), "copy": In(1), "start": In(1), "shown": In(1), "active": In(1),
                          "room": In(1, init=1), "place": In(place_bits), "fb": In(fb),
                          "w_en": Out(1), "w_addr": Out(range(2 * pixels)), "w_data": Out(16), "stall": Out(1),
                          "copied": Out(1), "copy_place": Out(place_bits), "copy_show": Out(1),
                          "tile_place": Out(place_bits), "clearing": Out(1)})

    def elaborate(self, platform):
        m = Module()
        P, pixels = self.params, self.params.pixels
        quiet = Signal(range(self.quiet + 1))
        with m.If(self.active):
            m.d.sync += quiet.eq(0)
        with m.Elif(quiet != self.quiet):
            m.d.sync += quiet.eq(quiet + 1)
        back = Signal(init=1)
        want, waiting, clear_want = Signal(), Signal(), Signal()   # a copy to serve; a copy not yet shown; a clear
        want_show, tile_place = Signal(), self.tile_place          # the copy wanted is a SWAP's; the tile's place
        drained = pixels + P.readout_latency + 1        # the walk's address when its last word is in the store
        addr = Signal(range(drained + 1))
        reading, clearing, wvalid, waddr = Signal(), Signal(), Signal(), Signal(range(2 * pixels))
        with m.If(self.swap | self.copy):            # a SWAP's show is kept until its copy is served
            m.d.sync += [want.eq(1), want_show.eq(self.swap | (want & want_show))]
        # the place, held in the other clock from FRAME_START's handshake on, is taken here with its pulse (so it
        # has settled), and by the tile when its clear begins (a copy of the tile before waits for it)
        place_next = Signal.like(self.place)
        with m.If(self.start):
            m.d.sync += place_next.eq(self.place)
        with m.If(self.start):
            m.d.sync += clear_want.eq(1)
        with m.If(self.shown):
            m.d.sync += waiting.eq(0)
        zb = P.z_fmt.width
        data = self.fb.data
        word565 = Cat(data[zb + 19:zb + 24], data[zb + 10:zb + 16], data[zb + 3:zb + 8])
        # the tile's word is registered before the frame store's write port: both memories span the device's
        # block RAM rows, and the read-out's output straight into the other's inputs was a path through two
        # die-wide routes (the engine's clock at a third of its target after placement)
        m.d.comb += [self.fb.read.eq(reading), self.fb.clear.eq(clearing & reading),
                     self.clearing.eq(clearing & reading), self.fb.addr.eq(addr[:len(self.fb.addr)]),
                     self.stall.eq(clear_want)]
        # the address's word comes ``readout_latency`` clocks later (``rtl/rop.py``): its valid and store address
        # follow it in a delay line (the back buffer's index with it: it changes as the walk ends)
        m.d.sync += [wvalid.eq(reading & ~clearing & (addr < pixels) & self.room),
                     waddr.eq(Cat(addr[:len(waddr) - 1], back))]
        for _ in range(P.readout_latency - 1):
            v, a = Signal(), Signal.like(waddr)
            m.d.sync += [v.eq(wvalid), a.eq(waddr)]
            wvalid, waddr = v, a
        m.d.sync += [self.w_en.eq(wvalid), self.w_addr.eq(waddr), self.w_data.eq(word565)]
        ready = (quiet == self.quiet) & ~self.swap & ~self.copy & ~self.start
        with m.FSM():
            with m.State("idle"):
                with m.If(want & ~waiting & ready):
                    m.d.sync += [want.eq(0), addr.eq(0), reading.eq(1), self.copy_place.eq(tile_place),
                                 self.copy_show.eq(want_show)]
                    m.next = "walk"
                with m.Elif(clear_want & ~want & ready):
                    m.d.sync += [addr.eq(0), reading.eq(1), clearing.eq(1),     # the copy's walk, clearing
                                 tile_place.eq(place_next)]
                    m.next = "walk"
            with m.State("walk"):
                with m.If(addr == pixels):
                    m.d.sync += reading.eq(0)
                    m.next = "drain"
                with m.Elif(self.room | clearing):
                    m.d.sync += addr.eq(addr + 1)
            with m.State("drain"):          # the last words through the read-out and the store's registers
                m.d.sync += addr.eq(addr + 1)
                with m.If((addr == drained) & clearing):
                    m.d.sync += [clearing.eq(0), clear_want.eq(0)]
                    m.next = "idle"
                with m.Elif(addr == drained):
                    m.d.sync += waiting.eq(self.copy_show | self.wait_every_copy)
                    with m.If(self.copy_show):                  # a SWAP's: the display shows this buffer next
                        m.d.sync += [self.copied.eq(~self.copied), back.eq(~back)]
                    m.next = "idle"
        return m


class BoardSim(wiring.Component):
    """:class:`EngineSystem` with its two clocks as ports, for simulation (no I/O primitives, no PLL, no
    serializer: the display's encoded words are the output): ``clk``/``rst`` of the top are the pixel clock's,
    ``engine_clk``/``engine_rst`` the engine's. ``blank``: the texel memories start at zero (uploads fill them)."""

    def __init__(self, params, timing, divisor: int, blank: bool = False):
        self._sys = EngineSystem(params, timing, divisor, blank=blank)
        super().__init__({"engine_clk": In(1), "engine_rst": In(1), "rx": In(1, init=1), "tx": Out(1, init=1),
                          "words": Out(30), "error": Out(1), "good": Out(1), "overrun": Out(1), "front": Out(1),
                          "upload_bad": Out(1), "status": Out(self._sys.status.shape())})

    def elaborate(self, platform):
        from amaranth import ClockDomain, ClockSignal, ResetSignal
        m = Module()
        m.domains.engine = ClockDomain("engine")
        m.d.comb += [ClockSignal("engine").eq(self.engine_clk), ResetSignal("engine").eq(self.engine_rst)]
        m.submodules.system = s = self._sys
        m.d.comb += [s.rx.eq(self.rx), self.tx.eq(s.tx), self.words.eq(s.words), self.error.eq(s.error),
                     self.upload_bad.eq(s.upload_bad),
                     self.good.eq(s.good), self.overrun.eq(s.overrun), self.front.eq(s.front),
                     self.status.eq(s.status)]
        return m
