"""``make bench``: throughput of the golden model and of the co-simulation, as medians over repeats.

Model: whole-array ``compute`` over every input of the 24-bit reciprocal (2**24 codes) and over 10**6 random
divider inputs, median of ``--repeat`` runs, one core. Co-simulation: vectors per second of the per-vector
cocotb harness and of the streaming harness (``cosim/stream.py``: the stream version of the unit, vectors from
memory files, compared in HDL) on each available simulator (build time excluded), the streaming harness without
stalls (the whole input space counted by the wrapper, as ``make exhaustive`` runs) and with backpressure in the
loop (random inputs from vector files, pattern ``random``: input valid and output ready each high half the time),
and the same two runs through a one-register stand-in with the unit's ports (``stand_in_verilog``): what the
harness itself costs, the floor under the unit's rate. Each streaming row is the median of ``--repeat`` runs
(``--stream-only`` runs just those rows, ``--sim`` picks the simulators).
Machines here are shared and noisy: the figures are medians, the ratios between them mean more than any one
number, and the streaming rows also give vectors per CPU second of the simulator process (what a loaded machine
changes least).

Fixed-point core: the project's own narrowing (:mod:`fxmodel.core.rounding`) against apytypes'
(:mod:`fxmodel.units.apy_oracle`) on ``--core-products`` random products, one core each, so the choice of an own core
stays measured (``--core-only`` runs just this).

Icarus profile (``--icarus-profile UNIT``, needs ``valgrind``): the instructions Icarus' ``vvp`` executes a
clock cycle and a vector of the streaming harness around the unit (or, with ``--stand-in``, around the
one-register stand-in: the harness alone), counted by ``valgrind --tool=callgrind`` as the count of a run of
``--profile-vectors`` (default 4096) vectors minus that of a run of 16, so that start-up (the simulator, the
embedded Python, the build's loading) cancels; ``--pattern random`` puts the random gaps and backpressure in the
loop. Writes ``build/bench/icarus_profile.json`` and keeps both callgrind files beside it (for
``callgrind_annotate``).

Writes ``build/bench/bench.json`` and prints a Markdown table. Second phase (skip with ``--no-sweep``): the
design-space sweep, speed against error of the reciprocal, the other units' widths and pipeline presets
(:mod:`tools.sweep`: ``build/bench/speed_vs_error.{json,md}``, ``build/bench/pareto.png`` and
``build/bench/units.png``), with the ECP5 flow on at most ``--fpga-points`` reciprocal points and each other unit's
default preset and cheapest front point (cached under ``build/fpga``; ``--no-fpga`` skips it).
"""

from __future__ import annotations

import argparse
import platform
import shutil
import statistics
import time

import apytypes
import numpy as np
from tqdm import tqdm

from cosim.harness import run as cosim_run
from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import build_dir
from fxmodel.core.rounding import Overflow, Rounding, narrow
from fxmodel.core.unit import preset
from fxmodel.units.apy_oracle import OVERFLOW, QUANTIZATION, codes_of, narrow_apy, to_apy
from host.args import int_range
from host.atomic import atomic_json
from tools.record import add_record_option, machine, write_if_asked


def median_seconds(fn, repeat: int, warm_up=None) -> float:
    """Median wall time of ``fn()`` over ``repeat`` runs, after one untimed ``warm_up()`` (default ``fn``)."""
    (warm_up or fn)()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def model_rate(params, inputs, repeat: int) -> float:
    # build tables and cached formats outside the timing
    return len(inputs) / median_seconds(lambda: params.compute(inputs), repeat, lambda: params.compute(inputs[:1000]))


#: The fixed-point core comparison: products of two :data:`CORE_SRC` words narrowed to :data:`CORE_DST`.
CORE_SRC, CORE_DST = Fmt.parse("s2.16"), Fmt.parse("s2.14")


