"""Co-simulation harness of the decoupled texel cache (``rtl/texcache_decoupled.py``): lookups on the surfaces of a
:class:`~fxmodel.units.texcache.Layout` through the RTL, the surfaces in cocotbext-axi's ``AxiRam`` in the model's
blocked layout behind a delay queue on ``AR`` (the memory latency ``lat``, a bench input: one build serves every
latency), and the outputs (the four texels and the sideband of each lookup, in order) and the memory traffic
(every ``AR`` burst's address and length, the ``R`` beats) compared with :func:`fxmodel.units.texcache.simulate`
exactly. Random request gaps, output backpressure and wait states on both read channels; the clocks from reset to
the last output give the lookups per clock. Environment: ``SIM`` (``icarus`` default, or ``verilator``).
"""

from __future__ import annotations

import json

import numpy as np
from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from fxmodel.units.texcache import Layout, TexCacheParams, Trace, simulate
from rtl.digest import params_key
from rtl.texcache_decoupled import DecoupledTexCache, request_layout

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job
from .rop import LATENCY_BITS, DelayQueue

__all__ = ["FetchBench", "run", "run_fetch", "pack_requests", "MAX_LATENCY"]

#: Largest ``lat`` of the bench (its ``lat`` input's range).
MAX_LATENCY = (1 << LATENCY_BITS) - 1
#: Bursts the bench's ``AR`` delay queue holds (more than any design here has outstanding).
DELAY_DEPTH = 16


class FetchBench(wiring.Component):
    """Simulation top: ``inner`` (a :class:`~rtl.texcache_decoupled.DecoupledTexCache` or a
    :class:`~rtl.texfetch.TexFetch`), a delay queue of :data:`DELAY_DEPTH` entries on ``AR`` (every burst leaves
    it ``lat`` cycles after the design issued it), the AXI4 port ``mem`` (the design's port ``port``: the
    engine's ``tex``). Ports: the design's ``i``, ``o``, ``mem``, ``busy``, and ``lat``."""

    def __init__(self, inner, port: str = "mem"):
        self.inner, self.port = inner, port
        sig = self.inner.signature.members
        super().__init__({"i": sig["i"], "o": sig["o"], "mem": sig[port], "busy": Out(1), "lat": In(LATENCY_BITS)})

    def elaborate(self, platform):
        m = Module()
        m.submodules.cache = c = self.inner
        wiring.connect(m, wiring.flipped(self.i), c.i)
        wiring.connect(m, c.o, wiring.flipped(self.o))
        m.d.comb += self.busy.eq(c.busy)
        now = Signal(32)
        m.d.sync += now.eq(now + 1)
        src, dst = getattr(c, self.port), self.mem
        fields = ("arid", "araddr", "arlen", "arsize", "arburst")
        payload = [getattr(src, f) for f in fields]
        width = sum(len(p) for p in payload)
        m.submodules.delay_ar = q = DelayQueue(width, DELAY_DEPTH)
        m.d.comb += [q.now.eq(now), q.lat.eq(self.lat), q.in_valid.eq(src.arvalid), q.in_data.eq(Cat(*payload)),
                     src.arready.eq(q.in_ready), dst.arvalid.eq(q.out_valid), q.out_ready.eq(dst.arready),
                     Cat(*(getattr(dst, f) for f in fields)).eq(q.out_data)]
        for f in ("rid", "rdata", "rresp", "rlast", "rvalid", "bid", "bresp", "bvalid"):
            m.d.comb += getattr(src, f).eq(getattr(dst, f))
        m.d.comb += [dst.rready.eq(src.rready), dst.bready.eq(src.bready), dst.awvalid.eq(0), dst.wvalid.eq(0)]
        return m


def pack_requests(lay, trace: Trace, side=None) -> list[int]:
    """Request words of ``lay`` (:func:`rtl.texcache_decoupled.request_layout`; ``side`` per lookup, if it has a
    sideband)."""
    cols = {"surface": trace.surface, "x0": trace.x0, "x1": trace.x1, "y0": trace.y0, "y1": trace.y1}
    if side is not None:
        cols["side"] = side
    words = np.zeros(len(trace), dtype=object)
    for name, fld in lay:
        words = words + np.asarray(cols[name], dtype=object) * (1 << fld.offset)
    return [int(v) for v in words]


