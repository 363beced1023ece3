"""Co-simulation of the engine from the triangle with its bump map and color texture in external memory
(``rtl/engine.py`` with :attr:`~fxmodel.pipeline.engine.EngineParams.textures`: the pixel pipeline split around the
texture fetch, ``rtl/pixel_fetch.py``; the engine of the paper's Fig. 5, the maps of its sections 3.2 and 4).

The bench is :class:`cosim.texfetch.FetchBench` around the engine (its texture port ``tex``): both maps in
cocotbext-axi's ``AxiRam`` in the model's blocked layout (:meth:`~fxmodel.pipeline.engine.EngineParams.
texture_layout`, :meth:`fxmodel.units.texcache.Layout.image`) behind a delay queue of ``lat`` cycles on ``AR``
(one build serves every latency), random wait states on both read channels, random gaps in the triangle records and
backpressure on the fragments (``cosim.texfetch_tb``). Compared: every fragment out (``x, y``, the bytes, the
flags) with :meth:`~fxmodel.pipeline.engine.EngineParams.compute`, in order, none lost and none extra; each map's
``AR`` bursts (address and length, in order) with its cache's model
(:meth:`~fxmodel.pipeline.engine.EngineParams.texture_traffic`) and the bytes of the ``R`` beats with the model's
memory bytes. The clocks from reset to the last fragment give the clocks per fragment from triangles.
Environment: ``SIM`` (``icarus`` default, or ``verilator``).
"""

from __future__ import annotations

import json
import sys

import numpy as np

from fxmodel.units.texcache import CHOSEN_CACHE
from rtl.digest import params_key

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job
from .raster import pack, unpack
from .texfetch import MAX_LATENCY, FetchBench

__all__ = ["run_engine_fetch", "port_of", "sim_textures"]

def port_of(params, layout, address: int):
    """The cache (:meth:`~fxmodel.pipeline.engine.EngineParams.texture_ports`) whose surfaces hold ``address``."""
    where = layout.texel_at(address)
    if where is None:
        return None
    name, lv = layout.surfaces[where[0]][0]
    for port, m, parity in params.texture_ports():
        if m == name and (parity is None or parity == lv % 2):
            return port
    return None


def run_engine_fetch(params, records, *, latency: int = 1, p_valid: float = 1.0, p_ready: float = 1.0,
                     p_pause: float = 0.0, seed: int = 1, sim: str | None = None, tag: str = "") -> dict:
    """Draw triangle ``records`` (:class:`~fxmodel.units.raster.Records` or codes) through the engine with its maps
    in the memory model (``params`` an :class:`~fxmodel.pipeline.engine.EngineParams` with ``textures``, without
    ``rop``) and compare with the model.

    Returns
    -------
    dict
        ``mismatches`` (fragments that differ, missing or extra ones included), ``fragments``, ``outputs``,
        ``first`` (a few differing rows), per cache (``maps``: one per map, a trilinear map's even and odd
        levels apart, :meth:`~fxmodel.pipeline.engine.EngineParams.texture_ports`) ``bursts_equal``, ``bursts``,
        ``rtl_bursts`` (``(address, AXI length)`` in order) and the model's ``totals``,
        ``bursts_equal`` (every cache, none else), ``rtl_bytes``, ``model_bytes``, ``cycles`` (reset to the last
        fragment), ``clocks_per_fragment``, ``raster_clocks`` (the model's scan-converter clocks).
    """
    if params.textures is None or params.rop is not None:
        raise ValueError("run_engine_fetch: the engine must have textures set and no rop")
    if not 0 <= latency <= MAX_LATENCY:
        raise ValueError(f"latency={latency}: must be in 0..{MAX_LATENCY}")
    sim = simulator(sim)
    mat = records.matrix() if hasattr(records, "matrix") else np.asarray(records, dtype=np.int64)
    want, scan = params.compute(mat)
    traffic = params.texture_traffic(mat)
    layout, caches = params.texture_layout(), params.texture_caches()
    reqs = pack(params.raster.record, mat)
    from rtl.engine import Engine
    top, bdir, src = component_build("engine_fetch", params_key(params), sim,
                                     lambda: FetchBench(Engine(params), "tex"))
    job = job_folder(bdir, tag or "engine_fetch", {"key": repr(params)[:200], "sim": sim, "records": len(reqs),
                                                   "seed": seed, "p": [p_valid, p_ready, p_pause],
                                                   "latency": latency})
    beats = sum(t.totals["beats"] + 2 * (latency + 8) * t.totals["bursts"] for t in traffic.values())
    budget = 2000 + 4 * (int(scan.clocks.sum()) + len(want) + params.latency) + 3 * beats
    meta = {"requests": [format(r, "x") for r in reqs], "image": layout.image(params.texture_words()).hex(),
            "base": layout.base, "p_valid": p_valid, "p_ready": p_ready, "p_pause": p_pause, "seed": seed,
            "latency": latency, "max_cycles": int(budget / max(min(p_valid, p_ready, 1 - p_pause), 0.05)),
            "outputs": len(want)}
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.texfetch_tb", meta, "result.json")
    got = json.loads(out.read_text())
    remove_job(job)
    rtl = unpack(params.outputs, [int(v, 16) for v in got["outputs"]]) if got["outputs"] else \
        np.zeros((0, len(params.outputs)), np.int64)
    n = min(len(rtl), len(want))
    bad = np.flatnonzero(np.any(rtl[:n] != want[:n], axis=1))
    mismatches = len(bad) + abs(len(rtl) - len(want))
    first = [{"fragment": int(k), "rtl": rtl[k].tolist(), "model": want[k].tolist()} for k in bad[:5]]
    ar = [(int(a), int(ln)) for a, ln in got["ar"]]
    per_map = {}
    for name in caches:
        mine = [b for b in ar if port_of(params, layout, b[0]) == name]
        model = [(int(a), caches[name].beats_per_line - 1) for a in traffic[name].burst_addresses()]
        per_map[name] = {"bursts_equal": mine == model, "bursts": len(mine), "totals": traffic[name].totals,
                         "rtl_bursts": mine}
    model_bytes = sum(t.totals["memory_bytes"] for t in traffic.values())
    return {"mismatches": int(mismatches), "fragments": len(want), "outputs": len(rtl), "first": first,
            "maps": per_map, "rtl": rtl,
            "bursts_equal": all(v["bursts_equal"] for v in per_map.values())
            and len(ar) == sum(v["bursts"] for v in per_map.values()),
            "rtl_bytes": 4 * got["beats"], "model_bytes": model_bytes, "cycles": got["cycles"],
            "clocks_per_fragment": got["cycles"] / max(len(want), 1), "raster_clocks": int(scan.clocks.sum()),
            "latency": latency, "simulator": sim, "build_seconds": build_seconds, "seconds": seconds}


