"""End-to-end co-simulation of the board (``board/frame.py``): the host tool's bytes (``bumpmap send``'s frames,
``host/protocol.py``) into the UART, the command parser feeding the triangle records to the engine, the engine's
fragments through the depth test into its on-chip tile, SWAP copying the tile into the display's frame store in
RGB565, the display scanning it out as DVI; the TMDS words decoded (:func:`board.video.tmds_decode`, DVI 1.0
section 3.2) into the picture, compared on every pixel with the model's (the engine's frame, :meth:`EngineParams.draw
<fxmodel.pipeline.engine.EngineParams.draw>`, through the display's color format: :func:`board.frame.display_frame`),
and the video timing measured from the decoded syncs (``cosim.board_dvi.measure``); after the frame is shown, the
board's answer to STATUS (``state_ok``: not busy, no flag set, as ``bumpmap send`` requires).

The upload frames (TEXTURE, CUBE) are left out of the simulated stream by default: the RTL's texel memories hold
the scene's tables (as ``make sim`` does), and the uploads are nearly all of the bytes (most of a second of the
board's time at 1 MBd). With ``uploads`` they are sent, into texel memories that start at zero
(``BoardSim(blank=True)``), with the UART at :data:`UPLOAD_DIVISOR` pixel clocks a bit, so the picture shows that
every word reached its memory. With the maps in SDRAM (``params.textures``, the frame in SDRAM) the TEXTURE frames
are always sent (the SDRAM starts without the maps), with the UART at :data:`UPLOAD_DIVISOR` pixel clocks a bit;
the cubes keep their tables. The clocks: the board's 25 MHz pixel clock (UART at 1 MBd, 25 clocks a bit) and the
engine at 100 MHz.
"""

from __future__ import annotations

import hashlib
import json
import time
from functools import lru_cache

import numpy as np

from board.frame import BoardSim, display_frame
from board.top import DRAM_HZ, ENGINE_HZ, PIXEL_HZ
from board.video import VGA_640x480, VideoTiming, tmds_decode
from fxmodel.core.paths import source_digest
from host.protocol import STATE_ANSWER, Cmd
from host.protocol import frame as protocol_frame

from .board_dvi import measure
from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job

__all__ = ["simulate", "split_frames", "decode_words", "PIXEL_NS", "ENGINE_NS", "DRAM_NS", "DIVISOR"]

#: The pixel clock (25 MHz, the board's), the engine's (the board's with the frame on chip, ``board.top.ENGINE_HZ``,
#: its 100 MHz target), pixel clocks a UART bit (1 MBd).
PIXEL_NS, ENGINE_NS, DIVISOR = 10 ** 9 // PIXEL_HZ, 10 ** 9 // ENGINE_HZ, 25
#: The SDRAM's clock with the frame in SDRAM: the board's (``board.top.DRAM_HZ``).
DRAM_NS = 10 ** 9 // DRAM_HZ
#: Pixel clocks a UART bit when the uploads are simulated (6.25 MBd: the receiver samples each bit's middle).
UPLOAD_DIVISOR = 4


def split_frames(data: bytes) -> list[bytes]:
    """The protocol's frames of a well-formed byte stream (``ValueError`` where a frame does not start)."""
    out, k = [], 0
    while k < len(data):
        if data[k] != 0xA5 or k + 4 > len(data):
            raise ValueError(f"byte {k}: no frame starts here (SYNC 0xA5 and a 2-byte length expected)")
        n = 6 + int.from_bytes(data[k + 2:k + 4], "little")
        out.append(data[k:k + n])
        k += n
    return out


@lru_cache(maxsize=1024)
def _decode(word: int) -> tuple[int, int, int]:
    return tmds_decode(word)


def decode_words(words: np.ndarray) -> np.ndarray:
    """The display's 30-bit words (lane 0 low) -> ``(K, 6)``: ``de, hsync, vsync, r, g, b`` per pixel clock, as
    :func:`cosim.board_dvi.decode` (syncs held through active video), memoised per symbol."""
    out, hs, vs = np.zeros((len(words), 6), dtype=np.int64), 0, 0
    for k, w in enumerate(words.tolist()):
        (de, b, c0), (de1, g, c1), (de2, r, c2) = (_decode(w & 0x3FF), _decode(w >> 10 & 0x3FF),
                                                   _decode(w >> 20 & 0x3FF))
        if not de == de1 == de2 or c1 or c2:
            raise AssertionError(f"clock {k}: lanes disagree on de or carry control bits: {w:#x}")
        if not de:
            hs, vs = c0 & 1, c0 >> 1
        out[k] = (de, hs, vs, r, g, b)
    return out


