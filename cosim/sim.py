"""``make sim``: draw a scene from triangles through the RTL engine and prove it bit-identical to the golden model.

``bumpmap sim [--scene tin-plane] [--sim icarus|verilator] [--size N] [--preset default]
[--input triangles|fragments] [--pattern none|random|bursts|stalls] [--shards N]``

By default (``--input triangles``) the host's set-up turns the scene into triangle records
(``host.render.from_triangles``: snapped vertices, edge functions, each attribute's plane rounded once, the
bump matrix's block exponent per triangle), and the RTL of the engine from the triangle (``rtl/engine.py``'s
``Engine``: the scan converter and interpolators of ``rtl/raster.py`` feeding the stream version of the
pixel pipeline) draws them, in the streaming harness (``cosim/stream.py``, ``run_records``: records from
binary chunk files (``$fread``), the clock and the stimulus inside the HDL wrapper, no Python per clock); every output
(``x, y``, the bytes, the flags) is compared with the bit-exact model, in order, none lost and none extra, and the
scan converter's busy cycles with the model's clock count. Without the depth test the triangles are independent,
so they are simulated as ``--shards`` contiguous shards (default: one per usable core, at most one per triangle;
one with ``WAVES=1``) in as many simulator processes at once (``run_records(shards=N)``), the fragments joined in
order, and the clock count checked shard by shard (each shard starts from reset); the report says how many
(``shards``, ``shard_triangles``). ``--input fragments`` starts at the fragment instead:
the front end's fragments, quantized to the pipeline's inputs (``host.render.prepare``), stream through the
stream version of ``rtl/pixel.py`` (``run_stream``), every output compared in the simulation.

Writes ``build/sim/<key>-triangles/`` (``<key>-fragments/`` from fragments, ``<key>-depth/`` with the depth
test), ``<key>`` the scene FILE's stem (letters, digits, ``-`` and ``_`` kept, the rest ``_``) and a digest of the
run (scene file, size, preset, cube size, simulator, input): :func:`run_key`. The folder always lies under the
build folder, whatever the scene's ``name`` (only a label), and concurrent runs of one scene with other sizes,
presets or simulators never share it (nor the simulator's job folders, named by the same key). In it:
``rtl.png`` (what the RTL drew),
``model.png``, ``float.png``, ``ideal.png``, ``diff.png`` (amplified differences of the model from the two float
references), ``compare.png`` and ``report.json`` (with the ``verdict``; from triangles also ``"input":
"triangles"``, the triangle and fragment counts, the clocks per fragment, and the frame from float-interpolated
fragments beside it: ``fragments.png``, ``from_fragments``, ``triangles_vs_fragments``, the interpolators' share of
the error); prints a summary table; exits 1 on any mismatch and on a frame farther than ``--max-lsb`` (default:
the documented scene bound) from reference (a), 2 on a scene the preset cannot draw (unless ``--allow-clamp``,
fragments only): ``host.render.judge``. ``WAVES=1`` dumps a waveform (short runs).
From triangles, every pixel shows the fragment the depth test keeps (``host/visibility.py``, with the
raster-operations unit's model); ``report.json`` gets ``depth`` (fragments, passed, failed, overdraw, the
disagreements with reference (a)'s float z-buffer and their largest depth gap, the depth precision) and
``memory`` (frame-buffer bytes read and written per covered pixel), ``depth_disagreements.png`` marks the
disagreements, and the verdict fails on a disagreement beyond the depth precision.

``--input triangles --depth`` adds the depth test and the frame buffer behind the ROP's AXI4 port
(``cosim/rop.py``: the memory model with ``--latency`` cycles): overlapping geometry is drawn, the frame is read
from the memory model at the end and compared with the model's; ``build/sim/<scene>-depth/report.json`` has the
memory traffic (``depth_test``: bytes read and written per covered pixel).

``--model-only`` stops before the RTL build: the model side only (the frame prepared, drawn and judged, the
images and ``report.json`` written, ``"rtl": null``), for checking a scene quickly. A frame with no covered
pixel is refused (exit 2): there is nothing to compare.

``--unit U [--preset P]`` co-simulates a single unit on its hard cases and random vectors instead.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import build_dir, shown_path
from host.args import SIZE_HELP, cube_size_arg, float_range, int_range, size_arg
from host.atomic import atomic_json, check_output_dir
from host.images import db_text, depth_rows, disagreement_row, summary_table, truth_rows, verdict_row
from host.truth import DEFAULT_SAMPLES

from .harness import simulator
from .stream import PATTERNS, ArraySpace, FullSpace, Space, run_records, run_stream

#: Fragments per vector file: the progress bar moves once a chunk.
CHUNK = 4096
#: Largest run whose outputs are written out (beyond, they are only compared in the simulation).
DUMP_MAX = 1 << 22


def _bar(total: int, args, what: str):
    from tqdm import tqdm
    return tqdm(total=total, desc=f"RTL {args.sim}", unit=what, unit_scale=True)


def _stream(params, space, args, tag: str, what: str):
    """Stream ``space`` (codes or a :class:`~cosim.stream.Space`) through the unit's RTL with the outputs written
    out (``result.rtl``); a tqdm bar counting ``what``."""
    space = space if isinstance(space, Space) else ArraySpace(space, what)
    with _bar(len(space), args, what) as bar:
        return run_stream(params, space, sim=args.sim, chunk=CHUNK, pattern=args.pattern, tag=tag,
                          dump=len(space) <= DUMP_MAX, progress=bar)


def run_key(args, scene_file) -> str:
    """The name of a scene run's folders (output and simulator jobs): the scene file's stem made safe (letters,
    digits, ``-``, ``_``; at most 40 characters) and 10 hex digits of a SHA-1 over the resolved file and every
    option that changes the run (size, preset, cube size, simulator, input, depth, clamping, reference (c)). Never
    taken from the file's contents, so it cannot climb out of the build folder; distinct for concurrent runs that
    differ."""
    path = Path(scene_file)
    stem = re.sub(r"[^A-Za-z0-9_-]", "_", path.stem)[:40].strip("_-") or "scene"
    what = [str(path.resolve()), args.size, args.preset, args.cube_size, args.sim, args.input, args.depth,
            args.allow_clamp] + ([args.truth] if getattr(args, "truth", 0) else [])     # (c), when on
    if getattr(args, "textures", "on-chip") != "on-chip":                              # the maps' memory, when not
        what.append(args.textures)
    return f"{stem}-{hashlib.sha1(repr(what).encode()).hexdigest()[:10]}"


def out_dir_of(args, scene_file) -> Path:
    """The run's output folder under ``build/sim`` (:func:`run_key`); checked to lie inside it."""
    kind = "depth" if args.depth else ("textures" if getattr(args, "textures", "on-chip") != "on-chip"
                                       else args.input)
    root = build_dir("sim")
    out = root / f"{run_key(args, scene_file)}-{kind}"
    if out.resolve().parent != root.resolve():              # cannot happen with run_key's characters
        raise ValueError(f"output folder {out} is not inside {root}")
    return out


