"""``make sim``: render a scene through the RTL pixel pipeline and prove it bit-identical to the golden model.

``python -m cosim.sim [--scene tin-plane] [--sim icarus|verilator] [--size N] [--preset default]``

The model side prepares the frame (scene file, front end, maps and reflectance cubes quantized into the
pipeline's memories, fragments quantized to its input formats: ``fxmodel.render.prepare``); the fragment codes
stream through the stream version of ``rtl/pipeline.py`` (``rtl/streams.py``) in the streaming harness
(``cosim/stream.py``: vector files read by the HDL wrapper, no Python per clock), one per clock, or with gaps and
backpressure (``--pattern``); every output byte and flag is compared with the bit-exact model in the simulation,
and written out (``rtl.png``, compared again here). Writes ``build/sim/<scene>/``: ``rtl.png``, ``model.png``, ``float.png``,
``ideal.png``, ``diff.png`` (amplified differences of the model from the two float references), ``compare.png``
and ``report.json`` (with the ``verdict``); prints a summary table; exits non-zero on any mismatch, on a frame
farther than ``--max-lsb`` (default: the documented scene bound) from reference (a), and on a fragment input the
preset cannot hold (unless ``--allow-clamp``): ``fxmodel.render.judge``. ``WAVES=1`` dumps a waveform.

``--input triangles`` draws from triangles instead: the host's set-up turns the scene into triangle records
(``fxmodel.render.from_triangles``), and the RTL of the engine from the triangle (``rtl/pipeline.py``'s
``TrianglePipeline``: the scan converter and interpolators of ``rtl/raster.py`` feeding the pixel pipeline) draws
them; every output (``x, y``, bytes, flags) and the scan converter's clock count are compared with the model.
``report.json`` then has ``"input": "triangles"``, the triangle and fragment counts, the clocks per fragment, and
the frame from triangles against reference (a) beside the frame from float-interpolated fragments
(``triangles_vs_fragments``: the interpolators' share of the error); ``triangles.png`` is what the RTL drew.

``--unit U [--preset P]`` co-simulates a single unit on its hard cases and random vectors instead.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from .harness import ROOT, simulator
from .stream import PATTERNS, ArraySpace, FullSpace, Space, run_stream

#: Fragments per vector file: the progress bar moves once a chunk.
CHUNK = 4096
#: Largest run whose outputs are written out (beyond, they are only compared in the simulation).
DUMP_MAX = 1 << 22


def _stream(params, space, args, tag: str, what: str):
    """Stream ``space`` (codes or a :class:`~cosim.stream.Space`) through the unit's RTL with the outputs written
    out (``result.rtl``); a tqdm bar counting ``what``."""
    from tqdm import tqdm
    space = space if isinstance(space, Space) else ArraySpace(space, what)
    with tqdm(total=len(space), desc=f"RTL {args.sim}", unit=what, unit_scale=True) as bar:
        return run_stream(params, space, sim=args.sim, chunk=CHUNK, pattern=args.pattern, tag=tag,
                          dump=len(space) <= DUMP_MAX, progress=bar)


def _table(rows) -> str:
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)


def sim_scene(args) -> int:
    from fxmodel.render import judge, prepare, render, save_png, tell
    from fxmodel.scene import SceneError, scene_path

    t0 = time.perf_counter()
    try:
        frame = prepare(scene_path(args.scene), size=args.size, preset=args.preset, cube_size=args.cube_size,
                        allow_clamp=args.allow_clamp)
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    name = frame.scene.name
    out_dir = ROOT / "build" / "sim" / name
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("report.json", "rtl.png"):                # never leave an old result looking current
        (out_dir / stale).unlink(missing_ok=True)
    print(f"{name}: {len(frame.codes)} fragments, {frame.scene.width}x{frame.scene.height}, RTL on {args.sim}")
    report = render(frame, out_dir)
    model = report.pop("_model_bytes")
    result = _stream(frame.params, frame.codes, args, f"scene_{name}", "px")
    wall = time.perf_counter() - t0
    # the harness compared every output (bytes and flags) with the model; this is what the RTL drew
    # the wrapper compared every output in the simulation; the outputs it wrote out are compared again here
    complete = result.rtl is not None and len(result.rtl) == len(frame.codes)
    mismatches = result["mismatches"]
    if complete:
        save_png(out_dir / "rtl.png", frame.image(result.rtl[:, :3].astype(np.uint8)))
        mismatches = max(mismatches, int(np.any(result.rtl != frame.params.compute(frame.codes), axis=1).sum()))
    del model
    report.update({"simulator": args.sim, "preset": args.preset, "pattern": args.pattern,
                   "mismatches": mismatches, "stream_ok": result.ok,
                   "first_mismatches": result["first"], "rtl_seconds": result["seconds"],
                   "rtl_cpu_seconds": result["sim_cpu_seconds"], "cycles": result["cycles"],
                   "build_seconds": result["build_seconds"], "wall_seconds": round(wall, 2),
                   "pixels_per_second": round(len(frame.codes) / result["seconds"]) if result["seconds"] else None,
                   "pipeline_latency": frame.params.latency})
    judge(report, args.max_lsb)
    (out_dir / "report.json").write_text(json.dumps(report, indent=2))
    print(_table([
        ("scene", name), ("simulator", args.sim), ("pixels", f"{report['pixels']:,}"),
        ("mismatches", str(report["mismatches"])),
        ("PSNR vs float", f"{report['psnr_db_vs_float']} dB (max {report['max_lsb_vs_float']} LSB)"),
        ("PSNR vs ideal", f"{report['psnr_db_vs_ideal']} dB (max {report['max_lsb_vs_ideal']} LSB)"),
        ("verdict", f"{'pass' if report['verdict']['pass'] else 'FAIL'} (bound {args.max_lsb} LSB from (a))"),
        ("RTL pixels/s", f"{report['pixels_per_second']:,}"), ("wall seconds", f"{wall:.1f}"),
        ("output", str(out_dir))]))
    if mismatches or not result.ok:
        print(result.describe(), file=sys.stderr)
        return 1
    print("  RTL == model on every pixel")
    return tell(report, name)


def sim_triangles(args) -> int:
    from fxmodel.render import from_triangles, prepare, render_triangles, save_png
    from fxmodel.scene import SceneError, scene_path

    from .raster import run as run_raster

    t0 = time.perf_counter()
    try:
        frame = prepare(scene_path(args.scene), size=args.size, preset=args.preset, cube_size=args.cube_size)
        tframe = from_triangles(frame)
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    name = frame.scene.name
    out_dir = ROOT / "build" / "sim" / f"{name}-triangles"
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in ("report.json", "rtl.png"):
        (out_dir / stale).unlink(missing_ok=True)
    print(f"{name}: {len(tframe.records)} triangles, {len(tframe.out)} fragments, "
          f"{frame.scene.width}x{frame.scene.height}, RTL on {args.sim}")
    report = render_triangles(tframe, out_dir)
    report.pop("_triangle_bytes")
    os.environ.setdefault("COSIM_PROGRESS", "1")
    result = run_raster(tframe.params, tframe.records, sim=args.sim, tag=f"scene_{name}")
    rtl = result.pop("rtl")
    wall = time.perf_counter() - t0
    if len(rtl):
        save_png(out_dir / "rtl.png", tframe.image(rtl[:, 2:5].astype(np.uint8)) if len(rtl) == len(tframe.out)
                 else np.zeros((1, 1, 3), np.uint8))
    clocks_ok = result["busy_cycles"] == result["clocks"]
    report.update({"simulator": args.sim, "preset": args.preset, "mismatches": result["mismatches"],
                   "first_mismatches": result["first"], "rtl_busy_cycles": result["busy_cycles"],
                   "rtl_clocks_match_model": clocks_ok, "rtl_seconds": result["seconds"],
                   "build_seconds": result["build_seconds"], "wall_seconds": round(wall, 2),
                   "latency": tframe.params.latency})
    (out_dir / "report.json").write_text(json.dumps(report, indent=2))
    tv = report["triangles_vs_fragments"]
    print(_table([
        ("scene", name), ("input", f"{report['triangles']} triangles -> {report['fragments']:,} fragments"),
        ("simulator", args.sim), ("mismatches", str(report["mismatches"])),
        ("clocks / fragment", f"{report['clocks_per_fragment']} (RTL {result['busy_cycles']:,} cycles, "
                              f"model {result['clocks']:,})"),
        ("from triangles vs float", f"{tv['psnr_db_vs_float']} dB (max {tv['max_lsb_vs_float']} LSB)"),
        ("from fragments vs float", f"{report['psnr_db_vs_float']} dB (max {report['max_lsb_vs_float']} LSB)"),
        ("wall seconds", f"{wall:.1f}"), ("output", str(out_dir))]))
    if result["mismatches"] or not clocks_ok:
        print(f"RTL differs from the model: {result['mismatches']} outputs, clocks {result['busy_cycles']} "
              f"against {result['clocks']}; first: {result['first']}", file=sys.stderr)
        return 1
    print("  RTL == model on every pixel, clock for clock")
    return 0


def sim_unit(args) -> int:
    from fxmodel.unit import preset

    params = preset(args.unit, args.preset)
    rng = np.random.default_rng(args.seed)
    vectors = FullSpace(params) if args.exhaustive else ArraySpace(
        np.concatenate([params.hard_cases(), params.random_inputs(rng, args.vectors)]), "hard cases and random")
    result = _stream(params, vectors, args, "sim", "vec")
    out = ROOT / "build" / "sim" / f"{args.unit}_{args.preset}"
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps({"unit": args.unit, "preset": args.preset, **result}, indent=2))
    print(_table([("unit", f"{args.unit} ({args.preset})"), ("simulator", args.sim),
                  ("vectors", f"{result['vectors']:,}"), ("mismatches", str(result["mismatches"])),
                  ("vectors/s", f"{result['vectors_per_second']:,.0f}"), ("report", str(out / "report.json"))]))
    if not result.ok:
        print(result.describe(), file=sys.stderr)
        return 1
    return 0


def main(argv=None) -> int:
    from fxmodel.render import bound_args
    ap = argparse.ArgumentParser(prog="python -m cosim.sim", description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="tin-plane", help="scene name in scenes/ or a .toml path")
    ap.add_argument("--size", type=int, default=None, help="override the image size (square)")
    ap.add_argument("--cube-size", type=int, help="texels per reflectance-cube face edge (default: the preset's, 64 "
                   "unless a preset file sets it)")
    ap.add_argument("--preset", default="default")
    bound_args(ap)
    ap.add_argument("--sim", default=None, help="icarus or verilator (default: $SIM or icarus)")
    ap.add_argument("--input", choices=("fragments", "triangles"), default="fragments",
                    help="what the RTL starts from: the front end's fragments, or triangle records through the scan "
                         "converter (default: %(default)s)")
    ap.add_argument("--unit", help="co-simulate one unit instead of a scene")
    ap.add_argument("--vectors", type=int, default=100_000, help="random vectors besides the hard cases (--unit)")
    ap.add_argument("--exhaustive", action="store_true", help="the unit's whole input space (--unit)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pattern", default="none", choices=list(PATTERNS),
                    help="gaps on the input valid and backpressure on the output ready (default: %(default)s)")
    args = ap.parse_args(argv)
    try:
        args.sim = simulator(args.sim)
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.unit:
        return sim_unit(args)
    return sim_triangles(args) if args.input == "triangles" else sim_scene(args)


if __name__ == "__main__":
    raise SystemExit(main())