def simulate(params, records, data: bytes, *, timing: VideoTiming = VGA_640x480, sim: str | None = None,
             frame: str = "chip", uploads: bool = False, picture=None) -> dict:
    """Simulate the board drawing ``records`` (codes) from the byte stream ``data``; the report (``pix`` the
    decoded clocks, ``picture`` the decoded frame, ``want`` the model's). ``frame="sdram"``: the frame in SDRAM
    behind LiteDRAM's simulation core (``board/sdram_system.py``). ``uploads``: the TEXTURE and CUBE frames sent
    into blank texel memories (module docstring; the frame on chip). ``picture``: the engine's picture drawn a tile
    at a time (:func:`board.frame.tiled_color`), the model's frame instead of ``records`` drawn as one tile."""
    sim = simulator(sim)
    if uploads and frame != "chip":
        raise ValueError("uploads: simulated with the frame on chip only")
    textures = params.textures is not None
    if textures and frame != "sdram":
        raise ValueError("the maps in SDRAM (params.textures): simulated with the frame in SDRAM only")
    frames = split_frames(data)
    left_out = () if uploads else (Cmd.CUBE,) if textures else (Cmd.TEXTURE, Cmd.CUBE)
    kept = [f for f in frames if f[1] not in left_out]
    if textures and not any(f[1] == Cmd.TEXTURE for f in kept):
        raise ValueError("the maps in SDRAM (params.textures): the bytes carry no TEXTURE frame to load them")
    stream = b"".join(kept)
    divisor = UPLOAD_DIVISOR if uploads or textures else DIVISOR
    color = params.draw(records)[1] if picture is None else picture
    want = display_frame(color, timing.h_active, timing.v_active)
    key = hashlib.sha1(repr((params, timing, divisor, uploads)).encode()
                       + source_digest(("fxmodel", "rtl", "board", "host"))).hexdigest()[:12]
    t0 = time.perf_counter()
    if frame == "sdram":
        from board.sdram_sim import SdramBoardSim

        from .sdram_frame import litedram_sources
        top, bdir, src = litedram_sources(sim, "board_sim_sdram", key, lambda: SdramBoardSim(params, timing, divisor),
                                          textures=textures)
    else:
        top, bdir, src = component_build("board_sim", key, sim, lambda: BoardSim(params, timing, divisor, uploads))
    verilog_seconds = time.perf_counter() - t0
    clocks = (timing.v_total - timing.v_active + timing.v_total + 2) * timing.h_total
    frame_ns = timing.frame_clocks * PIXEL_NS
    meta = {"data": stream.hex(), "status_frame": protocol_frame(Cmd.STATUS).hex(), "pixel_ns": PIXEL_NS,
            "engine_ns": ENGINE_NS, "divisor": divisor,
            "clocks": clocks, "timeout_ns": 3 * frame_ns, **({"dram_ns": DRAM_NS} if frame == "sdram" else {})}
    job = job_folder(bdir, "system", {"data": hashlib.sha1(stream).hexdigest(), "clocks": clocks})
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.board_system_tb", meta,
                                                "result.json")
    res = json.loads(out.read_text())
    shown = (job / "words.npy").exists()
    words = np.load(job / "words.npy") if shown else np.zeros(0, np.uint32)
    remove_job(job)
    rep = {"simulator": sim, "frames_sent": len(kept), "frames_left_out": len(frames) - len(kept),
           "bytes_sent": len(stream), "bytes_left_out": len(data) - len(stream),
           "replies": res["replies"], "acks_ok": bytes.fromhex(res["replies"]) == bytes(len(kept)),
           "state_answer": res["state_answer"],
           "state_ok": res["state_answer"] is not None and int(res["state_answer"], 16) == STATE_ANSWER,
           "error": res["error"], "overrun": res["overrun"], "rop_status": res["status"], "shown": shown,
           "uploads": uploads, "textures": textures, "upload_bad": res.get("upload_bad"),
           "frame": frame, "underrun": res.get("underrun"), "mem_error": res.get("mem_error"),
           "dram_ready": res.get("dram_ready"),
           "sim_ms": {"uart_done": res["sent_ns"] / 1e6, "shown": res["shown_ns"] / 1e6, "end": res["end_ns"] / 1e6},
           "verilog_seconds": round(verilog_seconds, 1), "build_seconds": round(build_seconds, 1),
           "sim_seconds": round(seconds, 1), "want": want}
    if not shown:
        rep.update(pixels=0, mismatches=None, timing_ok=False)
        return rep
    pix = decode_words(words)
    m = measure(pix, timing)
    de = pix[:, 0]
    starts = [s for s in np.flatnonzero(de) if s >= timing.h_total and not de[s - timing.h_total:s].any()]
    first = int(starts[0])
    h = timing.h_total
    lines = [pix[first + v * h:first + v * h + timing.h_active] for v in range(timing.v_active)]
    ok_de = all(len(ln) == timing.h_active and ln[:, 0].all() for ln in lines)
    picture = np.stack([ln[:, 3:6] for ln in lines]) if ok_de else np.zeros_like(want)
    bad = np.argwhere(np.any(picture != want, axis=-1))
    expect = {"line_periods": [timing.h_total], "hsync_widths": [timing.h_sync], "active_widths": [timing.h_active],
              "vsync_widths": [timing.v_sync * timing.h_total], "frame_periods": [timing.frame_clocks],
              "lines_per_frame": [timing.v_active]}
    rep.update(pixels=int(want.shape[0] * want.shape[1]), mismatches=int(len(bad)),
               first_mismatches=[{"x": int(x), "y": int(y), "rtl": picture[y, x].tolist(),
                                  "model": want[y, x].tolist()} for y, x in bad[:5]],
               timing=m, timing_expected=expect, timing_ok=(m == expect) and ok_de, picture=picture)
    return rep

