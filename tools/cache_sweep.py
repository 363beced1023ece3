"""Size the texel cache in the model before any RTL: sweep it on the shipped scenes and the grazing floor.

``bumpmap cache-sweep [--scenes ...] [--sizes-kb 1 2 ...] [--blocks 2 4 8] [--ways 1 2 4 8] [--record JSON]
[--picture PNG]``

Each scene is drawn from triangles by the bit-exact engine (:func:`host.render.from_triangles`; scenes that a preset
cannot draw exactly, such as the grazing floor, with their fragment inputs saturated, ``allow_clamp``): the scan
converter's fragments in drawing order, and for each the texel footprints the pixel pipeline's bump-map and
color-texture lookups read (:func:`fxmodel.units.texcache.footprints` of the samplers at the perspective unit's
``s, t`` and ``sc, tc``). Each map has its own cache (the two samplers look up in the same clock), so a scene's memory
traffic is the sum of two caches' fills. For every cache configuration (data size per cache, block ``B`` and ways;
LRU, XOR set index, 32-bit AXI4 bus) the record keeps the hit rate (per line access), the lookups that hit entirely
and the memory bytes per fragment; then the replacement and set-index variants at the chosen block and ways.

The SDRAM time a fragment costs (:func:`memory_ns`) is its bytes at the peak bandwidth (``--sdram-mb-s``, 200 MB/s:
one x16 SDR chip at 100 MHz) plus ``--burst-overhead-ns`` per burst (each line fill opens a row at random), so
short lines pay for their many bursts. The chosen cache (:func:`choose`): the smallest data size and then the
fewest ways and smallest block whose SDRAM time per fragment is within ``--slack`` of the best configuration
swept on every scene. From it the record states the pixel rate a board sustains per scene (textures alone; and,
bytes only, with the depth test's and frame buffer's own traffic sharing the memory), and the block RAM of the
reflectance cubes (64-texel faces, banked by texel parity), the caches and the rest of the engine against the
ECP5-85's 208 DP16KD (:mod:`fxmodel.core.cost`).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import shlex
import sys
from pathlib import Path

from fxmodel.core.cost import bram_blocks
from fxmodel.core.paths import ROOT, shipped_scenes
from fxmodel.units.texcache import Layout, TexCacheParams, simulate
from host.atomic import atomic_write_bytes
from tools.record import machine

#: Scenes swept by default: every shipped scene and the grazing floor (a regression scene of ``tests/scenes``).
DEFAULT_SCENES = tuple(shipped_scenes()) + (str(ROOT / "tests/scenes/grazing-floor.toml"),)
MAPS = ("bump_map", "texture")
ECP5_85_DP16KD = 208


def scene_traces(scene: str, size=None, preset: str = "default") -> dict:
    """One scene's lookups with the pipeline ``preset``: per cache (``traces``, the engine's
    :meth:`~fxmodel.pipeline.engine.EngineParams.texture_ports`: one per map, a trilinear map's even and odd levels
    apart) its :class:`~fxmodel.units.texcache.Trace` (the engine's
    :meth:`~fxmodel.pipeline.engine.EngineParams.texture_lookups`: with MIP mapping the LOD unit's levels, only
    those a lookup needs), the layout's surfaces (each map's levels), each cache's texel bits, and the frame's
    figures (fragments, clocks, the depth test's and frame buffer's bytes per fragment, the engine's other
    memories)."""
    from host.render import from_triangles, prepare
    from host.scene import scene_path
    frame = prepare(scene_path(scene), size=size, preset=preset, allow_clamp=True)
    tframe = from_triangles(frame)
    p = frame.params
    engine = dataclasses.replace(tframe.params, textures=TexCacheParams())
    traces = engine.texture_lookups(tframe.records)
    n = len(tframe.out)
    mem = tframe.vis.stats["memory"]
    maps = p.bump_map.memories() + p.texture.memories()
    others = [m for m in tframe.params.memories() if m not in maps]
    cubes = p.diffuse.memories() + p.specular.memories()
    return {"traces": traces, "surfaces": engine.texture_layout().surfaces,
            "word_bits": {port: getattr(p, name).word_bits for port, name, _ in engine.texture_ports()},
            "fragments": n, "raster_clocks": tframe.stats["raster_clocks"],
            "covered_pixels": tframe.vis.stats["depth"]["covered_pixels"], "name": frame.scene.name,
            "size": f"{frame.scene.width}x{frame.scene.height}",
            "clamped_fragment_inputs": frame.stats["clamped_fragment_inputs"],
            "maps": {m: list(getattr(p, m).texels.shape[1:3]) for m in MAPS},
            "levels": {m: getattr(p, m).levels for m in MAPS},
            "frame_buffer_bytes_per_fragment": (mem["bytes_read"] + mem["bytes_written"]) / n if n else 0.0,
            "cube_face": p.diffuse.width, "cube_bram": bram_blocks(cubes),
            "other_bram": bram_blocks([m for m in others if m not in cubes]),
            "on_chip_map_bram": bram_blocks(maps)}


def cache_for(size_kb: float, block: int, ways: int, **kw) -> TexCacheParams | None:
    """The cache of ``size_kb`` KB of data, or ``None`` when that is not a power-of-two number of sets."""
    line = block * block * kw.get("texel_bytes", 4)
    sets, rest = divmod(int(size_kb * 1024), line * ways)
    if rest or sets < 1 or sets & (sets - 1):
        return None
    return TexCacheParams(block=block, sets=sets, ways=ways, **kw)


def run_config(data: dict, params: TexCacheParams) -> dict:
    """Each cache's lookups through its own cache of ``params`` over the scene's layout blocked by its line: per
    cache totals (``maps``) and the scene's sums per fragment."""
    out = {"maps": {}}
    layout = Layout(data["surfaces"], params.block, params.texel_bytes)
    for m, trace in data["traces"].items():
        out["maps"][m] = simulate(params, layout, trace).totals
    tot = {k: sum(v[k] for v in out["maps"].values()) for k in ("line_accesses", "hits", "lookups", "lookup_hits",
                                                             "memory_bytes", "bursts", "distinct_lines",
                                                             "bank_conflicts", "self_evictions")}
    n = data["fragments"] or 1
    out.update(tot, hit_rate=tot["hits"] / tot["line_accesses"], lookup_hit_rate=tot["lookup_hits"] / tot["lookups"],
               bytes_per_fragment=tot["memory_bytes"] / n, bursts_per_fragment=tot["bursts"] / n,
               compulsory_bytes_per_fragment=tot["distinct_lines"] * params.line_bytes / n,
               lines_per_lookup=tot["line_accesses"] / tot["lookups"])
    return out


