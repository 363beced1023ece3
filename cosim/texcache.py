"""Co-simulation harness of the texel cache (``rtl/texcache.py``): footprint requests through the RTL, the map in
cocotbext-axi's ``AxiRam`` in the model's blocked layout, and the outputs (the four texels of each lookup) and the
memory traffic (every ``AR`` burst's address and length, the ``R`` beats) compared with
:func:`fxmodel.units.texcache.simulate` exactly. Random request gaps, output backpressure and wait states on the
read channels (``AxiRam``'s pause generators). Environment: ``SIM`` (``icarus`` default, or ``verilator``).
"""

from __future__ import annotations

import json

import numpy as np

from fxmodel.units.texcache import TexCacheParams, Trace, simulate
from rtl.digest import params_key
from rtl.texcache import TexCache

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job

__all__ = ["run", "memory_image", "pack_requests"]


def memory_image(cache: TexCache, words: np.ndarray) -> bytes:
    """The map's texel words ``(height, width)`` at their layout addresses (little-endian, 4 bytes a texel),
    from the layout's base to its end; padding zero."""
    L = cache.layout
    h, w = words.shape
    img = bytearray(L.size_bytes)
    yy, xx = np.mgrid[0:h, 0:w]
    addr = L.address(np.zeros(xx.size, np.int64), xx.ravel(), yy.ravel()) - L.base
    for a, v in zip(addr.tolist(), words.ravel().tolist()):
        img[a:a + 4] = int(v).to_bytes(4, "little")
    return bytes(img)


def pack_requests(cache: TexCache, trace: Trace) -> list[int]:
    """Request words: ``x0 | x1 | y0 | y1``, :attr:`TexCache.coord_bits` each, ``x0`` in the low bits."""
    cb = cache.coord_bits
    return [int(a) | int(b) << cb | int(c) << 2 * cb | int(d) << 3 * cb
            for a, b, c, d in zip(trace.x0, trace.x1, trace.y0, trace.y1)]


def _build(cache: TexCache, key, sim: str):
    return component_build("texcache", params_key(key), sim, lambda: cache)


def run(params: TexCacheParams, words: np.ndarray, trace: Trace, *, base: int = 0, p_valid: float = 1.0,
        p_ready: float = 1.0, p_pause: float = 0.0, seed: int = 1, sim: str | None = None, tag: str = "") -> dict:
    """Look up ``trace`` (one surface) in the RTL cache over the map ``words`` ``(height, width)`` and compare.

    Returns
    -------
    dict
        ``mismatches`` (lookups whose four texels differ from the map's), ``rtl_bursts`` and ``model_bursts``
        (``(address, AXI length)`` of every ``AR`` transfer, in order), ``bursts_equal``, ``rtl_bytes`` and
        ``model_bytes`` (4 per ``R`` beat; the model's ``memory_bytes``), ``model`` (its totals), ``cycles``.
    """
    sim = simulator(sim)
    words = np.asarray(words, dtype=np.int64)
    h, w = words.shape
    cache = TexCache(params, h, w, base)
    res_model = simulate(params, cache.layout, trace)
    key = (params, h, w, base)
    top, bdir, src = _build(cache, key, sim)
    job = job_folder(bdir, tag or "texcache", {"key": repr(key), "sim": sim, "lookups": len(trace), "seed": seed,
                                               "p": [p_valid, p_ready, p_pause]})
    reqs = pack_requests(cache, trace)
    meta = {"requests": [format(r, "x") for r in reqs], "image": memory_image(cache, words).hex(), "base": base,
            "p_valid": p_valid, "p_ready": p_ready, "p_pause": p_pause, "seed": seed,
            "max_cycles": 200 + len(reqs) * 12 + int(res_model.totals["beats"] * 3 / max(1 - p_pause, 0.05))
            * 4 + 2000}
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.texcache_tb", meta, "result.json")
    got = json.loads(out.read_text())
    remove_job(job)
    x, y = trace.corners()
    tb = params.texel_bits
    want = words[y, x] & ((1 << tb) - 1)
    rtl = np.array([[(int(v, 16) >> (tb * q)) & ((1 << tb) - 1) for q in range(4)] for v in got["outputs"]],
                   dtype=np.int64).reshape(-1, 4)
    bad = np.flatnonzero(np.any(rtl != want, axis=1)) if rtl.shape == want.shape else np.arange(len(want))
    bursts = [(int(a), int(n)) for a, n in got["ar"]]
    model_bursts = [(int(a), params.beats_per_line - 1) for a in res_model.burst_addresses()]
    return {"mismatches": int(len(bad)), "outputs": len(rtl), "lookups": len(trace),
            "bursts_equal": bursts == model_bursts, "rtl_bursts": bursts, "model_bursts": model_bursts,
            "rtl_bytes": 4 * got["beats"], "model_bytes": res_model.totals["memory_bytes"],
            "model": res_model.totals, "cycles": got["cycles"], "simulator": sim,
            "build_seconds": build_seconds, "seconds": seconds}