def sim_textures(args, tframe, report: dict, out_dir, t0: float) -> int:
    """``bumpmap sim --textures external``: the scene's triangles through the engine with its maps in the memory
    model (latency ``args.latency``, wait states ``args.wait_states``), every fragment and each map's bursts
    compared with the model; ``rtl.png`` and ``report.json`` in ``out_dir``; exit 1 on any difference."""
    import dataclasses
    import time

    from host.atomic import atomic_json
    from host.images import disagreement_row, summary_table, verdict_row
    from host.render import save_png, tell

    name = tframe.frame.scene.name
    params = dataclasses.replace(tframe.params, textures=CHOSEN_CACHE)
    pause = args.wait_states
    print(f"{name}: bump map and color texture behind the texel caches in an AXI4 memory model (latency "
          f"{args.latency}, wait states {pause:g})")
    res = run_engine_fetch(params, tframe.records, latency=args.latency, p_pause=pause,
                           p_valid=0.9 if pause else 1.0, p_ready=0.8 if pause else 1.0, seed=args.seed,
                           sim=args.sim, tag=f"scene_{out_dir.name}")
    wall = time.perf_counter() - t0
    rtl = res.pop("rtl")
    if len(rtl) == len(tframe.out):
        col = {p.name: rtl[:, i] for i, p in enumerate(params.outputs)}
        save_png(out_dir / "rtl.png", tframe.image(np.stack([col[c] for c in "rgb"], 1).astype(np.uint8)))
    ok = not res["mismatches"] and res["bursts_equal"] and res["rtl_bytes"] == res["model_bytes"]
    report.update({"simulator": args.sim, "preset": args.preset, "textures": "external",
                   "memory_latency": args.latency, "memory_wait_states": pause, "mismatches": res["mismatches"],
                   "first_mismatches": res["first"], "texture_bursts_equal_model": res["bursts_equal"],
                   "texture_bytes": {"rtl": res["rtl_bytes"], "model": res["model_bytes"]},
                   "texture_misses": {k: v["totals"]["misses"] for k, v in res["maps"].items()},
                   "rtl_cycles": res["cycles"], "rtl_clocks_per_fragment": round(res["clocks_per_fragment"], 4),
                   "rtl_seconds": res["seconds"], "build_seconds": res["build_seconds"],
                   "wall_seconds": round(wall, 2)})
    atomic_json(out_dir / "report.json", report)
    print(summary_table([
        ("scene", name), ("input", f"{report['triangles']} triangles -> {report['fragments']:,} fragments"),
        ("simulator", args.sim), ("mismatches", f"{res['mismatches']} fragments"),
        ("texture traffic", f"{res['rtl_bytes']:,} B in {sum(v['bursts'] for v in res['maps'].values())} bursts "
                            f"(model {res['model_bytes']:,} B; bursts {'equal' if res['bursts_equal'] else 'DIFFER'})"),
        ("clocks / fragment", f"{res['clocks_per_fragment']:.3f} ({res['cycles']:,} cycles, scan converter "
                              f"{res['raster_clocks']:,})"),
        disagreement_row(report), verdict_row(report),
        ("wall seconds", f"{wall:.1f}"), ("output", str(out_dir))]))
    if not ok:
        print(f"RTL differs from the model: {res['mismatches']} fragments, bursts equal {res['bursts_equal']}, "
              f"bytes {res['rtl_bytes']} / {res['model_bytes']}; first: {res['first']}", file=sys.stderr)
        return 1
    print("  RTL == model on every fragment, texture bursts == model")
    return tell(report, name)
