"""The golden model's commands: ``bumpmap {info,eval,errors,render,fit,presets,verilog} ...``.

``info UNIT``
    JSON: the unit's inputs and outputs (``name, signed, int_bits, frac_bits``; ``int_bits`` counts the sign),
    latency, parameters, documented error bounds and the hardware estimate (``cost``: MULT18X18D and DP16KD
    blocks, multipliers, table and memory bits, :mod:`fxmodel.core.cost`), for ``--preset NAME`` (default
    ``default``). ``info pipeline --scene SCENE --preset P``: the pipeline with the scene's tables.
``eval UNIT IN.npy OUT.npy``
    Reads real input values (float64, shape ``(K,)`` or ``(K, inputs)``), which must be exactly representable in
    the input formats (else an error naming the file, column and first bad row, and nothing is written); writes
    the real value of every output as float64, shape ``(K, outputs)``. ``--hex FILE`` also writes ``$readmemh``
    vectors (input codes then expected output codes, packed; see :mod:`fxmodel.core.vectors`).
``errors UNIT``
    Measures the preset's error against exact math: exhaustively if the input space has at most 2**26 vectors,
    else over ``--random`` vectors plus the hard cases. Prints JSON (worst, mean, bound, faithful, monotone).
``render SCENE.toml OUT.png``
    Renders a scene through the bit-exact pipeline model (no simulator) and the two float references, and prints
    JSON with PSNR and the largest per-channel difference against each and the ``verdict``; ``--refs DIR`` also
    writes the references' images. Exits 1 when the frame is farther than ``--max-lsb`` (default: the documented
    scene bound, ``host.render.SCENE_BOUND_LSB``) from reference (a), and 2 when a fragment input does not fit
    the preset (it would be clamped; ``--allow-clamp`` draws it clamped and prints the counts).
``presets [UNIT]``
    Lists units and their presets.
``fit SCENE.toml --max-lsb 1``
    Measures the ranges the scene produces and searches the smallest formats and table sizes for which the
    bit-exact frame stays within ``--max-lsb`` of the float reference (a) on every well-conditioned pixel
    (widening first a preset that cannot draw the scene); writes the pipeline preset ``presets/<name>.toml``
    (``--name``, default ``<scene>-fit``; folder ``--out`` or ``$FXMODEL_PRESETS``) that ``--preset`` and
    ``make sim PRESET=<name>`` accept, and prints JSON: the knobs, the ranges, the final error at full size and
    the hardware estimate against ``default``.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import build_dir
from fxmodel.core.unit import BLOCK_MODULES, preset, preset_names, unit_class, units
from fxmodel.core.vectors import write_readmemh
from fxmodel.units import exact
from host.args import SIZE_HELP, cube_size_arg, int_range, size_arg
from host.atomic import (
    atomic_save_npy,
    check_output_dir,
    check_output_file,
    check_output_not_input,
    strict_json,
)
from host.truth import DEFAULT_SAMPLES

EXHAUSTIVE_LIMIT = 1 << 26


def _params(args):
    unit_class(args.unit)
    return preset(args.unit, args.preset)


def cmd_info(args) -> int:
    if args.scene is not None:
        if args.unit != "pipeline":
            raise SystemExit(f"error: --scene sets the tables of the pipeline only, not of {args.unit!r}") from None
        from host.render import pipeline_params
        try:
            params = pipeline_params(args.scene, args.preset)
        except (ValueError, KeyError) as exc:
            raise SystemExit(f"error: {exc}") from None
        print(json.dumps({"preset": args.preset, "scene": args.scene, **params.info()}, indent=2))
        return 0
    params = _params(args)
    print(json.dumps({"preset": args.preset, **params.info()}, indent=2))
    return 0


def load_npy(path) -> np.ndarray:
    """A ``.npy`` array from an untrusted file: never a pickle (``allow_pickle=False``), and its header's shape
    and dtype checked against the file's size before numpy allocates the array (a 130-byte file declaring
    ``shape (10**12,)`` made ``np.load`` ask for 7 TiB and end in a ``MemoryError`` traceback). Raises
    ``ValueError`` (or ``OSError``) naming what is wrong."""
    path = Path(path)
    with open(path, "rb") as fh:
        version = np.lib.format.read_magic(fh)
        read_header = {(1, 0): np.lib.format.read_array_header_1_0,
                       (2, 0): np.lib.format.read_array_header_2_0}.get(version)
        if read_header is None:
            raise ValueError(f"unsupported .npy format version {version}")
        shape, _, dtype = read_header(fh, max_header_size=10_000)
        data = os.fstat(fh.fileno()).st_size - fh.tell()
    if dtype.hasobject:
        raise ValueError(f"dtype {dtype} holds Python objects (a pickle), which are never loaded")
    need = math.prod(shape) * dtype.itemsize
    if need != data:
        raise ValueError(f"its header declares shape {shape} of {dtype} ({need:,} bytes), but the file holds "
                         f"{data:,} bytes of data")
    return np.load(path, allow_pickle=False)


def cmd_eval(args) -> int:
    params = _params(args)
    check_output_file(args.output, "output", inputs=[args.input])     # before any work: nothing half done
    if args.hex:
        check_output_file(args.hex, "--hex file", inputs=[args.input, args.output])
    src = Path(args.input)
    try:
        values = load_npy(src)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"error: cannot read {src} as a .npy array: {exc}") from None
    if values.ndim == 1 and len(params.inputs) == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[1] != len(params.inputs):
        names = ", ".join(p.name for p in params.inputs)
        raise SystemExit(f"error: {src}: expected shape (K, {len(params.inputs)}) for inputs ({names}), "
                         f"got {values.shape}")
    if not np.issubdtype(values.dtype, np.floating) and not np.issubdtype(values.dtype, np.integer):
        raise SystemExit(f"error: {src}: expected real numbers (float64), got dtype {values.dtype}") from None
    try:
        codes = np.stack([p.fmt.from_real(values[:, i], what=f"{src} column {i} ({p.name})")
                          for i, p in enumerate(params.inputs)], axis=1)
    except ValueError as exc:
        raise SystemExit(f"error: {exc}") from None
    out = params.compute(codes)
    reals = np.stack([p.fmt.to_real(out[:, i]) for i, p in enumerate(params.outputs)], axis=1)
    atomic_save_npy(args.output, reals)
    if args.hex:
        fields = [(p.name, p.fmt) for p in params.inputs + params.outputs]
        write_readmemh(args.hex, fields, np.concatenate([codes, out], axis=1))
    return 0


def cmd_errors(args) -> int:
    params = _params(args)
    if args.unit not in exact.MEASURES:
        raise SystemExit(f"error: no error measure for unit {args.unit!r}; have {', '.join(exact.MEASURES)}") from None
    space = params.input_space()
    if space <= EXHAUSTIVE_LIMIT and not args.random:
        inputs, how = params.all_inputs(), "exhaustive"
    else:
        rng = np.random.default_rng(args.seed)
        inputs = np.concatenate([params.hard_cases(), params.random_inputs(rng, args.random or 1_000_000)])
        how = f"{len(inputs)} random and hard-case vectors"
    t0 = time.perf_counter()
    out = params.compute(inputs)
    seconds = time.perf_counter() - t0
    report = {"unit": args.unit, "preset": args.preset, "coverage": how,
              **exact.MEASURES[args.unit](params, inputs if len(params.inputs) > 1 else inputs[:, 0], out),
              "model_seconds": round(seconds, 3)}
    if args.unit == "recip":
        report["monotone"] = exact.recip_monotone(inputs[:, 0], out[:, 0], out[:, 1]) if how == "exhaustive" \
            else "needs the exhaustive run"
    print(json.dumps(report, indent=2))
    return 0


def render_summary(args, report: dict) -> str:
    """The few lines ``bumpmap render`` prints (``--json``: the whole report instead)."""
    from host.images import db_text, disagreement_row, summary_table, truth_rows, verdict_row
    rows = [("scene", f"{report.get('scene', args.scene)} ({report['width']}x{report['height']}, preset "
                      f"{args.preset})"),
            ("drawn from", "triangles (the engine)" if args.triangles else "fragments (the float front end)"),
            ("pixels", f"{report['pixels']:,}"),
            ("vs float (a)", f"{db_text(report['psnr_db_vs_float'])} (max {report['max_lsb_vs_float']} LSB)"),
            ("vs ideal (b)", f"{db_text(report['psnr_db_vs_ideal'])} (max {report['max_lsb_vs_ideal']} LSB)"),
            *truth_rows(report),
            *([disagreement_row(report)] if "depth" in report else []),   # pixels the comparisons leave out
            verdict_row(report),
            ("output", args.output + (f", references in {args.refs}" if args.refs else ""))]
    return summary_table(rows)


def preset_file(name) -> Path | None:
    """The file of pipeline preset ``name`` if it is read from one (not built in, a valid name), else ``None``:
    an input an output must not overwrite."""
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS, preset_path
    if not isinstance(name, str) or name in BUILTIN_PRESET_UNITS:
        return None
    try:
        return preset_path(name)
    except ValueError:
        return None


def scene_images(scene) -> list:
    """The PNG files a loaded scene reads (its materials' color textures and bump maps)."""
    return [spec.path for m in scene.materials for spec in (m.color, m.bump) if spec is not None and spec.path]


def cmd_render(args) -> int:
    from host.render import (
        REFERENCE_IMAGES,
        from_triangles,
        judge,
        prepare,
        render,
        render_triangles,
        save_png,
        tell,
    )
    from host.scene import SceneError
    check_output_file(args.output, "output PNG", inputs=[args.scene, preset_file(args.preset)])  # before any work
    if args.refs:
        check_output_dir(args.refs, "--refs folder")
    try:
        frame = prepare(args.scene, size=args.size, preset=args.preset, cube_size=args.cube_size,
                        allow_clamp=args.allow_clamp)
        # the scene's PNG maps, known once it is read: still before anything is written
        check_output_not_input(args.output, "output PNG", scene_images(frame.scene))
        if args.refs:                   # the references' fixed names: none may be an input or the output PNG
            inputs = [args.scene, preset_file(args.preset), args.output, *scene_images(frame.scene)]
            for name in REFERENCE_IMAGES:
                ref = Path(args.refs) / f"{name}.png"
                if ref.resolve() == Path(args.output).resolve():
                    if name == "model":     # the same picture as the output: written twice, the same bytes
                        continue
                    raise OSError(f"output PNG {args.output}: is --refs' {name}.png, which the run also writes; "
                                  "give another output path or --refs folder")
                check_output_file(ref, f"--refs image {name}.png", inputs=inputs)
        tframe = from_triangles(frame) if args.triangles else None
    except (SceneError, OSError) as exc:
        raise SystemExit(f"error: {exc}") from None
    if tframe is not None:
        report = render_triangles(tframe, args.refs, truth_samples=args.truth)
        save_png(args.output, tframe.image(report.pop("_triangle_bytes")[:, 2:5].astype("uint8")))
    else:
        report = render(frame, args.refs, truth_samples=args.truth)
        save_png(args.output, frame.image(report.pop("_model_bytes")))
    judge(report, args.max_lsb)
    print(strict_json(report) if args.json else render_summary(args, report))
    if not report["pixels"]:
        print(f"warning: {args.scene}: nothing is drawn: no triangle covers a pixel of the {report['width']}x"
              f"{report['height']} frame (camera behind or inside the geometry, or everything clipped or culled); "
              f"{args.output} shows the background only", file=sys.stderr)
    return tell(report, args.scene)


def cmd_fit(args) -> int:
    from fxmodel.pipeline.presets import check_preset_name, preset_path, presets_dir
    from host.scene import SceneError

    from .fit import FitError, fit
    if args.name is not None:                                   # before any work: nothing written elsewhere
        check_preset_name(args.name)
        # `fit scenes/a.toml --out scenes --name a` would replace the scene with the preset (the default name,
        # <stem>-fit, never names the scene file)
        check_output_not_input(preset_path(args.name, args.out), "preset file", [args.scene])
    check_output_dir(args.out if args.out is not None else presets_dir(), "preset folder")
    try:
        report = fit(args.scene, max_lsb=args.max_lsb, size=args.size or None, cube_size=args.cube_size,
                     name=args.name, directory=args.out, progress=not args.quiet, passes=args.passes,
                     scene_size=args.scene_size, jobs=args.jobs, scheduler=args.scheduler)
    except (SceneError, OSError) as exc:
        raise SystemExit(f"error: {exc}") from None
    except FitError as exc:                                     # no preset within the limits meets --max-lsb
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(strict_json(report))
    return 0


def cmd_presets(args) -> int:
    for name in ([args.unit] if args.unit else units() + list(BLOCK_MODULES)):
        print(f"{name}: {', '.join(preset_names(name))}")
    return 0


def _unit_arg(p):
    p.add_argument("unit", help=f"one of: {', '.join(units() + list(BLOCK_MODULES))}")
    p.add_argument("--preset", default="default", help="named parameter set (default: %(default)s)")


def add_info_arguments(p):
    _unit_arg(p)
    p.add_argument("--scene", help="pipeline only: with this scene's tables (name in scenes/ or a .toml file); "
                   "--preset may then name a preset file (presets/<name>.toml)")


def add_eval_arguments(p):
    _unit_arg(p)
    p.add_argument("input", help="IN.npy: float64, shape (K,) or (K, inputs)")
    p.add_argument("output", help="OUT.npy: float64, shape (K, outputs)")
    p.add_argument("--hex", help="also write $readmemh vectors (inputs then expected outputs) to this file")


def add_errors_arguments(p):
    _unit_arg(p)
    p.add_argument("--random", type=int_range(0, 1 << 30), default=0,
                   help="use this many random vectors instead (0 .. 2^30)")
    p.add_argument("--seed", type=int_range(0, 2**32 - 1), default=1)


def add_render_arguments(p):
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("output", help="PNG to write")
    p.add_argument("--size", type=size_arg(), help=SIZE_HELP)
    p.add_argument("--preset", default="default", help="pipeline preset (default: %(default)s)")
    p.add_argument("--cube-size", type=cube_size_arg(),
                   help="texels per reflectance-cube face edge, 1 .. 1024 (default: the preset's, 64 "
                        "unless a preset file sets it)")
    p.add_argument("--refs", metavar="DIR", help="also write the float references' images (and diff.png) into DIR")
    p.add_argument("--json", action="store_true", help="print the whole report as JSON instead of the summary")
    p.add_argument("--truth", type=int_range(0, 32), default=DEFAULT_SAMPLES, metavar="K",
                   help="judge the frame against reference (c), the true image: K x K samples per pixel, a power "
                        "of two (default: %(default)s, the documented choice; 0 leaves it out)")
    p.add_argument("--triangles", action="store_true", help="draw from triangles (the engine's set-up, scan "
                   "converter and interpolators; the report adds the frame from fragments beside it)")
    from host.render import bound_args
    bound_args(p)


def add_fit_arguments(p):
    from host.scene import MAX_IMAGE_SIZE
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--max-lsb", type=int_range(0, 255), default=1,
                   help="allowed per-channel error vs reference (a), 8-bit steps (0 .. 255)")
    p.add_argument("--size", type=int_range(0, MAX_IMAGE_SIZE), default=64,
                   help=f"square size of the screening renders, 0 .. {MAX_IMAGE_SIZE} (0: full size only); "
                        "every accepted step is also checked at the scene's size (default: %(default)s)")
    p.add_argument("--cube-size", type=cube_size_arg(),
                   help="texels per reflectance-cube face edge to start from, 1 .. 1024 (a "
                        "knob of the search; default: the default preset's, 64)")
    p.add_argument("--name", help="preset name: letters, digits, '_', '.', '+', '-' (default: <scene file stem>-fit)")
    p.add_argument("--out", help="preset folder (default: $FXMODEL_PRESETS or presets/ at the repo root)")
    p.add_argument("--scene-size", type=size_arg(), help="render the scene at this square size instead of its own")
    p.add_argument("--passes", type=int_range(1, 100), default=2, help="passes over the knobs, 1 .. 100 (default: "
                   "%(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from .jobs import add_arguments
    add_arguments(p, what="candidate presets rendered")


def add_presets_arguments(p):
    p.add_argument("unit", nargs="?")


def add_verilog_arguments(p):
    p.add_argument("--unit", action="append", help="unit name (repeatable; default: all)")
    p.add_argument("--preset", action="append", help="preset name (repeatable; default: all of each unit; "
                   "with --scene: pipeline presets, default 'default')")
    p.add_argument("--scene", help="the pipeline with this scene's tables (name in scenes/ or a .toml file)")
    p.add_argument("--out", default=str(build_dir("verilog")), help="output folder (default: %(default)s)")


def _check_verilog_out(args) -> None:
    check_output_dir(args.out, "--out folder")


def cmd_verilog(args) -> int:
    """Without ``--scene``: ``OUT/<unit>_<preset>.v``, every registered unit (or ``--unit``) and every preset of
    each (or ``--preset``). With ``--scene``: the pixel pipeline or the engine with that scene's memories and each
    pipeline ``--preset``, as ``OUT/<unit>_<preset>_<scene>.v`` (:func:`tools.fpga.design_list`)."""
    from rtl.verilog import write_verilog

    from .fpga import design_list, scene_hint
    _check_verilog_out(args)
    try:
        if args.scene is not None:
            for label, params in design_list(args.unit, args.preset, scene=args.scene):
                stem = "_".join(label.values())
                print(f"wrote {write_verilog(params, f'{args.out}/{stem}.v')}")
            return 0
        for unit in args.unit or units():
            for name in args.preset or preset_names(unit):
                print(f"wrote {write_verilog(preset(unit, name), f'{args.out}/{unit}_{name}.v')}")
    except ValueError as exc:
        print(f"error: {exc}{scene_hint(args.preset) if args.scene is None else ''}", file=sys.stderr)
        return 2
    return 0


#: The commands of this module (``tools.main``): name -> (help, add arguments, run).
COMMANDS = {
    "info": ("ports, formats, latency, error bound and cost estimate of a unit (JSON)", add_info_arguments, cmd_info),
    "eval": ("run the golden model on real values from a .npy file", add_eval_arguments, cmd_eval),
    "errors": ("measure the error against exact math (exhaustive when feasible)", add_errors_arguments, cmd_errors),
    "render": ("render a scene through the bit-exact pipeline model (no simulator)", add_render_arguments,
               cmd_render),
    "fit": ("scene-driven word lengths: the smallest preset within --max-lsb of float", add_fit_arguments, cmd_fit),
    "presets": ("list units and presets", add_presets_arguments, cmd_presets),
    "verilog": ("write Verilog for units and presets, or the pipeline with a scene's tables", add_verilog_arguments,
                cmd_verilog),
}