def run(params: TexCacheParams, layout: Layout, maps: list, trace: Trace, *, side_bits: int = 4, latency: int = 1,
        p_valid: float = 1.0, p_ready: float = 1.0, p_pause: float = 0.0, seed: int = 1, sim: str | None = None,
        tag: str = "") -> dict:
    """Look up ``trace`` in the RTL cache over ``layout`` holding ``maps`` and compare with the model.

    Returns
    -------
    dict
        ``mismatches`` (lookups whose texels or sideband differ), ``outputs``, ``bursts_equal``, ``rtl_bursts``
        and ``model_bursts`` (``(address, AXI length)`` of every ``AR``, in order), ``rtl_bytes``,
        ``model_bytes``, ``model`` (the model's totals), ``cycles`` (reset to the last output),
        ``lookups_per_clock``.
    """
    sim = simulator(sim)
    model = simulate(params, layout, trace)
    side = np.arange(len(trace)) % (1 << side_bits) if side_bits else None
    reqs = pack_requests(request_layout(layout, side_bits), trace, side)
    budget = 400 + len(reqs) * 6 + (model.totals["beats"] + 40 * model.totals["bursts"]) * 3
    got, build_seconds, seconds = _simulate_bench(
        lambda: DecoupledTexCache(params, layout, side_bits), (params, layout, side_bits), reqs,
        layout.image(maps), layout.base, budget=budget,
        **dict(latency=latency, p_valid=p_valid, p_ready=p_ready, p_pause=p_pause, seed=seed, sim=sim, tag=tag))
    tb = params.texel_bits
    x, y = trace.corners()
    want = np.zeros((len(trace), 4), np.int64)
    for k, words in enumerate(maps):
        rows = np.flatnonzero(trace.surface == k)
        want[rows] = np.asarray(words, np.int64)[y[rows], x[rows]] & ((1 << tb) - 1)
    vals = [int(v, 16) for v in got["outputs"]]
    rtl = np.array([[(v >> (tb * q)) & ((1 << tb) - 1) for q in range(4)] for v in vals], np.int64).reshape(-1, 4)
    rside = np.array([v >> (4 * tb) for v in vals], np.int64)
    ok = rtl.shape == want.shape
    bad = (np.any(rtl != want, axis=1) | ((rside != side) if side is not None else False)) if ok \
        else np.ones(len(want), bool)
    bursts = [(int(a), int(n)) for a, n in got["ar"]]
    model_bursts = [(int(a), params.beats_per_line - 1) for a in model.burst_addresses()]
    return {"mismatches": int(bad.sum()), "outputs": len(vals), "lookups": len(trace),
            "bursts_equal": bursts == model_bursts, "rtl_bursts": bursts, "model_bursts": model_bursts,
            "rtl_bytes": 4 * got["beats"], "model_bytes": model.totals["memory_bytes"], "model": model.totals,
            "cycles": got["cycles"], "lookups_per_clock": len(trace) / max(got["cycles"], 1), "latency": latency,
            "simulator": sim, "build_seconds": build_seconds, "seconds": seconds}