def core_rates(n: int, repeat: int, rng: np.random.Generator) -> list[dict]:
    """The project's fixed-point core (:mod:`fxmodel.core.rounding`) against apytypes on the same narrowing: ``n``
    random products of two :data:`CORE_SRC` arrays narrowed to :data:`CORE_DST`, half-up and saturating, one core
    each (apytypes' thread pool set to one thread). The product is part of the timed work on both sides; the inputs
    are each side's own array type. Refuses to report a speed if the two results are not bit-identical."""
    src, dst, rounding, overflow = CORE_SRC, CORE_DST, Rounding.HALF_UP, Overflow.SATURATE
    a = rng.integers(src.min_code, src.max_code, n, endpoint=True)
    b = rng.integers(src.min_code, src.max_code, n, endpoint=True)
    A, B = to_apy(a, src), to_apy(b, src)
    threads = apytypes.n_threads()
    apytypes.reset_thread_pool(1)
    try:
        own = narrow(a * b, 2 * src.frac_bits, dst, rounding, overflow)
        apy = narrow_apy(A * B, dst, rounding, overflow)
        if not (np.array_equal(own[0], apy[0]) and np.array_equal(own[1], apy[1])):
            raise SystemExit("fxmodel.core.rounding and apytypes differ on the bench's narrowing: run "
                             "pytest tests/fxmodel/units/test_apy_oracle.py to see where")
        cast = dict(int_bits=dst.int_bits, frac_bits=dst.frac_bits, quantization=QUANTIZATION[rounding],
                    overflow=OVERFLOW[overflow])
        runs = [("fxmodel.core.rounding.narrow (own core): codes and flag",
                 lambda: narrow(a * b, 2 * src.frac_bits, dst, rounding, overflow)),
                ("apytypes APyFixedArray.cast (RND, SAT): codes", lambda: codes_of((A * B).cast(**cast))),
                ("apytypes, codes and flag (a second cast)", lambda: narrow_apy(A * B, dst, rounding, overflow))]
        what = f"{n / 1e6:g} M random {src} * {src} -> {dst} half-up, saturate"
        return [{"what": name, "workload": what, "per_second": n / median_seconds(fn, repeat)} for name, fn in runs]
    finally:
        apytypes.reset_thread_pool(threads)


def _callgrind_total(path) -> int:
    """The total instruction count (``Ir``) of a callgrind output file (its ``summary:`` or ``totals:`` line)."""
    from pathlib import Path
    for line in Path(path).read_text(errors="replace").splitlines():
        if line.startswith(("summary:", "totals:")):
            return int(line.split()[1])
    raise RuntimeError(f"{path}: no summary line (did callgrind finish?)")