def _draw(args):
    """The model side: ``(name, frame, tframe or None, report, out_dir)`` with the images written, or an exit
    status (2: a bad scene, one the preset cannot draw, or one that draws nothing)."""
    from host.render import from_triangles, prepare, render, render_triangles
    from host.scene import SceneError, scene_path

    triangles = args.input == "triangles"
    scene_file = scene_path(args.scene)
    try:
        frame = prepare(scene_file, size=args.size, preset=args.preset, cube_size=args.cube_size,
                        allow_clamp=args.allow_clamp)
        if not len(frame.codes):
            raise ValueError(f"{scene_file}: nothing is drawn: no triangle covers a pixel of the "
                             f"{frame.scene.width}x{frame.scene.height} frame (camera behind or inside the geometry, "
                             f"or everything clipped or culled), so there is nothing to compare")
        tframe = from_triangles(frame, depth=args.depth) if triangles else None
        out_dir = check_output_dir(out_dir_of(args, scene_file))
    except (SceneError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    name = frame.scene.name
    for stale in ("report.json", "rtl.png", "truth.png"):   # never leave an old result looking current
        (out_dir / stale).unlink(missing_ok=True)           # (in this run's own folder, under build/sim)
    size = f"{frame.scene.width}x{frame.scene.height}, " + ("model only" if args.model_only else f"RTL on {args.sim}")
    if triangles:
        print(f"{name}: {len(tframe.records)} triangles, {len(tframe.out)} fragments, {size}")
        report = render_triangles(tframe, out_dir, truth_samples=args.truth)
        report.pop("_triangle_bytes")
    else:
        print(f"{name}: {len(frame.codes)} fragments, {size}")
        report = render(frame, out_dir, truth_samples=args.truth)
        report.pop("_model_bytes")
    return name, frame, tframe, report, out_dir


def sim_scene(args) -> int:
    """``make sim`` of a scene, from triangles (default) or from fragments."""
    from host.render import judge, save_png, tell

    t0 = time.perf_counter()
    drawn = _draw(args)
    if isinstance(drawn, int):
        return drawn
    name, frame, tframe, report, out_dir = drawn
    # The verdict is the model's frame against reference (a) (the RTL must equal the model): judged here, once, for
    # every way of drawing (--depth and --textures external exited 0 without it, whatever --max-lsb said).
    judge(report, args.max_lsb)
    if args.model_only:
        return model_only(args, report, out_dir, name)
    key = out_dir.name
    if args.depth:
        return sim_depth(args, tframe, report, out_dir, t0)
    if args.textures != "on-chip":
        from .engine_fetch import sim_textures
        return sim_textures(args, tframe, report, out_dir, t0)
    if tframe is not None:                                  # records in, fragments out: compared here, in order
        counts = np.bincount(tframe.scan.record, minlength=len(tframe.records))
        with _bar(len(tframe.out), args, "px") as bar:
            result = run_records(tframe.params, tframe.records.matrix(), tframe.out, counts,
                                 clocks=tframe.scan.clocks, sim=args.sim, pattern=args.pattern,
                                 tag=f"scene_{key}", progress=bar, shards=args.shards)
        expected, pixels = tframe.out, len(tframe.out)
    else:                                                   # compared in the simulation, and again here
        result = _stream(frame.params, frame.codes, args, f"scene_{key}", "px")
        expected, pixels = (frame.params.compute(frame.codes) if len(frame.codes) else None), len(frame.codes)
    wall = time.perf_counter() - t0
    rtl = result.rtl
    complete = rtl is not None and len(rtl) == pixels
    mismatches = result["mismatches"]
    if complete:
        mismatches = max(mismatches, int(np.any(rtl != expected, axis=1).sum()) if pixels else 0)
        if tframe is not None:                              # each pixel: the fragment the depth test keeps
            col = {p.name: rtl[:, i] for i, p in enumerate(tframe.params.outputs)}
            img = tframe.image(np.stack([col[c] for c in "rgb"], 1).astype(np.uint8))
        else:
            img = frame.image(rtl[:, :3].astype(np.uint8))
        save_png(out_dir / "rtl.png", img)
    report.update({"simulator": args.sim, "preset": args.preset, "pattern": args.pattern,
                   "mismatches": mismatches, "stream_ok": result.ok,
                   "first_mismatches": result["first"], "rtl_seconds": result["seconds"],
                   "rtl_cpu_seconds": result["sim_cpu_seconds"], "cycles": result["cycles"],
                   "build_seconds": result["build_seconds"], "wall_seconds": round(wall, 2),
                   "pixels_per_second": round(pixels / result["seconds"]) if result["seconds"] else None,
                   "pipeline_latency": frame.params.latency})
    clocks_ok = True
    if tframe is not None:                                  # clock for clock, shard by shard (each from reset)
        model_clocks = [int(tframe.scan.clocks[a:b].sum()) for a, b in result["shards"]]
        clocks_ok = args.pattern != "none" or (result["shard_busy_cycles"] == model_clocks
                                               and result["busy_cycles"] == report["raster_clocks"])
        report.update({"rtl_busy_cycles": result["busy_cycles"], "rtl_clocks_match_model": clocks_ok,
                       "shards": len(result["shards"]), "shard_triangles": result["shards"],
                       "rtl_shard_busy_cycles": result["shard_busy_cycles"], "model_shard_clocks": model_clocks})
    atomic_json(out_dir / "report.json", report)
    rows = [("scene", name), ("simulator", args.sim)]
    if tframe is not None:
        rows += [("input", f"{report['triangles']} triangles -> {report['fragments']:,} fragments"),
                 ("shards", f"{report['shards']} (" + ("simulated at once, triangles " + ", ".join(
                     f"{a}..{b - 1}" for a, b in report["shard_triangles"]) if report["shards"] > 1 else
                     "one simulator process") + ")"),
                 ("clocks / fragment", f"{report['clocks_per_fragment']} (model {report['raster_clocks']:,}, RTL busy "
                                       f"{result['busy_cycles']:,}; {result['cycles']:,} cycles in all)")]
    else:
        rows += [("pixels", f"{report['pixels']:,}")]
    rows += [("mismatches", str(mismatches)),
             ("PSNR vs float", f"{db_text(report['psnr_db_vs_float'])} (max {report['max_lsb_vs_float']} LSB)"),
             ("PSNR vs ideal", f"{db_text(report['psnr_db_vs_ideal'])} (max {report['max_lsb_vs_ideal']} LSB)"),
             *truth_rows(report)]
    if tframe is not None:
        ff = report["from_fragments"]
        rows += [("from fragments vs float", f"{db_text(ff['psnr_db_vs_float'])} (max {ff['max_lsb_vs_float']} LSB)"),
                 *depth_rows(report)]
    rows += [verdict_row(report),
             ("RTL pixels/s", f"{report['pixels_per_second']:,}"),
             ("seconds", f"{wall:.1f} wall, simulator {result['sim_cpu_seconds']:.1f} CPU, build "
                         f"{result['build_seconds']:.1f}"),
             ("output", shown_path(out_dir))]
    print(summary_table(rows))
    if mismatches or not result.ok or not clocks_ok:
        print(result.describe(), file=sys.stderr)
        if not clocks_ok:
            print(f"the scan converter was busy {result['shard_busy_cycles']} cycles (by shard), the model counts "
                  f"{report['model_shard_clocks']}", file=sys.stderr)
        return 1
    print("  RTL == model on every pixel" + (", clock for clock" if tframe is not None else ""))
    return tell(report, name)


def model_only(args, report: dict, out_dir: Path, name: str) -> int:
    """``--model-only``: the model side's report (judged by :func:`sim_scene`) written (``"rtl": null``), no RTL
    build."""
    from host.render import tell
    report.update({"rtl": None, "preset": args.preset, "simulator": args.sim})
    atomic_json(out_dir / "report.json", report)
    print(summary_table([("scene", name), ("PSNR vs float", f"{db_text(report['psnr_db_vs_float'])} (max "
                                                             f"{report['max_lsb_vs_float']} LSB)"),
                         *truth_rows(report),
                         ("verdict", f"{'pass' if report['verdict']['pass'] else 'FAIL'} (model only, no RTL)"),
                         ("output", shown_path(out_dir))]))
    return tell(report, name)


def sim_depth(args, tframe, report, out_dir, t0) -> int:
    """``--depth``: the engine with its depth test; the frame is read from the memory model behind the ROP's
    AXI4 port at the end (``cosim.rop.run_engine``) and compared with the model's."""
    from host.render import save_png, tell

    from .rop import run_engine

    name = tframe.frame.scene.name
    rop = tframe.params.rop
    print(f"{name}: depth test and frame buffer behind AXI4 (latency {args.latency}, wait states "
          f"{args.wait_states:g}), {rop.width}x{rop.height}")
    os.environ.setdefault("COSIM_PROGRESS", "1")
    result = run_engine(tframe.params, tframe.records, latency=args.latency, p_pause=args.wait_states,
                        seed=args.seed, sim=args.sim, tag=f"scene_{out_dir.name}")
    wall = time.perf_counter() - t0
    save_png(out_dir / "rtl.png", result["color"][..., :3].astype(np.uint8))
    dt = report["depth_test"]
    traffic_ok = (result["rtl_bytes_read"], result["rtl_bytes_written"]) == (dt["bytes_read"], dt["bytes_written"])
    report.update({"simulator": args.sim, "preset": args.preset, "mismatches": result["mismatches"],
                   "first_mismatches": result["first"], "memory_latency": args.latency,
                   "memory_wait_states": args.wait_states,
                   "rtl_bytes_read": result["rtl_bytes_read"], "rtl_bytes_written": result["rtl_bytes_written"],
                   "rtl_traffic_matches_model": traffic_ok, "rtl_status": result["status"],
                   "rtl_cycles": result["cycles"], "rtl_seconds": result["seconds"],
                   "build_seconds": result["build_seconds"], "wall_seconds": round(wall, 2)})
    atomic_json(out_dir / "report.json", report)
    tv = report["triangles_vs_fragments"]
    print(summary_table([
        ("scene", name), ("input", f"{report['triangles']} triangles -> {report['fragments']:,} fragments "
                                   f"({dt['fragments_per_covered_pixel']} per covered pixel)"),
        ("simulator", args.sim), ("mismatches", f"{result['mismatches']} pixels (frame read from memory)"),
        ("depth test", f"{dt['passed']:,} passed, {dt['failed']:,} failed"),
        ("memory traffic", f"{dt['bytes_read_per_pixel']} B read, {dt['bytes_written_per_pixel']} B written per "
                           f"covered pixel (RTL {result['rtl_bytes_read']:,} / {result['rtl_bytes_written']:,} B)"),
        ("from triangles vs float", f"{db_text(tv['psnr_db_vs_float'])} (max {tv['max_lsb_vs_float']} LSB)"),
        disagreement_row(report), verdict_row(report),
        ("wall seconds", f"{wall:.1f}"), ("output", shown_path(out_dir))]))
    if result["mismatches"] or not traffic_ok or result["status"]:
        print(f"RTL differs from the model: {result['mismatches']} pixels, traffic {result['rtl_bytes_read']} / "
              f"{result['rtl_bytes_written']} B, status {result['status']}; first: {result['first']}",
              file=sys.stderr)
        return 1
    print("  RTL == model on every pixel of the frame in memory")
    return tell(report, name)


def sim_unit(args) -> int:
    from fxmodel.core.unit import preset

    params = preset(args.unit, args.preset)
    rng = np.random.default_rng(args.seed)
    vectors = FullSpace(params) if args.exhaustive else ArraySpace(
        np.concatenate([params.hard_cases(), params.random_inputs(rng, args.vectors)]), "hard cases and random")
    result = _stream(params, vectors, args, "sim", "vec")
    out = build_dir("sim") / re.sub(r"[^A-Za-z0-9_-]", "_", f"{args.unit}_{args.preset}")
    out.mkdir(parents=True, exist_ok=True)
    atomic_json(out / "report.json", {"unit": args.unit, "preset": args.preset, **result})
    print(summary_table([("unit", f"{args.unit} ({args.preset})"), ("simulator", args.sim),
                  ("vectors", f"{result['vectors']:,}"), ("mismatches", str(result["mismatches"])),
                  ("vectors/s", f"{result['vectors_per_second']:,.0f}"), ("report", str(out / "report.json"))]))
    if not result.ok:
        print(result.describe(), file=sys.stderr)
        return 1
    return 0


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap sim``, :mod:`tools.main`)."""
    from host.render import bound_args
    ap.add_argument("--scene", default="tin-plane", help="scene name in scenes/ or a .toml path")
    ap.add_argument("--size", type=size_arg(), default=None, help=SIZE_HELP)
    ap.add_argument("--cube-size", type=cube_size_arg(),
                    help="texels per reflectance-cube face edge, 1 .. 1024 (default: the preset's, 64 "
                         "unless a preset file sets it)")
    ap.add_argument("--preset", default="default")
    bound_args(ap)
    ap.add_argument("--sim", default=None, help="icarus or verilator (default: $SIM or icarus)")
    ap.add_argument("--input", choices=("triangles", "fragments"), default="triangles",
                    help="what the RTL starts from: the front end's fragments, or triangle records through the scan "
                         "converter (default: %(default)s)")
    ap.add_argument("--depth", action="store_true",
                    help="with --input triangles: the engine with its depth test and frame buffer behind an AXI4 port "
                         "(cosim/rop.py); the frame is read from the memory model (build/sim/<scene>-depth/)")
    ap.add_argument("--textures", choices=("on-chip", "external"), default="on-chip",
                    help="with --input triangles (without --depth): the bump map and color texture in block RAM, or "
                         "in an AXI4 memory model behind the texel caches (cosim/engine_fetch.py; "
                         "build/sim/<scene>-textures/; default %(default)s)")
    ap.add_argument("--latency", type=int_range(0, 63), default=4,
                    help="memory latency added by the bench (--depth: 0..24; --textures external: 0..63)")
    ap.add_argument("--wait-states", type=float_range(0.0, 0.99), default=0.0, metavar="P",
                    help="--depth, --textures external: probability that each AXI channel of the memory model pauses "
                         "in a cycle (random wait states, 0 .. 0.99; default %(default)s)")
    ap.add_argument("--truth", type=int_range(0, 32), default=DEFAULT_SAMPLES, metavar="K",
                    help="judge the frame against reference (c), the true image: K x K samples per pixel, a power "
                         "of two (default: %(default)s; 0 leaves it out)")
    ap.add_argument("--unit", help="co-simulate one unit instead of a scene")
    ap.add_argument("--vectors", type=int_range(0, 1 << 30), default=100_000,
                    help="random vectors besides the hard cases (--unit)")
    ap.add_argument("--exhaustive", action="store_true", help="the unit's whole input space (--unit)")
    ap.add_argument("--seed", type=int_range(0, 2**32 - 1), default=1)
    ap.add_argument("--shards", type=int_range(1, 1024), default=None, metavar="N",
                    help="from triangles (without --depth): simulate the triangles as N contiguous shards in N "
                         "simulator processes at once (default: the usable cores, at most the triangles; one "
                         "with WAVES=1)")
    ap.add_argument("--model-only", action="store_true",
                    help="stop before the RTL build: prepare, draw and judge the model side only, write its images "
                         "and report.json (\"rtl\": null)")
    ap.add_argument("--pattern", default="none", choices=list(PATTERNS),
                    help="gaps on the input valid and backpressure on the output ready (default: %(default)s)")


def run(args: argparse.Namespace) -> int:
    try:
        args.sim = simulator(args.sim) if not args.model_only else (args.sim or "none")
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.depth and args.input != "triangles":
        print("error: --depth draws from triangles: add --input triangles", file=sys.stderr)
        return 2
    if args.textures != "on-chip" and (args.input != "triangles" or args.depth):
        print("error: --textures external draws from triangles without the depth test: add --input triangles, "
              "drop --depth", file=sys.stderr)
        return 2
    if args.depth and args.latency > 24:
        print(f"error: --latency {args.latency}: the depth test's bench takes 0..24", file=sys.stderr)
        return 2
    if args.shards is None:
        args.shards = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if args.shards < 1:
        print(f"error: --shards {args.shards}: must be >= 1", file=sys.stderr)
        return 2
    if args.unit:
        from fxmodel.core.unit import preset, unit_class
        try:
            unit_class(args.unit)
            preset(args.unit, args.preset)
        except (KeyError, ValueError) as exc:
            print(f"error: {str(exc).strip(chr(39))}", file=sys.stderr)
            return 2
        return sim_unit(args)
    return sim_scene(args)


def output_folder(argv) -> Path:
    """The output folder that the ``bumpmap sim`` command line ``argv`` (a scene run) writes: :func:`out_dir_of`."""
    from host.scene import scene_path
    ap = argparse.ArgumentParser(prog="bumpmap sim")
    add_arguments(ap)
    args = ap.parse_args(argv)
    args.sim = simulator(args.sim) if not args.model_only else (args.sim or "none")
    return out_dir_of(args, scene_path(args.scene))


def main(argv=None) -> int:
    """``bumpmap sim`` called from Python (the co-simulation tests): parse ``argv`` and run."""
    ap = argparse.ArgumentParser(prog="bumpmap sim", description=__doc__.split("\n")[0])
    add_arguments(ap)
    return run(ap.parse_args(argv))
