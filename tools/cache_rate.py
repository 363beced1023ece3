"""The texture fetch's rate under memory latency, measured in co-simulation on the shipped scenes' fragments.

``bumpmap cache-rate [--scenes ...] [--fragments N] [--latencies 0 1 20 40] [--record JSON]``

Each scene is drawn from triangles by the bit-exact engine with its maps in external memory
(:attr:`fxmodel.pipeline.engine.EngineParams.textures`): the bump-map and color-texture footprints of its
fragments in drawing order (the first ``--fragments``: the cold start, where the misses are) go through the
texture fetch (``rtl/texfetch.py``: one decoupled cache per map, ``rtl/texcache_decoupled.py``, on one AXI4 read
port; the chosen cache of ``docs/texcache.md`` unless ``--block``, ``--sets``, ``--ways``, ``--lookup-depth``,
``--misses`` say otherwise), both maps in cocotbext-axi's ``AxiRam`` behind a delay queue of ``L`` cycles on
``AR`` (:mod:`cosim.texfetch`), a fragment offered every clock and the output always ready. Per scene and latency
the record keeps the clocks, the fragments per clock and their ratio to the first latency's (Igehy, Eldridge &
Proudfoot report at least 97 % of the zero-latency rate with a FIFO deep enough), the mismatches (both maps'
texels and the sideband against the maps), whether every ``AR`` burst of each map equals its cache's model
(:meth:`~fxmodel.pipeline.engine.EngineParams.texture_traffic`'s), and each map's misses. Exit 1 on a mismatch or a
burst that differs. Environment: ``SIM`` (``verilator`` is much faster than the default Icarus).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np

from fxmodel.core.paths import shipped_scenes
from fxmodel.pipeline.engine import TEXTURE_MAPS as MAPS
from fxmodel.units.texcache import TexCacheParams, footprints

from .record import add_record_option, machine, write_if_asked

#: The cache's parameters the commands take as options and their records keep.
CACHE_FIELDS = ("block", "sets", "ways", "lookup_depth", "misses")

__all__ = ["add_arguments", "run", "measure", "table", "cache_and_simulator", "cache_fields", "measure_scenes",
           "CACHE_FIELDS"]


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scenes", nargs="+", default=shipped_scenes(),
                    help="scene names or .toml paths (default: every shipped scene)")
    ap.add_argument("--size", type=int, help="draw the scenes at this size (default: each scene's own)")
    ap.add_argument("--fragments", type=int, default=4000, help="the first N fragments of each scene (default 4000)")
    ap.add_argument("--latencies", nargs="+", type=int, default=[0, 1, 20, 40],
                    help="memory latencies in clocks added on AR (0 first: the reference)")
    ap.add_argument("--block", type=int, default=8, help="line edge B in texels (default: the chosen cache's 8)")
    ap.add_argument("--sets", type=int, default=32, help="sets (default: the chosen cache's 32)")
    ap.add_argument("--ways", type=int, default=4, help="ways (default: the chosen cache's 4)")
    ap.add_argument("--lookup-depth", type=int, default=TexCacheParams.lookup_depth,
                    help="lookup FIFO entries between the tag and data stages")
    ap.add_argument("--misses", type=int, default=TexCacheParams.misses, help="outstanding lines (fill buffer)")
    add_record_option(ap, "the rates")


def fetch_inputs(scene: str, params: TexCacheParams, fragments: int, size=None) -> tuple:
    """``(engine, traces, words, data)`` of a scene's first ``fragments`` fragments: the engine with its maps
    external (:attr:`fxmodel.pipeline.engine.EngineParams.textures` = ``params``), per map the footprints on its
    surface of :meth:`~fxmodel.pipeline.engine.EngineParams.texture_layout`, the surfaces' texel words, and the
    scene's name, size and fragment counts."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    tframe = from_triangles(prepare(scene_path(scene), size=size, allow_clamp=True))
    eng = dataclasses.replace(tframe.params, textures=params)
    p = eng.pipeline
    codes = np.stack([tframe.scan.codes[q.name] for q in p.inputs], axis=1)[:fragments]
    st = p.trace(codes)["st"]
    traces = {k: footprints(getattr(p, k), st[:, 2 * j], st[:, 2 * j + 1], j) for j, k in enumerate(MAPS)}
    words = [np.array(getattr(p, k).words, np.int64).reshape(getattr(p, k).texels.shape[1:3]) for k in MAPS]
    sc = tframe.frame.scene
    info = {"scene": sc.name, "source": str(scene), "size": f"{sc.width}x{sc.height}",
            "frame_fragments": len(tframe.scan), "fragments": len(codes)}
    return eng, traces, words, info