def _simulate_bench(make, key, reqs: list, image: bytes, base: int, *, latency, p_valid, p_ready, p_pause, seed,
                    sim, tag, budget, dram_ns=None) -> tuple[dict, float, float]:
    """Build (once per ``key``) and run the bench around the design ``make()`` builds; the testbench's result.
    With ``dram_ns`` the bench is :class:`cosim.texfetch_dram.FetchDramBench` (the memory LiteDRAM's simulation
    core in a clock of that period; ``latency`` and ``p_pause`` do not apply), else :class:`FetchBench`."""
    if not 0 <= latency <= MAX_LATENCY:
        raise ValueError(f"latency={latency}: must be in 0..{MAX_LATENCY}")
    if dram_ns is None:
        top, bdir, src = component_build("texfetch", params_key(key), sim, lambda: FetchBench(make()))
        tb = "cosim.texfetch_tb"
    else:
        from fxmodel.core.paths import source_digest

        from .sdram_frame import litedram_sources
        from .texfetch_dram import FetchDramBench
        bkey = params_key(key, source_digest(("board", "cosim")).hex())
        top, bdir, src = litedram_sources(sim, "texfetch_dram", bkey, lambda: FetchDramBench(make()), textures=True)
        from board.texture_port import TEXTURE_BASE
        tb, budget = "cosim.texfetch_dram_tb", budget * max(1, -(-dram_ns // 10)) + 4000
        base += TEXTURE_BASE                                # where the testbench writes the maps
    job = job_folder(bdir, tag or "texfetch", {"key": repr(key), "sim": sim, "lookups": len(reqs), "seed": seed,
                                               "p": [p_valid, p_ready, p_pause], "latency": latency,
                                               "dram_ns": dram_ns})
    meta = {"requests": [format(r, "x") for r in reqs], "image": image.hex(), "base": base, "p_valid": p_valid,
            "p_ready": p_ready, "p_pause": p_pause, "seed": seed, "latency": latency, "dram_ns": dram_ns,
            "max_cycles": int(budget / max(min(p_valid, p_ready, 1 - p_pause), 0.05))}
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, tb, meta, "result.json")
    got = json.loads(out.read_text())
    remove_job(job)
    return got, build_seconds, seconds


def run_fetch(caches: dict, layout: Layout, maps: list, traces: dict, *, side_bits: int = 4, latency: int = 1,
              p_valid: float = 1.0, p_ready: float = 1.0, p_pause: float = 0.0, seed: int = 1,
              sim: str | None = None, tag: str = "", dram_ns: int | None = None) -> dict:
    """Fragments through the texture fetch (``rtl/texfetch.py``): ``traces[map]`` (one row per fragment, the
    same fragments) in the caches ``caches[map]`` over ``layout`` holding ``maps`` (one array per surface); the
    texels of both maps and the sideband against the maps, and each map's bursts (the ``AR`` transfers to its
    surfaces, in order) against its cache's model. ``dram_ns``: the maps in LiteDRAM's simulation core behind the
    board's clock crossing, the SDRAM's clock of that period (``cosim/texfetch_dram.py``), instead of an
    ``AxiRam`` behind a delay queue of ``latency`` with wait states ``p_pause``.

    Returns
    -------
    dict
        ``mismatches`` (fragments with a texel or the sideband wrong), ``outputs``, ``fragments``, per map
        ``bursts_equal`` and ``model`` totals, ``bursts_equal`` (both), ``rtl_bytes``, ``model_bytes``, ``cycles``,
        ``fragments_per_clock``.
    """
    from rtl.texfetch import MAPS, TexFetch
    sim = simulator(sim)
    n = len(traces[MAPS[0]])
    models = {k: simulate(caches[k], layout, traces[k]) for k in MAPS}
    lay, olay = TexFetch.payloads(caches, layout, side_bits)
    side = np.arange(n) % (1 << side_bits)
    reqs = np.asarray(side, dtype=object) * (1 << lay["side"].offset)
    for k in MAPS:
        sub = pack_requests(request_layout(layout), traces[k])
        reqs = reqs + np.asarray(sub, dtype=object) * (1 << lay[k].offset)
    beats = sum(v.totals["beats"] + 40 * v.totals["bursts"] for v in models.values())
    if dram_ns is None:
        make, key = (lambda: TexFetch(caches, layout, side_bits)), (tuple(caches.items()), layout, side_bits, "fetch")
    else:
        from board.texture_port import TEXTURE_ADDR_BITS
        make = lambda: TexFetch(caches, layout, side_bits, addr_bits=TEXTURE_ADDR_BITS)     # noqa: E731
        key = (tuple(caches.items()), layout, side_bits, "fetch", "dram")
    got, build_seconds, seconds = _simulate_bench(
        make, key, [int(r) for r in reqs], layout.image(maps), layout.base, budget=400 + 6 * n + 3 * beats,
        **dict(latency=latency, p_valid=p_valid, p_ready=p_ready, p_pause=p_pause, seed=seed, sim=sim, tag=tag,
               dram_ns=dram_ns))
    vals = [int(v, 16) for v in got["outputs"]]
    bad = np.zeros(n, bool) if len(vals) == n else np.ones(n, bool)
    if len(vals) == n:
        for k in MAPS:
            tb = caches[k].texel_bits
            x, y = traces[k].corners()
            want = np.zeros((n, 4), np.int64)
            for s_ in range(len(maps)):
                rows = np.flatnonzero(traces[k].surface == s_)
                want[rows] = np.asarray(maps[s_], np.int64)[y[rows], x[rows]] & ((1 << tb) - 1)
            off = olay[k].offset
            rtl = np.array([[(v >> (off + tb * q)) & ((1 << tb) - 1) for q in range(4)] for v in vals], np.int64)
            bad |= np.any(rtl != want, axis=1)
        bad |= np.array([(v >> olay["side"].offset) & ((1 << side_bits) - 1) for v in vals]) != side
    ar = [(int(a), int(ln)) for a, ln in got["ar"]]
    per_map = {}
    for k in MAPS:
        surfaces = set(np.unique(traces[k].surface).tolist())
        mine = [b for b in ar if (layout.texel_at(b[0]) or (None,))[0] in surfaces]
        want_b = [(int(a), caches[k].beats_per_line - 1) for a in models[k].burst_addresses()]
        per_map[k] = {"bursts_equal": mine == want_b, "bursts": len(mine), "model": models[k].totals}
    model_bytes = sum(v.totals["memory_bytes"] for v in models.values())
    return {"mismatches": int(bad.sum()), "outputs": len(vals), "fragments": n, "maps": per_map,
            "bursts_equal": all(v["bursts_equal"] for v in per_map.values()) and len(ar) == sum(
                v["bursts"] for v in per_map.values()),
            "rtl_bytes": 4 * got["beats"], "model_bytes": model_bytes, "cycles": got["cycles"],
            "fragments_per_clock": n / max(got["cycles"], 1), "latency": latency, "simulator": sim,
            "mem_error": got.get("mem_error"), "dram_ns": dram_ns, "build_seconds": build_seconds, "seconds": seconds}