def icarus_profile(unit: str, name: str = "default", pattern: str = "none", stand_in: bool = False,
                   vectors: int = 4096, small: int = 16) -> dict:
    """Instructions a cycle and a vector of Icarus on the streaming harness around ``unit`` (preset ``name``):
    callgrind's count for ``vectors`` vectors minus that for ``small`` (module docstring). ``pattern="none"``
    streams the first rows of the input space counted by the wrapper, ``"random"`` random inputs from the vector
    files under random gaps and backpressure (as :func:`cosim.stream.measure_throughput`). Every output is checked
    bit for bit (the stand-in's are not the model's and are not judged)."""
    import os

    from cosim.stream import measure_throughput
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        raise SystemExit("--icarus-profile needs valgrind on PATH (apt-get install valgrind)")
    if not 1 <= small < vectors:
        raise SystemExit(f"--profile-vectors {vectors}: must be more than {small}")
    params = preset(unit, name)
    out = build_dir("bench")
    out.mkdir(parents=True, exist_ok=True)
    tag = f"{unit}_{name}_{pattern}{'_stand_in' if stand_in else ''}"
    runs = {}
    old = os.environ.get("SIM_CMD_PREFIX")
    try:
        for n in (small, vectors):
            path = out / f"callgrind_{tag}_{n}.out"
            path.unlink(missing_ok=True)
            # cocotb's Icarus runner puts SIM_CMD_PREFIX in front of vvp
            os.environ["SIM_CMD_PREFIX"] = f"{valgrind} --tool=callgrind --callgrind-out-file={path}"
            res = measure_throughput(params, "icarus", vectors=n, inputs="exhaustive" if pattern == "none" else
                                     "random", pattern=pattern, stand_in=stand_in)
            runs[n] = {"instructions": _callgrind_total(path), "cycles": res["cycles"], "vectors": res["vectors"],
                       "callgrind": str(path)}
    finally:
        if old is None:
            os.environ.pop("SIM_CMD_PREFIX", None)
        else:
            os.environ["SIM_CMD_PREFIX"] = old
    a, b = runs[small], runs[vectors]
    di, dc, dv = b["instructions"] - a["instructions"], b["cycles"] - a["cycles"], b["vectors"] - a["vectors"]
    report = {"unit": unit, "preset": name, "pattern": pattern, "stand_in": stand_in, "runs": runs,
              "instructions_per_cycle": round(di / dc), "instructions_per_vector": round(di / dv),
              "cycles_per_vector": round(dc / dv, 3)}
    atomic_json((out / "icarus_profile.json"), report, indent=2)
    return report


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap bench``, :mod:`tools.main`)."""
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cosim-vectors", type=int, default=30_000)
    ap.add_argument("--core-products", type=int, default=4_000_000,
                    help="random products narrowed by the own fixed-point core and by apytypes (0 skips)")
    ap.add_argument("--core-only", action="store_true", help="only the fixed-point core comparison (no sweep)")
    ap.add_argument("--stream-only", action="store_true",
                    help="only the streaming co-simulation rows (medians of --repeat runs; no sweep)")
    ap.add_argument("--sim", action="append", choices=("icarus", "verilator"),
                    help="simulator of the co-simulation rows (repeatable; default: every one installed)")
    ap.add_argument("--no-sweep", action="store_true", help="skip the design-space sweep (tools.sweep)")
    ap.add_argument("--no-fpga", action="store_true", help="sweep without the ECP5 flow")
    ap.add_argument("--fpga-points", type=int_range(0, 6), default=6,
                    help="sweep points placed and routed (0 to 6, cached; each new design takes 1-2 minutes)")
    from . import jobs as jobrunner
    jobrunner.add_arguments(ap, jobs=2, what="sweep points and FPGA designs")
    ap.add_argument("--docs", action="store_true", help="also write docs/img/pareto.png and docs/img/units.png")
    ap.add_argument("--icarus-profile", metavar="UNIT",
                    help="only count Icarus' instructions a cycle on the streaming harness around UNIT (valgrind)")
    ap.add_argument("--preset", default="default", help="--icarus-profile: the unit's preset")
    ap.add_argument("--pattern", default="none", choices=("none", "random"),
                    help="--icarus-profile: no stalls, or random gaps and backpressure")
    ap.add_argument("--stand-in", action="store_true",
                    help="--icarus-profile: around the one-register stand-in (the harness alone)")
    ap.add_argument("--profile-vectors", type=int, default=4096,
                    help="--icarus-profile: vectors of the long run (the short one has 16)")

    add_record_option(ap, "the throughput rows")


def run(args: argparse.Namespace) -> int:
    before = machine()
    if args.icarus_profile:
        rep = icarus_profile(args.icarus_profile, args.preset, args.pattern, args.stand_in, args.profile_vectors)
        what = "the harness alone (stand-in)" if args.stand_in else f"{rep['unit']} ({rep['preset']})"
        print(f"Icarus on {what}, pattern {rep['pattern']}: {rep['instructions_per_cycle']:,} instructions a cycle, "
              f"{rep['instructions_per_vector']:,} a vector ({rep['cycles_per_vector']} cycles a vector; callgrind "
              f"count of {args.profile_vectors} vectors minus that of 16)")
        for n, r in rep["runs"].items():
            print(f"  {n} vectors: {r['instructions']:,} instructions, {r['cycles']:,} cycles ({r['callgrind']})")
        return 0
    rows = []
    rng = np.random.default_rng(1)
    jobs = [("model", "recip", "default", "all 2^24 inputs"), ("model", "recip", "small", "all 2^16 inputs"),
            ("model", "divide", "default", "10^6 random")]
    sims = [s for s, tool in (("icarus", "iverilog"), ("verilator", "verilator"))
            if shutil.which(tool) and (not args.sim or s in args.sim)]
    jobs += [("cosim", "recip", "default", sim) for sim in sims]
    jobs += [(f"stream-{pattern}", "recip", "default", sim) for sim in sims for pattern in ("none", "random")]
    jobs += [(f"floor-{pattern}", "recip", "default", sim) for sim in sims for pattern in ("none", "random")]
    if args.stream_only:
        jobs = [j for j in jobs if j[0].startswith(("stream", "floor"))]
    if args.core_products and not args.stream_only:
        rows += core_rates(args.core_products, args.repeat, np.random.default_rng(2))
    if args.core_only:
        jobs = []
    for kind, unit, name, what in tqdm(jobs, desc="bench", unit="job", disable=not jobs):
        params = preset(unit, name)
        if kind == "model":
            inputs = params.all_inputs() if params.input_space() <= 1 << 24 else params.random_inputs(rng, 10 ** 6)
            rate = model_rate(params, inputs, args.repeat)
            rows.append({"what": f"model {unit} ({name})", "workload": what, "per_second": rate})
        elif kind.startswith(("stream", "floor")):
            from cosim.stream import measure_throughput
            pattern, floor = kind.split("-")[1], kind.startswith("floor")
            runs = [measure_throughput(params, what, inputs="exhaustive" if pattern == "none" else "random",
                                       pattern=pattern, stand_in=floor) for _ in range(args.repeat)]
            res = runs[0]
            label = "no stalls" if pattern == "none" else "random gaps and backpressure"
            head = f"streaming harness alone (a one-register stand-in with {unit}'s ports)" if floor else \
                f"co-simulation {unit} ({name}), streaming"
            rows.append({"what": f"{head}, {label}", "workload": what,
                         "per_second": statistics.median(r["vectors_per_second"] for r in runs),
                         "per_cpu_second": statistics.median(r["vectors"] / r["sim_cpu_seconds"] for r in runs),
                         "cycles": res["cycles"], "vectors": res["vectors"], "runs": len(runs)})
        else:
            vectors = params.random_inputs(rng, args.cosim_vectors)
            res = cosim_run(params, vectors, sim=what, tag="bench")
            if res["mismatches"]:
                raise SystemExit(res.describe())
            rows.append({"what": f"co-simulation {unit} ({name}), per-vector cocotb", "workload": what,
                         "per_second": res["vectors_per_second"]})
    out = build_dir("bench")
    out.mkdir(parents=True, exist_ok=True)
    meta = {"machine": platform.platform(), "python": platform.python_version(), "repeat": args.repeat}
    atomic_json((out / "bench.json"), {"meta": meta, "results": rows}, indent=2)
    print("\n| measurement | workload | per second | per CPU second |\n|---|---|---:|---:|")
    for r in rows:
        cpu = f"{r['per_cpu_second']:,.0f}" if "per_cpu_second" in r else ""
        print(f"| {r['what']} | {r['workload']} | {r['per_second']:,.0f} | {cpu} |")
    print(f"\n(written to {out / 'bench.json'})")
    write_if_asked(args, {"meta": meta, "results": rows}, before)
    if args.no_sweep or args.core_only or args.stream_only:
        return 0
    sweep_argv = (["--no-fpga"] if args.no_fpga else ["--fpga-points", str(args.fpga_points)]) + [
        "--jobs", str(args.jobs), "--out", str(out)] + (["--docs"] if args.docs else []) + (
        ["--scheduler", args.scheduler] if args.scheduler else [])
    print("\nSpeed against error (bumpmap sweep):\n")
    from .main import main
    return main(["sweep", *sweep_argv])