def memory_ns(res: dict, sdram: float, burst_ns: float) -> float:
    """SDRAM time per fragment of a result: its bytes at the peak bandwidth ``sdram`` (bytes/s) plus ``burst_ns``
    per burst (a row opened at random and closed again: activate, CAS latency, precharge)."""
    return 1e9 * res["bytes_per_fragment"] / sdram + burst_ns * res["bursts_per_fragment"]


def choose(rows: list[dict], scenes: list[str], slack: float) -> dict:
    """The smallest cache (data bytes, then ways, then block) whose SDRAM time per fragment
    (``sdram_ns_per_fragment``, :func:`memory_ns`) is within ``slack`` (relative, plus 0.25 ns) of the sweep's best on
    every scene."""
    best = {s: min(r["scenes"][s]["sdram_ns_per_fragment"] for r in rows) for s in scenes}
    ok = [r for r in rows if all(r["scenes"][s]["sdram_ns_per_fragment"] <= best[s] * (1 + slack) + 0.25
                                 for s in scenes)]
    return min(ok, key=lambda r: (r["cache"]["size_bytes"], r["cache"]["ways"], r["cache"]["block"]))


def sustained(data: dict, res: dict, sdram: float, burst_ns: float, engine_mhz: float) -> dict:
    """Pixel rates (fragments per second) a board sustains with the cache: the engine's own rate (one fragment a
    raster clock at ``engine_mhz``) capped by the SDRAM: textures alone at the peak bandwidth (bytes only), with
    the burst overhead (:func:`memory_ns`), and with the depth test's and frame buffer's bytes per fragment on
    the same memory (bytes only: an optimistic bound)."""
    n = data["fragments"] or 1
    engine = engine_mhz * 1e6 * n / max(data["raster_clocks"], 1)
    tex = res["bytes_per_fragment"]
    ns = memory_ns(res, sdram, burst_ns)
    both = tex + data["frame_buffer_bytes_per_fragment"]
    return {"engine_fragments_per_s": engine,
            "sustained_textures_bytes_only": min(engine, sdram / tex) if tex else engine,
            "sdram_ns_per_fragment": ns,
            "sustained_textures": min(engine, 1e9 / ns) if ns else engine,
            "frame_buffer_bytes_per_fragment": data["frame_buffer_bytes_per_fragment"],
            "sustained_with_frame_buffer_bytes_only": min(engine, sdram / both) if both else engine}


