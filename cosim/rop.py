"""Co-simulation harness of the raster-operations unit (``rtl/rop.py``): fragments through the RTL into a frame
buffer held by cocotbext-axi's ``AxiRam`` (or the on-chip block RAM), the final memory image decoded
(:func:`fxmodel.units.rop.read_frame`) and compared with :func:`fxmodel.units.rop.draw` bit for bit, and the bus traffic
(``AR`` and ``AW`` transfers) with the model's byte counts.

Memory latency: ``AxiRam`` answers as soon as it can (about two cycles) and has no latency setting, so the
bench (:class:`RopBench`, simulation only) puts a **delay queue** on the ``AR``, ``AW`` and ``W`` channels
between the ROP and the memory: a transfer leaves the queue ``lat`` cycles after it entered (``lat`` an input of
the bench, so one build serves every latency), up to :data:`DELAY_DEPTH` in flight (full throughput up to that
latency). A read then takes ``lat`` plus the memory's own cycles, and a write lands ``lat`` cycles after its
issue, which is what makes the same-pixel hazard window long. Random wait states come from ``AxiRam``'s pause
generators on all five channels (ready low on ``AW``, ``W``, ``AR``; valid held back on ``R``, ``B``).
Environment: ``SIM`` (``icarus`` default, or ``verilator``).
"""

from __future__ import annotations

import json

import numpy as np
from amaranth.hdl import Array, Cat, Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from fxmodel.units.rop import DEPTH_BYTES, PIXEL_BYTES, RopParams, clear_frame, draw, read_frame, write_frame
from rtl.digest import params_key
from rtl.rop import Rop, axi_signature, ring_next

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job
from .raster import pack

__all__ = ["RopBench", "DelayQueue", "run", "run_engine", "DELAY_DEPTH", "LATENCY_BITS"]

#: Transfers a delay queue holds: full throughput up to this latency.
DELAY_DEPTH = 24
#: Width of the bench's ``lat`` input.
LATENCY_BITS = 6
#: Forward fields of each delayed channel (the ROP drives them), its valid and ready.
_CHANNELS = {"ar": ("arid", "araddr", "arlen", "arsize", "arburst"),
             "aw": ("awid", "awaddr", "awlen", "awsize", "awburst"),
             "w": ("wdata", "wstrb", "wlast")}
_RESPONSES = ("bid", "bresp", "bvalid", "rid", "rdata", "rresp", "rlast", "rvalid")


