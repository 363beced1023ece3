"""Co-simulation harness of the frame in SDRAM (``board/sdram_frame.py``): :class:`SdramFrameBench` (the frame
module and the display's timing generator, its two clocks as ports) against cocotbext-axi's ``AxiRam`` with random
wait states on every channel; the testbench (``cosim.sdram_frame_tb``) copies a sequence of frames in with random
gaps and records the display's words every pixel clock. Checked here against the frame store's model: every
displayed frame is one whole copied frame (no tearing), the frames shown in order (blank until the first copy, each
copy shown for at least one frame), every word of the active area equal to the model's (black outside the frame),
the back buffers in the ``AxiRam`` holding the copies at :class:`~board.sdram_frame.FrameLayout`'s addresses, and
every burst legal (inside a 4 KB page, the lengths of the layout). Environment: ``SIM`` (``icarus`` default).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
from amaranth import Module
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from board.dvi import TimingGenerator
from board.litedram import ADDR_BITS, DATA_BITS, ID_BITS
from board.sdram_frame import LATENCY, FrameLayout, SdramFrame
from board.video import VideoTiming
from fxmodel.core.paths import source_digest
from rtl.rop import axi_signature

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job

__all__ = ["SdramFrameBench", "run", "shown_frames"]


class SdramFrameBench(wiring.Component):
    """:class:`SdramFrame` with the display's :class:`TimingGenerator` (``sync``, the pixel clock); ``dram`` the
    memory's clock (ports ``dram_clk``, ``dram_rst``). ``x``, ``y``: the position the timing generator is at."""

    def __init__(self, layout: FrameLayout, timing: VideoTiming, fifo_depth: int, tile=None):
        self._frame = f = SdramFrame(layout, timing, fifo_depth, tile=tile)
        self.timing = timing
        super().__init__({"i": In(stream.Signature(DATA_BITS)), "col": In(f.col.shape()), "row": In(f.row.shape()),
                          "show": In(1), "copied": Out(1),
                          "mem": Out(axi_signature(ADDR_BITS, DATA_BITS, ID_BITS)), "error": Out(1),
                          "x": Out(range(timing.h_total)), "y": Out(range(timing.v_total)), "color": Out(DATA_BITS),
                          "front": Out(1), "underrun": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.timing = tg = TimingGenerator(self.timing)
        m.submodules.frame = f = self._frame
        wiring.connect(m, wiring.flipped(self.i), f.i)
        wiring.connect(m, f.mem, wiring.flipped(self.mem))
        m.d.comb += [f.col.eq(self.col), f.row.eq(self.row), f.show.eq(self.show)]
        m.d.comb += [f.x.eq(tg.x), f.y.eq(tg.y), self.x.eq(tg.x), self.y.eq(tg.y), self.color.eq(f.color),
                     self.copied.eq(f.copied), self.error.eq(f.error), self.front.eq(f.front),
                     self.underrun.eq(f.underrun)]
        return m


class SdramFrameLiteDramBench(wiring.Component):
    """:class:`SdramFrameBench` with LiteDRAM's simulation core (its DRAM model inside) in the place of the AXI
    memory: the frame's ``mem`` port on the core's AXI port, the core's init sequence run by
    :class:`~board.sdram_core.SdramInit` (``cke_delay``: the power-up wait, which the model does not check);
    ``ready`` once the core's port is open."""

    def __init__(self, layout: FrameLayout, timing: VideoTiming, fifo_depth: int, cke_delay: int = 200):
        from board.sdram_core import LiteDram
        self._bench = SdramFrameBench(layout, timing, fifo_depth)
        self._dram = LiteDram(None, cke_delay)
        super().__init__({"i": In(stream.Signature(DATA_BITS)), "show": In(1), "copied": Out(1), "error": Out(1),
                          "x": Out(range(timing.h_total)), "y": Out(range(timing.v_total)), "color": Out(DATA_BITS),
                          "front": Out(1), "underrun": Out(1), "ready": Out(1)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.bench = b = self._bench
        m.submodules.dram = d = self._dram
        wiring.connect(m, wiring.flipped(self.i), b.i)
        wiring.connect(m, b.mem, d.axi)
        m.d.comb += b.show.eq(self.show)
        m.d.comb += [self.x.eq(b.x), self.y.eq(b.y), self.color.eq(b.color), self.copied.eq(b.copied),
                     self.error.eq(b.error), self.front.eq(b.front), self.underrun.eq(b.underrun),
                     self.ready.eq(d.ready)]
        return m


def litedram_sources(sim: str, top: str, key: str, component, textures: bool = False) -> tuple[str, Path, Path]:
    """:func:`~cosim.harness.component_build` of a design holding LiteDRAM's simulation core (with its texture
    port when ``textures``), with the core's Verilog (generated into the build folder when missing:
    :func:`board.litedram.core`) appended."""
    from board.litedram import core as litedram_core
    core = litedram_core(True, textures=textures)
    top, bdir, src = component_build(top, key, sim, component)
    both = bdir / f"{top}_with_litedram.v"
    if not both.exists():
        both.write_text(src.read_text() + "\n" + core.read_text())
    return top, bdir, both


def shown_frames(rec: np.ndarray, layout: FrameLayout, timing: VideoTiming) -> list[np.ndarray]:
    """The recorded clocks ``(K, 3)`` (``x``, ``y``, ``color``) -> each whole frame's words at the frame's pixels
    ``(height, width)``, and the words outside the frame (must be 0) as the last row's check; the color of clock
    ``k`` belongs to the position of clock ``k - LATENCY``."""
    x, y, c = rec[:-LATENCY, 0], rec[:-LATENCY, 1], rec[LATENCY:, 2]
    starts = np.flatnonzero((x == 0) & (y == 0))
    out = []
    for s in starts:
        n = timing.frame_clocks
        if s + n > len(x):
            break
        fx, fy, fc = x[s:s + n], y[s:s + n], c[s:s + n]
        inside = (fx < layout.width) & (fy < layout.height)
        if fc[~inside].any():
            raise AssertionError(f"frame at clock {s}: a word outside the {layout.width}x{layout.height} frame "
                                 f"is not black")
        words = np.zeros((layout.height, layout.width), dtype=np.int64)
        words[fy[inside], fx[inside]] = fc[inside]
        out.append(words)
    return out


def tile_copies(words: list[np.ndarray], layout: FrameLayout, tile) -> tuple[list[dict], list[np.ndarray]]:
    """The copies that write the pictures ``words`` (``(rows th, cols tw)`` each: whole tiles) a ``tile`` at a
    time: ``[{col, row, show, words}]``, each picture's tiles in raster order of the grid, the last one showing it;
    and each picture cut to the frame (``(height, width)``), as the display must show it."""
    tw, th = tile
    copies, shown = [], []
    for w in words:
        rows, cols = w.shape[0] // th, w.shape[1] // tw
        for r in range(rows):
            for c in range(cols):
                copies.append({"col": c, "row": r, "show": int(r == rows - 1 and c == cols - 1),
                               "words": w[r * th:(r + 1) * th, c * tw:(c + 1) * tw].ravel().tolist()})
        shown.append(w[:layout.height, :layout.width])
    return copies, shown


def run(layout: FrameLayout, timing: VideoTiming, frames: list[np.ndarray], *, fifo_depth: int = 64,
        p_pause: float = 0.0, p_valid: float = 1.0, seed: int = 1, dram_ns: int = 10, pixel_ns: int = 40,
        extra_frames: int = 2, litedram: bool = False, sim: str | None = None, tile=None) -> dict:
    """Copy ``frames`` (``(height, width)`` RGB565 words each) in through the RTL and compare (module docstring).
    ``tile``: ``(width, height)``, each frame copied a tile at a time (:func:`tile_copies`; the frames then cover
    the whole grid of tiles, ``(rows th, cols tw)``), and the bursts checked at each tile's place.

    Returns
    -------
    dict
        ``shown`` (index of the copy each recorded frame equals, -1 blank, None none), ``in_order``, ``all_shown``,
        ``memory_ok`` (the buffers in the ``AxiRam``), ``bursts_ok``, ``underrun``, ``error``, ``cycles``.
    """
    sim = simulator(sim)
    key = hashlib.sha1(repr((layout, timing, fifo_depth, tile)).encode()
                       + source_digest(("board", "rtl", "cosim"))).hexdigest()[:12]
    if litedram:
        top, bdir, src = litedram_sources(sim, "sdram_frame_litedram", key,
                                          lambda: SdramFrameLiteDramBench(layout, timing, fifo_depth))
    else:
        top, bdir, src = component_build("sdram_frame", key, sim,
                                         lambda: SdramFrameBench(layout, timing, fifo_depth, tile))
    T = FrameLayout(*(tile or (layout.width, layout.height)), burst=layout.burst)
    pictures = [np.asarray(f, dtype=np.int64) for f in frames]
    if tile is None:
        pictures = [f.reshape(layout.height, layout.width) for f in pictures]
    copies, words = tile_copies(pictures, layout, (T.width, T.height))
    meta = {"copies": copies, "p_pause": p_pause, "p_valid": p_valid, "seed": seed,
            "dram_ns": dram_ns, "pixel_ns": pixel_ns, "extra_frames": extra_frames,
            "frame_clocks": timing.frame_clocks, "mem_bytes": 1 << max(12, (layout.base + 2 * layout.buffer_bytes
                                                                             - 1).bit_length()),
            "buffers": [[layout.address(b, y, 0) for y in range(layout.height)] for b in (0, 1)],
            "width": layout.width, "litedram": litedram}
    job = job_folder(bdir, "sdram_frame", {"key": key, "seed": seed, "p": [p_pause, p_valid], "n": len(frames)})
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.sdram_frame_tb", meta,
                                                "result.json")
    res = json.loads(out.read_text())
    rec = np.load(job / "clocks.npy").astype(np.int64)
    remove_job(job)
    shown = []
    for f in shown_frames(rec, layout, timing):
        if not f.any() and not any(not w.any() for w in words):
            shown.append(-1)
            continue
        hit = [k for k, w in enumerate(words) if np.array_equal(f, w)]
        shown.append(hit[-1] if hit else None)
    seq = [s for s in shown if s is not None]
    in_order = None not in shown and all(b in (a, a + 1) for a, b in zip(seq, seq[1:])) and seq[:1] in ([-1], [0])
    last_buffer = [bytes.fromhex(h) for h in res["buffers"]]
    want_last = [np.asarray(w, dtype="<u2").tobytes() for w in words[-2:]]
    memory_ok = None if litedram else \
        sorted(last_buffer) == sorted(want_last) if len(words) >= 2 else want_last[0] in last_buffer
    bursts_ok = all((a % 4096) + 2 * n <= 4096 and n in (layout.burst, layout.width % layout.burst or layout.burst,
                                                         T.width % layout.burst or layout.burst)
                    for a, n in res["aw"] + res["ar"])
    # the copies' bursts in order, each picture's into the buffer not shown (picture k into buffer 1 - k % 2), each
    # tile's at its place; no AW of a copy before its first word (its place comes with it)
    per = len(copies) // len(words)
    aw_want = [[layout.address(1 - (k // per) % 2, c["row"] * T.height + y, c["col"] * T.width + x),
                min(layout.burst, T.width - x)]
               for k, c in enumerate(copies) for y in range(T.height) for x in range(0, T.width, layout.burst)]
    aw_equal = res["aw"] == aw_want
    return {"shown": shown, "in_order": in_order, "all_shown": set(range(len(words))) <= set(shown),
            "memory_ok": memory_ok, "bursts_ok": bursts_ok, "aw_equal": aw_equal,
            "underrun": res["underrun"], "error": res["error"], "copied": res["copied"], "cycles": res["cycles"],
            "ar_bursts": len(res["ar"]), "ready_ns": res["ready_ns"], "simulator": sim,
            "build_seconds": build_seconds, "seconds": seconds}