def sweep(datas: dict, sizes_kb, blocks, ways_list, progress=None) -> list[dict]:
    """Every configuration (LRU, XOR index) on every scene: rows ``{"cache": info, "scenes": {name: result}}``."""
    rows = []
    for size_kb in sizes_kb:
        for block in blocks:
            for ways in ways_list:
                params = cache_for(size_kb, block, ways)
                if params is None:
                    continue
                rows.append({"cache": params.info(), "scenes": {s: run_config(d, params) for s, d in datas.items()}})
                if progress:
                    progress(rows[-1])
    return rows


def variants(datas: dict, chosen: TexCacheParams, sdram: float, burst_ns: float) -> list[dict]:
    """The chosen cache with the other replacement and set index, for the record."""
    out = []
    for repl, index in (("lru", "linear"), ("plru", "xor"), ("plru", "linear"), ("fifo", "xor")):
        if repl == "plru" and chosen.ways & (chosen.ways - 1):
            continue
        p = TexCacheParams(block=chosen.block, sets=chosen.sets, ways=chosen.ways, replacement=repl, index=index)
        res = {s: _brief(run_config(d, p)) for s, d in datas.items()}
        for v in res.values():
            v["sdram_ns_per_fragment"] = memory_ns(v, sdram, burst_ns)
        out.append({"cache": p.info(), "scenes": res})
    return out


def _brief(res: dict) -> dict:
    """A result without its per-map totals (the sweep's rows)."""
    return {k: v for k, v in res.items() if k != "maps"}


