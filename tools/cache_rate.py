"""The decoupled texel cache's rate under memory latency, measured in co-simulation on the shipped scenes' lookups.

``bumpmap cache-rate [--scenes ...] [--fragments N] [--latencies 0 1 20 40] [--record JSON]``

Each scene is drawn from triangles by the bit-exact engine (:func:`tools.cache_sweep.scene_traces`): its bump-map
and color-texture lookups in drawing order (the first ``--fragments`` fragments: the cold start, where the misses
are). Each map's lookups go through its own decoupled cache (``rtl/texcache_decoupled.py``; the chosen cache of
``docs/texcache.md`` unless ``--block``, ``--sets``, ``--ways``, ``--lookup-depth``, ``--misses`` say otherwise)
with the map in cocotbext-axi's ``AxiRam`` behind a delay queue of ``L`` cycles on ``AR``
(:mod:`cosim.texfetch`), a lookup offered every clock and the output always ready. Per scene, map and latency the
record keeps the clocks, the lookups per clock and their ratio to latency 0 (Igehy, Eldridge & Proudfoot report
at least 97 % with a FIFO deep enough), the mismatches (texels and sideband against the map), whether every ``AR``
burst equals the model's (:func:`fxmodel.units.texcache.simulate`), and the model's misses. A pixel needs one lookup
in each map a clock, so the slower map's rate bounds the pixel rate the textures allow the engine. Exit 1 on a
mismatch or a burst that differs. Environment: ``SIM`` (``verilator`` is much faster than the default Icarus).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from fxmodel.units.texcache import Layout, TexCacheParams

from .cache_sweep import DEFAULT_SCENES, MAPS, scene_traces
from .record import add_record_option, machine, write_if_asked

__all__ = ["add_arguments", "run", "measure", "table"]


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), help="scene names or .toml paths")
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


def measure(scene: str, params: TexCacheParams, latencies, fragments: int, size=None) -> dict:
    """One scene's rates: per map and latency the co-simulation's figures (module docstring)."""
    import dataclasses

    from cosim.texfetch import run as cosim_run
    data = scene_traces(scene, size)
    out = {"scene": data["name"], "size": data["size"], "fragments": min(fragments, data["fragments"]), "maps": {}}
    for m in MAPS:
        sampler, trace = data["traces"][m]
        n = min(fragments, len(trace))
        trace = type(trace)(*(getattr(trace, f)[:n] for f in ("fragment", "surface", "x0", "x1", "y0", "y1")))
        h, w = sampler.texels.shape[1:3]
        p = dataclasses.replace(params, texel_bits=sampler.word_bits)
        layout = Layout((((m, 0), h, w),), p.block, p.texel_bytes)
        words = np.array(sampler.words, dtype=np.int64).reshape(h, w)
        rows = {}
        for lat in latencies:
            r = cosim_run(p, layout, [words], trace, latency=lat, tag=f"rate_{m}_{lat}")
            rows[str(lat)] = {k: r[k] for k in ("cycles", "lookups_per_clock", "mismatches", "bursts_equal",
                                                "rtl_bytes", "model_bytes")}
            rows[str(lat)]["misses"] = r["model"]["misses"]
            print(f"{data['name']} {m} L={lat}: {r['lookups_per_clock']:.4f} lookups/clock, "
                  f"{r['mismatches']} mismatches, bursts equal {r['bursts_equal']}", file=sys.stderr)
        ref = rows[str(latencies[0])]["lookups_per_clock"]
        for v in rows.values():
            v["of_reference"] = v["lookups_per_clock"] / ref if ref else None
        out["maps"][m] = {"lookups": n, "map": [h, w], "rates": rows}
    return out


def table(record: dict) -> str:
    """Markdown: per scene, map and latency the lookups per clock, the share of latency 0, misses, exactness."""
    res = record["result"]
    lats = res["latencies"]
    head = ["scene", "map", "lookups", "misses", *(f"L = {lat}" for lat in lats), "mismatches", "bursts = model"]
    rows = []
    for s in res["scenes"]:
        for m, v in s["maps"].items():
            r = v["rates"]
            cells = [f"{r[str(lat)]['lookups_per_clock']:.3f}" + (
                f" ({100 * r[str(lat)]['of_reference']:.1f} %)" if lat != lats[0] else "") for lat in lats]
            rows.append([f"`{s['scene']}`", m, v["lookups"], r[str(lats[0])]["misses"], *cells,
                         sum(x["mismatches"] for x in r.values()),
                         "yes" if all(x["bursts_equal"] and x["rtl_bytes"] == x["model_bytes"] for x in r.values())
                         else "**no**"])
    c = res["cache"]
    lines = ["| " + " | ".join(head) + " |", "|---|---|" + "---:|" * (len(head) - 2)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    return ("\n".join(lines) + f"\n\nLookups per clock (share of latency {lats[0]}); cache: {c['block']} x "
            f"{c['block']}-texel lines, {c['sets']} sets, {c['ways']} ways, lookup FIFO {c['lookup_depth']}, "
            f"{c['misses']} outstanding lines; the first {res['fragments']} fragments of each scene; "
            f"simulator {res['simulator']}.\n")


def run(args: argparse.Namespace) -> int:
    from cosim.harness import simulator
    if args.fragments < 1 or not args.latencies or min(args.latencies) < 0:
        print("error: --fragments must be positive and --latencies non-negative", file=sys.stderr)
        return 2
    try:
        params = TexCacheParams(block=args.block, sets=args.sets, ways=args.ways, lookup_depth=args.lookup_depth,
                                misses=args.misses)
        sim = simulator()
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    before = machine()
    scenes = []
    try:
        for s in args.scenes:
            scenes.append(measure(s, params, args.latencies, args.fragments, args.size))
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    result = {"latencies": args.latencies, "fragments": args.fragments, "simulator": sim,
              "cache": {k: getattr(params, k) for k in ("block", "sets", "ways", "lookup_depth", "misses")},
              "scenes": scenes}
    record = {"result": result}
    print(table(record))
    write_if_asked(args, result, before)
    bad = [(s["scene"], m) for s in scenes for m, v in s["maps"].items() for r in v["rates"].values()
           if r["mismatches"] or not r["bursts_equal"] or r["rtl_bytes"] != r["model_bytes"]]
    return 1 if bad else 0