def measure(scene: str, params: TexCacheParams, latencies, fragments: int, size=None) -> dict:
    """One scene's rates through the texture fetch: per latency the co-simulation's figures (module docstring)."""
    from cosim.texfetch import run_fetch
    eng, traces, words, out = fetch_inputs(scene, params, fragments, size)
    rows = {}
    for lat in latencies:
        r = run_fetch(eng.texture_caches(), eng.texture_layout(), words, traces, latency=lat,
                      tag=f"rate_{out['scene']}_{lat}")
        rows[str(lat)] = {k: r[k] for k in ("cycles", "fragments_per_clock", "mismatches", "bursts_equal",
                                            "rtl_bytes", "model_bytes")}
        rows[str(lat)]["misses"] = {k: v["model"]["misses"] for k, v in r["maps"].items()}
        print(f"{out['scene']} L={lat}: {r['fragments_per_clock']:.4f} fragments/clock, {r['mismatches']} "
              f"mismatches, bursts equal {r['bursts_equal']}", file=sys.stderr)
    ref = rows[str(latencies[0])]["fragments_per_clock"]
    for v in rows.values():
        v["of_reference"] = v["fragments_per_clock"] / ref if ref else None
    out["rates"] = rows
    return out


def table(record: dict) -> str:
    """Markdown: per scene and latency the fragments per clock and their share of the first latency's, the
    misses of each map, the mismatches and whether every burst was the model's."""
    res = record["result"]
    lats = res["latencies"]
    head = ["scene", "fragments", "misses (bump, color)", *(f"L = {lat}" for lat in lats), "mismatches",
            "bursts = model"]
    rows = []
    for s in res["scenes"]:
        r = s["rates"]
        miss = r[str(lats[0])]["misses"]
        cells = [f"{r[str(lat)]['fragments_per_clock']:.3f}" + (
            f" ({100 * r[str(lat)]['of_reference']:.1f} %)" if lat != lats[0] else "") for lat in lats]
        rows.append([f"`{s['scene']}`", s["fragments"], f"{miss['bump_map']}, {miss['texture']}", *cells,
                     sum(x["mismatches"] for x in r.values()),
                     "yes" if all(x["bursts_equal"] and x["rtl_bytes"] == x["model_bytes"] for x in r.values())
                     else "**no**"])
    c = res["cache"]
    lines = ["| " + " | ".join(str(h) for h in head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    return ("\n".join(lines) + f"\n\nFragments per clock through the texture fetch (share of latency {lats[0]});"
            f" each map's cache: {c['block']} x {c['block']}-texel lines, {c['sets']} sets, {c['ways']} ways, "
            f"lookup FIFO {c['lookup_depth']}, {c['misses']} outstanding lines; the first {res['fragments']} "
            f"fragments of each scene in drawing order; simulator {res['simulator']}.\n")


def cache_and_simulator(args: argparse.Namespace) -> tuple:
    """The texel cache of the command's options (``--block``, ``--sets``, ``--ways``, ``--lookup-depth``,
    ``--misses``) and the simulator; ``ValueError`` or ``RuntimeError`` naming what was wrong. Shared with
    ``bumpmap engine-rate``."""
    from cosim.harness import simulator
    return TexCacheParams(**{k: getattr(args, k) for k in CACHE_FIELDS}), simulator()


def cache_fields(params: TexCacheParams) -> dict:
    """The cache's parameters as a record keeps them."""
    return {k: getattr(params, k) for k in CACHE_FIELDS}


def measure_scenes(args: argparse.Namespace, measure_one, table_of, extra: dict):
    """The body both rate commands share: the cache and simulator of ``args`` (:func:`cache_and_simulator`),
    ``measure_one(scene, params)`` on each of ``args.scenes``, the table ``table_of`` printed and the record
    written if asked. Returns the result, or ``None`` after printing an error that names the bad input."""
    try:
        params, sim = cache_and_simulator(args)
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None
    before = machine()
    scenes = []
    try:
        for s in args.scenes:
            scenes.append(measure_one(s, params))
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None
    result = {"latencies": args.latencies, **extra, "simulator": sim, "cache": cache_fields(params),
              "scenes": scenes}
    print(table_of({"result": result}))
    write_if_asked(args, result, before)
    return result


def run(args: argparse.Namespace) -> int:
    if args.fragments < 1 or not args.latencies or min(args.latencies) < 0:
        print("error: --fragments must be positive and --latencies non-negative", file=sys.stderr)
        return 2
    result = measure_scenes(args, lambda s, params: measure(s, params, args.latencies, args.fragments, args.size),
                            table, {"fragments": args.fragments})
    if result is None:
        return 2
    bad = [s["scene"] for s in result["scenes"] for r in s["rates"].values()
           if r["mismatches"] or not r["bursts_equal"] or r["rtl_bytes"] != r["model_bytes"]]
    return 1 if bad else 0
