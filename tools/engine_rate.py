"""The engine from the triangle with its maps in external memory, co-simulated on the shipped scenes: clocks per
fragment under memory latency, every fragment and every burst checked against the model.

``bumpmap engine-rate [--scenes ...] [--size N] [--latencies 0 1 20 40] [--wait-states P] [--record JSON]``

Each scene is drawn from its triangle records by the RTL engine (``rtl/engine.py`` with
:attr:`~fxmodel.pipeline.engine.EngineParams.textures`: the pixel pipeline split around the texture fetch,
``rtl/pixel_fetch.py``; the chosen cache of ``docs/texcache.md`` unless ``--block``, ``--sets``, ``--ways``,
``--lookup-depth``, ``--misses`` say otherwise), both maps in cocotbext-axi's ``AxiRam`` in the model's layout
behind ``L`` cycles of latency on ``AR`` (:mod:`cosim.engine_fetch`). Per scene and latency, with the records
offered every clock and the fragments always taken: the clocks from reset to the last fragment, per fragment, and
their ratio to the first latency's (the paper's engine makes one fragment a clock, section 4; Igehy, Eldridge &
Proudfoot report at least 97 % of the zero-latency rate with a FIFO deep enough). Then, at every latency but the
first, once more under random wait states (probability ``--wait-states`` on both read channels), gaps in the
records and backpressure on the fragments. Every run compares each fragment (``x, y``, the bytes, the flags) with
the model, each map's ``AR`` bursts with its cache's model and the bytes read with the model's. Exit 1 on a
mismatch or a burst that differs. Environment: ``SIM`` (``verilator``: much faster than the default Icarus).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

from fxmodel.units.texcache import TexCacheParams

from .cache_rate import measure_scenes
from .record import add_record_option

__all__ = ["add_arguments", "run", "measure", "table", "SHIPPED"]

#: The shipped scenes the engine draws exactly with the default preset (the grazing floor needs its inputs
#: saturated: ``docs/texcache.md``).
SHIPPED = ("tin-plane", "sphere", "tin-sphere", "berlin-wall")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--scenes", nargs="+", default=list(SHIPPED), metavar="SCENE[:PRESET]",
                    help="scene names or .toml paths, each with an optional pipeline preset after a colon (e.g. "
                         "berlin-wall:mip, grazing-floor:grazing-floor-mip: the color texture MIP-mapped, its levels "
                         "in memory); default: " + ", ".join(SHIPPED) + " with the default preset")
    ap.add_argument("--size", type=int, help="draw the scenes at this size (default: each scene's own)")
    ap.add_argument("--latencies", nargs="+", type=int, default=[0, 1, 20, 40],
                    help="memory latencies in clocks added on AR (the first: the reference)")
    ap.add_argument("--wait-states", type=float, default=0.2, metavar="P",
                    help="probability of a wait state on each read channel in the second run of each latency "
                         "(with gaps and backpressure; default %(default)s; 0: no second run)")
    from fxmodel.units.texcache import CHOSEN_CACHE as C
    ap.add_argument("--block", type=int, default=C.block, help="line edge B in texels (default: the chosen cache's "
                    "%(default)s)")
    ap.add_argument("--sets", type=int, default=C.sets, help="sets (default: the chosen cache's %(default)s)")
    ap.add_argument("--ways", type=int, default=C.ways, help="ways (default: the chosen cache's %(default)s)")
    ap.add_argument("--lookup-depth", type=int, default=C.lookup_depth,
                    help="lookup FIFO entries between the tag and data stages (default %(default)s)")
    ap.add_argument("--misses", type=int, default=C.misses, help="outstanding lines (fill buffer; default "
                    "%(default)s)")
    add_record_option(ap, "the clocks per fragment")


def engine_inputs(scene: str, params: TexCacheParams, size=None) -> tuple:
    """``(engine, records, info)``: the scene's engine (``SCENE[:PRESET]``) with its maps external, its triangle
    records and its name (with the preset, when one is given), size and counts."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    name, _, preset = scene.partition(":")
    tframe = from_triangles(prepare(scene_path(name), size=size, preset=preset or "default"))
    eng = dataclasses.replace(tframe.params, textures=params)
    sc = tframe.frame.scene
    return eng, tframe.records, {"scene": sc.name + (f":{preset}" if preset else ""), "source": str(scene),
                                 "size": f"{sc.width}x{sc.height}", "triangles": len(tframe.records),
                                 "fragments": len(tframe.scan), "caches": [q[0] for q in eng.texture_ports()]}


_KEEP = ("cycles", "clocks_per_fragment", "mismatches", "bursts_equal", "rtl_bytes", "model_bytes")