class RopBench(wiring.Component):
    """Simulation top: the ROP (``params`` a :class:`RopParams`) or the engine with its depth test (a
    :class:`~fxmodel.pipeline.engine.EngineParams` with ``rop``), delay queues on the ``AR``, ``AW`` and ``W``
    channels, the AXI4 port ``mem`` to the memory model. Ports: ``i`` (the design's: fragments or triangle
    records), ``mem`` (``axi_signature``), ``lat`` In(:data:`LATENCY_BITS`), ``busy`` (the design's, the ROP's
    too for the engine), ``status`` (the ROP's)."""

    def __init__(self, params):
        self.params = params
        self.inner = _design(params)
        rop = _rop_params(params)
        super().__init__({"i": In(stream.Signature(self.inner.i.payload.shape())),
                          "mem": Out(axi_signature(rop.addr_bits, rop.data_bits)),
                          "lat": In(LATENCY_BITS), "busy": Out(1), "status": Out(3)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.design = rop = self.inner
        wiring.connect(m, wiring.flipped(self.i), rop.i)
        busy = rop.busy | rop.rop_busy if hasattr(rop, "rop_busy") else rop.busy
        m.d.comb += [self.busy.eq(busy), self.status.eq(rop.status)]
        now = Signal(32)
        m.d.sync += now.eq(now + 1)
        src, dst = rop.axi, self.mem
        for ch, fields in _CHANNELS.items():
            payload = Cat(*(getattr(src, f) for f in fields))
            q = DelayQueue(len(payload), DELAY_DEPTH)
            setattr(m.submodules, f"delay_{ch}", q)
            m.d.comb += [q.now.eq(now), q.lat.eq(self.lat), q.in_valid.eq(getattr(src, f"{ch}valid")),
                         q.in_data.eq(payload), getattr(src, f"{ch}ready").eq(q.in_ready),
                         getattr(dst, f"{ch}valid").eq(q.out_valid), q.out_ready.eq(getattr(dst, f"{ch}ready")),
                         Cat(*(getattr(dst, f) for f in fields)).eq(q.out_data)]
        m.d.comb += [getattr(src, f).eq(getattr(dst, f)) for f in _RESPONSES]
        m.d.comb += [dst.rready.eq(src.rready), dst.bready.eq(src.bready)]
        return m


class DelayQueue(wiring.Component):
    """A valid/ready FIFO of ``depth`` registers whose head leaves no earlier than ``lat`` cycles after it
    entered (``now``: a cycle counter)."""

    def __init__(self, width: int, depth: int):
        self.width, self.depth = width, depth
        super().__init__({"in_valid": In(1), "in_ready": Out(1), "in_data": In(width), "out_valid": Out(1),
                          "out_ready": In(1), "out_data": Out(width), "lat": In(LATENCY_BITS), "now": In(32)})

    def elaborate(self, platform):
        m = Module()
        n = self.depth
        data = Array(Signal(self.width, name=f"d{k}") for k in range(n))
        due = Array(Signal(32, name=f"due{k}") for k in range(n))
        wp, rp, count = Signal(range(n)), Signal(range(n)), Signal(range(n + 1))
        push = self.in_valid & self.in_ready
        pop = self.out_valid & self.out_ready
        m.d.comb += [self.in_ready.eq(count < n), self.out_valid.eq((count != 0) & (self.now >= due[rp])),
                     self.out_data.eq(data[rp])]
        with m.If(push):
            m.d.sync += [data[wp].eq(self.in_data), due[wp].eq(self.now + self.lat),
                         wp.eq(ring_next(wp, n))]
        with m.If(pop):
            m.d.sync += rp.eq(ring_next(rp, n))
        m.d.sync += count.eq(count + push - pop)
        return m


def _rop_params(params) -> RopParams:
    return params if isinstance(params, RopParams) else params.rop


def _design(params):
    """The ROP, or the engine from the triangle with its depth test."""
    if isinstance(params, RopParams):
        return Rop(params)
    from rtl.engine import Engine
    return Engine(params)


def _build(params, sim: str):
    """``(top, build folder)``: the bench's Verilog written once per parameters (under a lock); on chip the
    design itself."""
    top, bdir, src = component_build(
        "rop_bench", params_key(params), sim,
        lambda: _design(params) if _rop_params(params).on_chip else RopBench(params))
    return top, bdir, src


def run(params: RopParams, frags, *, latency: int = 1, p_valid: float = 1.0, p_pause: float = 0.0,
        seed: int = 1, sim: str | None = None, tag: str = "", fb=None) -> dict:
    """Draw ``frags`` (codes ``(K, 7)`` of ``params.inputs``) through the ROP's RTL and compare the final frame
    with the model's.

    Parameters
    ----------
    latency : int
        Cycles the bench's delay queues add to ``AR``, ``AW``, ``W`` (0 .. ``DELAY_DEPTH``).
    p_valid : float
        Probability that the source offers a fragment in a cycle (random gaps).
    p_pause : float
        Probability of a wait state in a cycle, on each AXI channel independently.
    fb : tuple (depth, color), optional
        The frame in memory before drawing (default: the clear frame).

    Returns
    -------
    dict
        ``mismatches`` (pixels whose depth or color differ), ``model`` (the model's stats), ``rtl_bytes_read`` /
        ``rtl_bytes_written`` (4 per ``AR``, 8 per ``AW`` transfer), ``status``, ``cycles``, ``first`` (a few
        differing pixels); ``depth`` and ``color`` the RTL's frame.
    """
    frags = np.asarray(frags, dtype=np.int64).reshape(-1, len(params.inputs))
    want_d, want_c, stats = draw(params, frags, fb)
    res = _simulate(params, pack(params.inputs, frags), (want_d, want_c), fb, latency=latency, p_valid=p_valid,
                    p_pause=p_pause, seed=seed, sim=sim, tag=tag, drain=4)
    res["model"] = stats
    return res


def run_engine(params, records, *, latency: int = 1, p_valid: float = 1.0, p_pause: float = 0.0, seed: int = 1,
               sim: str | None = None, tag: str = "", fb=None) -> dict:
    """Draw triangle ``records`` (:class:`~fxmodel.units.raster.Records` or codes) through the engine with its depth
    test (``params`` a :class:`~fxmodel.pipeline.engine.EngineParams` with ``rop``) and compare the frame read
    from the memory model with :meth:`~fxmodel.pipeline.engine.EngineParams.draw`; arguments and report as
    :func:`run` (``model`` the model's depth-test stats, plus ``raster_clocks``)."""
    mat = records.matrix() if hasattr(records, "matrix") else np.asarray(records, dtype=np.int64)
    want_d, want_c, stats, out, scan = params.draw(mat, fb)
    res = _simulate(params, pack(params.raster.record, mat), (want_d, want_c), fb, latency=latency,
                    p_valid=p_valid, p_pause=p_pause, seed=seed, sim=sim, tag=tag,
                    drain=params.raster.latency + params.latency + 8,
                    expected=len(out))
    res["model"] = stats
    res["raster_clocks"] = int(scan.clocks.sum())
    return res


def _simulate(params, words, want, fb, *, latency, p_valid, p_pause, seed, sim, tag, drain, expected=None):
    sim = simulator(sim)
    P = _rop_params(params)
    if not 0 <= latency <= DELAY_DEPTH:
        raise ValueError(f"latency={latency}: must be in 0..{DELAY_DEPTH} (DELAY_DEPTH)")
    top, bdir, src = _build(params, sim)
    job = job_folder(bdir, tag or "job", {"design": top, "words": len(words), "latency": latency, "seed": seed,
                                           "p_valid": p_valid, "p_pause": p_pause, "tag": tag})
    init = write_frame(P, *(fb if fb is not None else clear_frame(P)))
    work = max(len(words), expected or 0)
    budget = int(work * (latency + 8) / max(min(p_valid, 1 - p_pause), 0.05)) * 4 + 4000 + 64 * len(words)
    meta = {"words": [format(w, "x") for w in words], "p_valid": p_valid, "drain": drain,
            "p_pause": p_pause, "seed": seed, "latency": latency, "max_cycles": budget,
            "on_chip": P.on_chip, "base": P.base, "frame_bytes": P.frame_bytes,
            "pixels": P.pixels, "readout_latency": P.readout_latency, "init": init.hex(),
            "engine": not isinstance(params, RopParams)}
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.rop_tb", meta, "frame.json")
    res = json.loads(out.read_text())
    remove_job(job)
    extra = {}
    if P.on_chip:
        depth, color = _unpack_words(P, [int(w, 16) for w in res["words"]])
        cd, cc = _unpack_words(P, [int(w, 16) for w in res["cleared"]])    # after the read-out that clears
        zd, zc = clear_frame(P)
        extra["cleared_mismatches"] = int(np.sum((cd != zd) | np.any(cc != zc, axis=-1)))
        extra["status_cleared"] = res["status_cleared"]
    else:
        depth, color = read_frame(P, bytes.fromhex(res["image"]))
    want_d, want_c = want
    bad = np.argwhere((depth != want_d) | np.any(color != want_c, axis=-1))
    first = [{"x": int(x), "y": int(y), "rtl": [int(depth[y, x])] + color[y, x].tolist(),
              "model": [int(want_d[y, x])] + want_c[y, x].tolist()} for y, x in bad[:5]]
    return {"depth": depth, "color": color, "simulator": sim, "inputs": len(words),
            "mismatches": int(len(bad)), "first": first,
            "rtl_bytes_read": DEPTH_BYTES * res["reads"], "rtl_bytes_written": PIXEL_BYTES * res["writes"],
            "status": res["status"], "cycles": res["cycles"], "accept_cycles": res["accept_cycles"],
            "build_seconds": build_seconds, "seconds": seconds, **extra}


def _unpack_words(params: RopParams, words):
    """On-chip words (depth, r, g, b, flags from the low bits) -> ``(depth (H, W), color (H, W, 4))``."""
    zb = params.z_fmt.width
    depth = np.array([v & ((1 << zb) - 1) for v in words], dtype=np.int64)
    color = np.array([[(v >> (zb + 8 * k)) & 0xFF for k in range(3)] + [v >> (zb + 24)] for v in words],
                     dtype=np.int64)
    return depth.reshape(params.height, params.width), color.reshape(params.height, params.width, 4)


def throughput(latencies=(1, 5, 10, 20), slots=(8, 16, 32), k: int = 400, sim: str | None = None) -> list[dict]:
    """Fragments accepted per clock against memory latency and scoreboard slots (``outstanding``): ``k``
    fragments on distinct pixels of a 32 x 16 frame (no hazard stalls), no gaps, no wait states."""
    rows = []
    for n in slots:
        P = RopParams(width=32, height=16, max_size=256, outstanding=n)
        i = np.arange(k) % P.pixels
        frags = np.stack([i % P.width, i // P.width, np.arange(k) + 1, i % 256, i % 256, i % 256, i % 32], 1)
        for lat in latencies:
            res = run(P, frags, latency=lat, sim=sim, tag=f"rate_{lat}")
            rows.append({"outstanding": n, "latency": lat, "mismatches": res["mismatches"],
                         "fragments_per_clock": round(k / res["accept_cycles"], 3)})
    return rows