def picture(rows: list[dict], scenes: list[str], labels: dict, chosen: dict) -> bytes:
    """PNG: per scene, memory bytes per fragment, hit rate and SDRAM time per fragment against the data size per
    cache, one line per block and ways."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    blocks = sorted({r["cache"]["block"] for r in rows})
    ways = sorted({r["cache"]["ways"] for r in rows})
    colors = dict(zip(blocks, ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")))
    styles = dict(zip(ways, ("-", "--", "-.", ":", (0, (1, 3)))))
    fig, axes = plt.subplots(len(scenes), 3, figsize=(14, 2.6 * len(scenes)), squeeze=False)
    for i, s in enumerate(scenes):
        for b in blocks:
            for w in ways:
                pts = sorted((r["cache"]["size_bytes"] / 1024, r["scenes"][s]) for r in rows
                             if r["cache"]["block"] == b and r["cache"]["ways"] == w)
                if not pts:
                    continue
                kb = [p[0] for p in pts]
                kw = dict(color=colors[b], linestyle=styles[w], label=f"{b}x{b} texels, {w}-way")
                axes[i, 0].plot(kb, [p[1]["bytes_per_fragment"] for p in pts], **kw)
                axes[i, 1].plot(kb, [100 * p[1]["hit_rate"] for p in pts], **kw)
                axes[i, 2].plot(kb, [p[1]["sdram_ns_per_fragment"] for p in pts], **kw)
        c = chosen["scenes"][s]
        ckb = chosen["cache"]["size_bytes"] / 1024
        axes[i, 0].plot([ckb], [c["bytes_per_fragment"]], "k*", markersize=12, label="chosen")
        axes[i, 1].plot([ckb], [100 * c["hit_rate"]], "k*", markersize=12)
        axes[i, 2].plot([ckb], [c["sdram_ns_per_fragment"]], "k*", markersize=12)
        axes[i, 2].set_ylabel("SDRAM ns / fragment")
        axes[i, 2].set_yscale("log")
        axes[i, 0].set_ylabel(f"{labels[s]}\nmemory bytes / fragment")
        axes[i, 1].set_ylabel("hit rate (line accesses) %")
        for ax in axes[i]:
            ax.set_xscale("log", base=2)
            ax.grid(True, alpha=0.3)
        axes[i, 0].set_yscale("log")
    for ax in axes[-1]:
        ax.set_xlabel("data per cache (KB; one cache per map)")
    handles, texts = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, texts, loc="lower center", ncol=7, fontsize=7)
    fig.suptitle("Texel cache sweep (LRU, XOR set index; bump map and color texture, each its own cache)")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=64)
    plt.close(fig)
    return buf.getvalue()


def _cache_name(c: dict) -> str:
    return f"{c['size_bytes'] // 1024} KB, {c['block']}x{c['block']}-texel lines, {c['ways']}-way"


def table(record: dict) -> str:
    """The Markdown summary of a record (``docs/texcache.md`` holds the committed record's)."""
    c, b = record["chosen_params"], record["bram"]
    lines = [f"Chosen: one cache per map (per level parity of a MIP-mapped map), {_cache_name(c)} "
             f"{c['replacement'].upper()}, {c['index']} set index, "
             f"{c['line_bytes']}-byte lines = one {c['beats_per_line']}-beat INCR burst on a {8 * c['bus_bytes']}-bit "
             f"AXI4 bus. Block RAM (DP16KD): cubes of {b['cube_face']}-texel faces {b['cubes']}, the caches "
             f"{b['caches']}, the rest of the engine {b['rest_of_engine']}: {b['total']} of the ECP5-85's "
             f"{b['device']}. "
             f"SDRAM {record['sdram_mb_s']:g} MB/s, {record['burst_overhead_ns']:g} ns a burst; "
             + (f"maps at level {record['level']}." if "level" in record else
                f"preset `{record['preset']}`, caches {', '.join(record['caches'])}."), "",
             "| scene | maps (bump, color) | fragments | hit rate | lookups all hit | bytes / fragment (compulsory) | "
             "bursts / fragment | SDRAM ns / fragment | Mfragments/s (engine) | with frame buffer, bytes only | "
             "smallest cache within slack |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name, v in record["per_scene"].items():
        r, m = v["result"], v["maps"]
        lines.append(f"| `{name}` | {m['bump_map'][1]}x{m['bump_map'][0]}, {m['texture'][1]}x{m['texture'][0]} | "
                     f"{v['fragments']:,} | {100 * r['hit_rate']:.2f} % | {100 * r['lookup_hit_rate']:.2f} % | "
                     f"{r['bytes_per_fragment']:.2f} ({r['compulsory_bytes_per_fragment']:.2f}) | "
                     f"{r['bursts_per_fragment']:.4f} | {v['sdram_ns_per_fragment']:.1f} | "
                     f"{v['sustained_textures'] / 1e6:.1f} ({v['engine_fragments_per_s'] / 1e6:.1f}) | "
                     f"{v['sustained_with_frame_buffer_bytes_only'] / 1e6:.1f} | "
                     f"{_cache_name(record['smallest_per_scene'][name])} |")
    if record.get("variants"):
        scenes = list(record["per_scene"])
        lines += ["", "The chosen cache's replacement and set index against the others (hit rate, bytes / fragment):",
                  "", "| replacement, set index | " + " | ".join(f"`{s}`" for s in scenes) + " |",
                  "|---|" + "---:|" * len(scenes)]
        rows = [(c, {s: v["result"] for s, v in record["per_scene"].items()})]
        rows += [(v["cache"], v["scenes"]) for v in record["variants"]]
        for cache, res in rows:
            chosen = " (chosen)" if cache is c else ""
            lines.append(f"| {cache['replacement'].upper()}, {cache['index']}{chosen} | " + " | ".join(
                f"{100 * res[s]['hit_rate']:.3f} %, {res[s]['bytes_per_fragment']:.2f}" for s in scenes) + " |")
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap cache-sweep``, :mod:`tools.main`)."""
    ap.add_argument("--scenes", nargs="+", default=list(DEFAULT_SCENES), metavar="SCENE",
                    help="scene names in scenes/ or .toml paths (default: the shipped scenes and the grazing floor)")
    ap.add_argument("--size", type=int, help="override every scene's image width (aspect kept)")
    ap.add_argument("--preset", default="default",
                    help="pipeline preset of every scene (default: default; mip: the color texture MIP-mapped, "
                         "its levels in memory and looked up in an even-level and an odd-level cache)")
    ap.add_argument("--sizes-kb", nargs="+", type=float, default=[0.5, 1, 2, 4, 8, 16, 32, 64],
                    help="data per cache in KB")
    ap.add_argument("--blocks", nargs="+", type=int, default=[2, 4, 8], help="line = block x block texels")
    ap.add_argument("--ways", nargs="+", type=int, default=[1, 2, 4, 8], help="associativities")
    ap.add_argument("--slack", type=float, default=0.10,
                    help="the chosen cache's SDRAM time per fragment may exceed the sweep's best by this fraction")
    ap.add_argument("--sdram-mb-s", type=float, default=200.0, help="board SDRAM bandwidth in MB/s (10^6 bytes)")
    ap.add_argument("--burst-overhead-ns", type=float, default=60.0,
                    help="SDRAM time per burst beyond its data (activate, CAS latency, precharge: 6 clocks at 100 MHz)")
    ap.add_argument("--engine-mhz", type=float, default=100.0, help="engine clock for its own fragment rate")
    ap.add_argument("--record", type=Path, help="write the JSON record here (e.g. docs/records/texcache.json)")
    ap.add_argument("--picture", type=Path, help="write the sweep picture here (e.g. docs/img/texcache-sweep.png)")


def run(args: argparse.Namespace) -> int:
    """Sweep the texel cache on scenes drawn from triangles, choose one, state the sustained pixel rates."""
    for name, vals in (("--sizes-kb", args.sizes_kb), ("--blocks", args.blocks), ("--ways", args.ways)):
        if not vals or min(vals) <= 0:
            print(f"error: {name} {vals}: must be positive numbers", file=sys.stderr)
            return 2
    if args.sdram_mb_s <= 0 or args.engine_mhz <= 0 or args.slack < 0 or args.burst_overhead_ns < 0:
        print("error: --sdram-mb-s and --engine-mhz must be positive, --slack and --burst-overhead-ns non-negative",
              file=sys.stderr)
        return 2
    try:
        datas = {}
        for s in args.scenes:
            d = scene_traces(s, args.size, args.preset)
            datas[d["name"]] = d
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    names = list(datas)
    rows = sweep(datas, args.sizes_kb, args.blocks, args.ways,
                 lambda r: print(f"{r['cache']['size_bytes'] // 1024:>3} KB {r['cache']['block']}x"
                                 f"{r['cache']['block']} {r['cache']['ways']}-way: " + "  ".join(
                                     f"{r['scenes'][s]['bytes_per_fragment']:7.2f}" for s in names),
                                 file=sys.stderr))
    if not rows:
        print("error: no cache of the given sizes, blocks and ways has a power-of-two number of sets", file=sys.stderr)
        return 2
    sdram = args.sdram_mb_s * 1e6
    for r in rows:
        r["scenes"] = {s: _brief(v) for s, v in r["scenes"].items()}
        for v in r["scenes"].values():
            v["sdram_ns_per_fragment"] = memory_ns(v, sdram, args.burst_overhead_ns)
    chosen = choose(rows, names, args.slack)
    c = chosen["cache"]
    params = TexCacheParams(block=c["block"], sets=c["sets"], ways=c["ways"])
    per_scene = {}
    for s, d in datas.items():
        res = run_config(d, params)
        per_scene[s] = {"scene": d["name"], "size": d["size"], "fragments": d["fragments"],
                        "covered_pixels": d["covered_pixels"], "raster_clocks": d["raster_clocks"], "maps": d["maps"],
                        "clamped_fragment_inputs": d["clamped_fragment_inputs"], "result": res,
                        "uncached_bytes_per_fragment": 4 * params.texel_bytes * res["lookups"] / max(d["fragments"], 1),
                        **sustained(d, res, sdram, args.burst_overhead_ns, args.engine_mhz)}
    first = datas[names[0]]
    cache_bram = sum(bram_blocks(dataclasses.replace(params, texel_bits=bits).memories())
                     for bits in first["word_bits"].values())
    bram = {"cube_face": first["cube_face"], "cubes": first["cube_bram"], "caches": cache_bram,
            "rest_of_engine": first["other_bram"], "total": first["cube_bram"] + cache_bram + first["other_bram"],
            "device": ECP5_85_DP16KD, "maps_on_chip_instead": {s: d["on_chip_map_bram"] for s, d in datas.items()}}
    record = {"command": "bumpmap cache-sweep " + shlex.join(sys.argv[2:] if sys.argv[1:2] == ["cache-sweep"]
                                                             else sys.argv[1:]),
              "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
              "machine": machine(), "sdram_mb_s": args.sdram_mb_s,
              "burst_overhead_ns": args.burst_overhead_ns, "engine_mhz": args.engine_mhz,
              "slack": args.slack, "chosen": chosen,
              "smallest_per_scene": {s: choose(rows, [s], args.slack)["cache"] for s in names},
              "preset": args.preset, "caches": list(first["traces"]), "chosen_params": params.info(),
              "per_scene": per_scene,
              "bram": bram, "variants": variants(datas, params, sdram, args.burst_overhead_ns), "sweep": rows}
    if args.record:
        atomic_write_bytes(args.record, (json.dumps(record, indent=1) + "\n").encode())
    if args.picture:
        atomic_write_bytes(args.picture, picture(rows, names, {s: datas[s]["name"] for s in names}, chosen))
    print(table(record))
    return 0