def measure(scene: str, params: TexCacheParams, latencies, wait_states: float, size=None) -> dict:
    """One scene's runs (module docstring): ``rates`` per latency, ``stalled`` per latency but the first."""
    from cosim.engine_fetch import run_engine_fetch
    eng, records, out = engine_inputs(scene, params, size)
    rows, stalled = {}, {}
    for lat in latencies:
        r = run_engine_fetch(eng, records, latency=lat, tag=f"rate_{out['scene']}_{lat}")
        rows[str(lat)] = {k: r[k] for k in _KEEP}
        rows[str(lat)]["misses"] = {k: v["totals"]["misses"] for k, v in r["maps"].items()}
        rows[str(lat)]["raster_clocks"] = r["raster_clocks"]
        print(f"{out['scene']} L={lat}: {r['clocks_per_fragment']:.4f} clocks/fragment, {r['mismatches']} "
              f"mismatches, bursts equal {r['bursts_equal']}", file=sys.stderr)
        if wait_states > 0 and lat != latencies[0]:
            s = run_engine_fetch(eng, records, latency=lat, p_valid=0.9, p_ready=0.8, p_pause=wait_states,
                                 seed=lat, tag=f"stall_{out['scene']}_{lat}")
            stalled[str(lat)] = {k: s[k] for k in _KEEP}
            print(f"{out['scene']} L={lat} with wait states: {s['mismatches']} mismatches, bursts equal "
                  f"{s['bursts_equal']}", file=sys.stderr)
    ref = rows[str(latencies[0])]["clocks_per_fragment"]
    for v in rows.values():
        v["rate_of_reference"] = ref / v["clocks_per_fragment"] if v["clocks_per_fragment"] else None
    out["rates"], out["stalled"] = rows, stalled
    return out


def _ok(r: dict) -> bool:
    return not r["mismatches"] and r["bursts_equal"] and r["rtl_bytes"] == r["model_bytes"]


def table(record: dict) -> str:
    """Markdown: per scene and latency the clocks per fragment and the rate's share of the first latency's, the
    misses of each map, the bytes read per fragment, the mismatches of every run and whether every burst was the
    model's."""
    res = record["result"]
    lats = res["latencies"]
    head = ["scene", "fragments", "misses (bump, color; color even, odd levels)", "bytes / fragment",
            *(f"L = {lat}" for lat in lats), "mismatches", "bursts = model"]
    rows = []
    for s in res["scenes"]:
        r, st = s["rates"], s["stalled"]
        first = r[str(lats[0])]
        cells = [f"{r[str(lat)]['clocks_per_fragment']:.3f}" + (
            f" ({100 * r[str(lat)]['rate_of_reference']:.1f} %)" if lat != lats[0] else "") for lat in lats]
        runs = list(r.values()) + list(st.values())
        rows.append([f"`{s['scene']}`", s["fragments"], ", ".join(str(v) for v in first["misses"].values()),
                     f"{first['model_bytes'] / max(s['fragments'], 1):.2f}", *cells,
                     sum(x["mismatches"] for x in runs), "yes" if all(_ok(x) for x in runs) else "**no**"])
    c = res["cache"]
    lines = ["| " + " | ".join(str(h) for h in head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    stall = (f"; the mismatches and bursts also of a second run at every latency but {lats[0]} with wait states "
             f"(probability {res['wait_states']} on both read channels), gaps in the records and backpressure on "
             f"the fragments" if res["wait_states"] else "")
    return ("\n".join(lines) + f"\n\nClocks per fragment of the engine from triangles, records offered every "
            f"clock and fragments always taken (in parentheses the rate's share of latency {lats[0]}'s); each "
            f"cache (one per map, a MIP-mapped map's even and odd levels apart): {c['block']} x {c['block']}-texel "
            f"lines, {c['sets']} sets, {c['ways']} ways, lookup "
            f"FIFO {c['lookup_depth']}, {c['misses']} outstanding lines; whole frames{stall}; simulator "
            f"{res['simulator']}.\n")


def run(args: argparse.Namespace) -> int:
    if not args.latencies or min(args.latencies) < 0 or not 0 <= args.wait_states < 1:
        print("error: --latencies must be non-negative and --wait-states in [0, 1)", file=sys.stderr)
        return 2
    result = measure_scenes(args, lambda s, params: measure(s, params, args.latencies, args.wait_states, args.size),
                            table, {"wait_states": args.wait_states, "size": args.size})
    if result is None:
        return 2
    bad = [s["scene"] for s in result["scenes"] for r in list(s["rates"].values()) + list(s["stalled"].values())
           if not _ok(r)]
    return 1 if bad else 0
