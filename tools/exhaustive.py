"""``make exhaustive``: exhaustive (or documented large) RTL equivalence runs on the streaming co-simulation.

Every target of :data:`TARGETS` is streamed through its RTL on each simulator of ``--sim`` and compared with the
golden model, bit for bit, by :func:`cosim.stream.run_stream`. Prints vectors, mismatches, seconds and vectors/s
per unit and simulator, and writes ``build/exhaustive/report.json``: a list of records with ``unit``, ``preset``,
``simulator``, ``vectors``, ``mismatches``, ``seconds``, ``vectors_per_second`` (and ``space``, ``valid_errors``,
``missing``, ``first`` mismatches, ``shards``, ``wall_seconds``, ``build_seconds``, ``ok``). A record replaces
the earlier one of the same unit, preset and simulator; the others stay.

Sharding
--------
``--shard i/N`` checks only the ``i``-th of ``N`` contiguous index ranges of every selected target (1-based) and
writes ``build/exhaustive/shards/<unit>-<preset>-<sim>-<i>of<N>.json``; once all ``N`` shard files of a run are
present (copy them there from other machines of a batch system), the shards are merged into the report
automatically, or by ``--merge``. Merged records sum ``vectors`` and ``mismatches``. (Without ``--shard`` the
pieces run on Dask, below: no files to copy.)

Running on Dask (:mod:`tools.jobs`)
-----------------------------------
Without ``--shard``, each target is cut into pieces of at most :data:`PIECE` vectors (``--pieces`` to choose; a
multiple of the workers) that run as Dask tasks: ``--jobs N`` single-threaded worker processes on this machine,
or the workers of the cluster at ``--scheduler`` (``$DASK_SCHEDULER_ADDRESS``). A piece carries its parameter
object and index range, builds its simulation on its worker (cached there by content) and returns its record;
the client merges them as the shard files are merged. Each piece's record is stored in
``build/jobs/exhaustive/`` under a key of unit, parameter object, simulator, RTL digest, input space and range, so
a rerun after an interruption checks only the missing pieces (``--no-resume`` to redo them). A mismatch in any
piece is reported with its vectors as a single-process run reports it.

``--sim exact`` is the model side of a proof: the bit-exact model against exact math over the same pieces
(:mod:`tools.prove`; a *mismatch* is then an output outside the unit's documented error bound).
``--throughput N`` measures the rate on ``N`` inputs of each target with 1 and with 2 local workers in one run
(``--repeat`` alternating rounds, medians; ``build/exhaustive/throughput.json``) and projects the whole space for
more workers. ``--select A:B`` checks pieces ``A..B`` of a run only (a partial record: ``pieces``, ``fraction``);
the whole run resumes from them. ``--record FILE`` also enters the records in ``FILE``: the committed figures of
``docs/exhaustive/``.

``seconds`` is the time the check took. For a run on one machine (``--jobs N`` included) that is the wall time; for
shards merged from their files (``--shard``, perhaps run on several machines at different times) it is the sum of
the shards' times, what one process would have taken. ``process_seconds`` is always that sum and
``wall_seconds`` the span from the first start to the last finish; ``vectors_per_second = vectors / seconds``.

Examples::

    bumpmap exhaustive --sim icarus,verilator --jobs 2     # what `make exhaustive` runs
    bumpmap exhaustive --sim verilator --only recip:default --shard 3/8
    bumpmap exhaustive --merge
    bumpmap exhaustive --list
    bumpmap exhaustive --sim exact,verilator --only recip:rcp32 --jobs 2   # `make exhaustive-wide`
    bumpmap exhaustive --sim exact --only recip:rcp32 --throughput 67108864
    DASK_SCHEDULER_ADDRESS=tcp://head:8786 bumpmap exhaustive --sim verilator --only recip:rcp32

Exit status: 0 when every record is bit-exact, 1 on any mismatch or valid-protocol error, 2 on a usage error.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cosim.harness import simulator
from cosim.stream import AHEAD, Space, full_space, grid_space, parse_pair, parse_shard, run_stream, shard_range
from fxmodel.core.unit import preset
from host.atomic import atomic_json
from rtl.digest import params_key

from . import jobs as jobrunner
from .exhaustive_report import EXACT, OUT, REPORT, SHARDS, merge_records, merge_shards, table, update_report
from .exhaustive_report import failures as _failures
from .prove import check_range

__all__ = ["Target", "TARGETS", "target", "run_target", "merge_shards", "update_report", "REPORT", "SHARDS"]

#: Largest input space a target may check whole without naming a subset (``--full`` overrides).
FULL_LIMIT = 1 << 32
#: Most vectors in one Dask task, per simulator (a Verilator piece takes about a minute on a free core).
PIECE = {"verilator": 1 << 25, "icarus": 1 << 22, "exact": 1 << 25}
#: Results of finished pieces (resume).
CACHE = jobrunner.CACHE / "exhaustive"


@dataclass(frozen=True)
class Target:
    """One exhaustive run: a unit's preset and the input space it covers.

    ``space`` maps the parameter object to a :class:`~cosim.stream.Space`; ``None`` means every input.
    ``why`` documents a subset in the report.
    """

    unit: str
    preset: str = "default"
    space: Callable | None = None
    why: str = ""

    @property
    def name(self) -> str:
        return f"{self.unit}:{self.preset}"

    def params(self):
        return preset(self.unit, self.preset)

    def make_space(self, full: bool = False) -> Space:
        params = self.params()
        if self.space is None or full:
            if params.input_space() > FULL_LIMIT and not full:
                raise ValueError(f"{self.name}: {params.input_space()} inputs is too many to check whole: give the "
                                 "target a documented subset (e.g. grid_space)")
            return full_space(params)
        return self.space(params)


#: The runs of ``make exhaustive``. Adding a unit is one line.
TARGETS: tuple[Target, ...] = (
    Target("recip", "default"),                                        # all 2**24 inputs
    Target("recip", "small"),                                          # all 2**16 inputs
    # all 2**16 denominators x 133 numerators (every 512th code and the edge codes) + the hard cases: 8.8M vectors;
    # `--full` checks all 2**32 (about an hour on Verilator with --jobs 2).
    Target("divide", "default", lambda p: grid_space(p, 7, full=("d",)),
           "all d, n on every 512th code and the edge codes, plus the hard cases"),
    # Target("cube", "default", lambda p: grid_space(p, 7), "x, y, z on every 2048th code and the edge codes"),
)


def target(name: str) -> Target:
    """The target ``unit`` or ``unit:preset`` of :data:`TARGETS` (or a full-space run of any registered preset)."""
    unit, _, pre = name.partition(":")
    for t in TARGETS:
        if t.unit == unit and t.preset == (pre or "default"):
            return t
    preset(unit, pre or "default")                    # ValueError naming the unknown unit or preset
    return Target(unit, pre or "default")


def _shard_file(t: Target, sim: str, i: int, n: int) -> Path:
    return SHARDS / f"{t.unit}-{t.preset}-{sim}-{i}of{n}.json"


def _record(t: Target, result: dict, shard: tuple[int, int] | None, full: bool = False) -> dict:
    rec = {"unit": t.unit, "preset": t.preset, "simulator": result["simulator"], "vectors": result["vectors"],
           "mismatches": result["mismatches"], "seconds": result["seconds"],
           "vectors_per_second": result["vectors_per_second"], "process_seconds": result["seconds"],
           "ok": bool(result.ok if hasattr(result, "ok") else result["ok"]),
           "valid_errors": result["valid_errors"], "missing": result["missing"],
           "expected_vectors": result["expected_vectors"], "space": result["space"], "range": result["range"],
           "first": result["first"], "build_seconds": result["build_seconds"],
           "sim_cpu_seconds": result["sim_cpu_seconds"],
           "started": result["started"], "finished": result["finished"],
           "wall_seconds": round(result["finished"] - result["started"], 3)}
    for k in _EXACT_KEYS:
        if k in result:
            rec[k] = result[k]
    if t.why and not full:
        rec["subset"] = t.why
    if shard:
        rec["shard"] = list(shard)
    return rec


#: Extra fields of a model-against-exact-math record (tools.prove).
_EXACT_KEYS = ("max_error_ulp", "worst_index", "unfaithful", "bound_ulp")


def check(t: Target, sim: str, space: Space, lo: int, hi: int, *, shard: tuple[int, int] | None = None,
          full: bool = False, progress=None, chunk: int | None = None, ahead: int = AHEAD) -> dict:
    """The record of rows ``lo..hi`` of ``space`` of target ``t``: streamed through the RTL on ``sim`` against the
    model, or (``sim == "exact"``) the model against exact math. ``cpu_seconds`` is the CPU time of this
    process and of the simulator meanwhile; ``ahead`` as :func:`cosim.stream.run_stream` (1: one core)."""
    c0 = jobrunner.cpu_seconds()
    if sim == EXACT:
        result = check_range(t.params(), space, lo, hi)
    else:
        kwargs = {"chunk": chunk} if chunk else {}
        result = run_stream(t.params(), space, sim=sim, lo=lo, hi=hi, progress=progress, ahead=ahead, **kwargs)
    rec = _record(t, result, shard, full)
    rec["cpu_seconds"] = round(jobrunner.cpu_seconds() - c0, 3)
    return rec


def run_target(t: Target, sim: str, *, shard: tuple[int, int] | None = None, full: bool = False,
               progress=None, chunk: int | None = None) -> dict:
    """Run one target (or one shard of it) on ``sim`` in this process; a shard is also written to its shard file."""
    space = t.make_space(full)
    rec = check(t, sim, space, *shard_range(len(space), shard), shard=shard, full=full, progress=progress,
                chunk=chunk)
    if shard:
        SHARDS.mkdir(parents=True, exist_ok=True)
        atomic_json(_shard_file(t, sim, *shard), rec, indent=1)
    return rec


@dataclass(frozen=True)
class Piece:
    """One Dask task: shard ``shard[0]`` of ``shard[1]`` (rows ``lo..hi`` of ``space``) of a target on ``sim``."""

    target: Target
    sim: str
    space: Space
    lo: int
    hi: int
    shard: tuple[int, int]
    full: bool = False
    chunk: int | None = None
    #: Chunk files ahead of the simulator (:func:`cosim.stream.run_stream`): 1, one core a task, on Dask.
    ahead: int = 1

    def key(self) -> str:
        """What the piece checks: unit, parameter object, simulator, RTL digest, input space and range."""
        params = self.target.params()
        return jobrunner.content_key(self.target.unit, self.target.preset, params, self.sim, params_key(params),
                                     self.space.describe(), self.lo, self.hi)

    def describe(self) -> str:
        return (f"{self.target.name} on {self.sim}: piece {self.shard[0]}/{self.shard[1]} "
                f"(rows {self.lo}..{self.hi})")


def run_piece(piece: Piece) -> dict:
    """The record of one piece (runs on a Dask worker)."""
    return check(piece.target, piece.sim, piece.space, piece.lo, piece.hi, shard=piece.shard, full=piece.full,
                 progress=False, chunk=piece.chunk, ahead=piece.ahead)


def pieces(t: Target, sim: str, *, workers: int = 1, count: int | None = None, full: bool = False,
           chunk: int | None = None, lo: int = 0, hi: int | None = None, ahead: int = 1) -> list[Piece]:
    """Rows ``lo..hi`` (default: all) of the target cut into ``count`` pieces (default: pieces of at most
    :data:`PIECE` vectors, a multiple of ``workers``)."""
    space = t.make_space(full)
    hi = len(space) if hi is None else hi
    n = hi - lo
    if count is None:
        count = -(-n // PIECE[sim])
        count = workers * -(-count // workers)
    count = max(1, min(count, n))
    return [Piece(t, sim, space, lo + a, lo + b, (i, count), full, chunk, ahead)
            for i, (a, b) in enumerate((shard_range(n, (i, count)) for i in range(1, count + 1)), 1)]


def run_dask(t: Target, sim: str, *, jobs: int = 1, scheduler: str | None = None, full: bool = False,
             chunk: int | None = None, count: int | None = None, resume: bool = True, client=None,
             progress: bool = True, select: tuple[int, int] | None = None) -> dict:
    """Run a whole target as Dask tasks (:mod:`tools.jobs`) and merge the pieces' records; ``seconds`` is the
    wall time of this run (``resumed`` counts the pieces taken from the cache of an earlier run).

    ``select=(a, b)`` runs only pieces ``a..b`` (1-based) of the whole run's pieces: a partial run, whose record
    says which pieces (``pieces``) and what ``fraction`` of the space it covers; the whole run later resumes
    from them. Once the first ``jobs`` pieces of this run have finished, their median rate is the per-worker
    rate, and ``projection`` records the wall time it projects for this run's vectors on ``jobs`` workers, and
    the wall time the run then took (``ratio``: taken / projected)."""
    in_process = client is None and jobs == 1 and not jobrunner.scheduler_address(scheduler)
    # a Dask task takes one core (the model and the simulator take turns); in this process they may overlap
    ps = pieces(t, sim, workers=jobs, count=count, full=full, chunk=chunk, ahead=AHEAD if in_process else 1)
    if select is not None:
        a, b = select
        if not 1 <= a <= b <= len(ps):
            raise ValueError(f"--select {a}:{b}: {t.name} on {sim} has pieces 1..{len(ps)}")
        ps = ps[a - 1:b]
    done, projection = [], {}
    todo_vectors = None

    def arrived(i, rec):
        done.append((i, rec))
        if len(done) == jobs and todo_vectors and len(ps) > jobs:     # a projection needs pieces left to run
            rates = sorted(r["vectors"] / r["seconds"] for _, r in done if r["seconds"])
            if not rates:                       # every piece finished within the timer's resolution: no rate
                return
            rate = rates[len(rates) // 2]
            projection.update({"workers": jobs, "per_worker_rate": round(rate, 1), "from_pieces": jobs,
                               "vectors": todo_vectors, "projected_seconds": round(todo_vectors / (rate * jobs), 3),
                               "load_average": round(os.getloadavg()[0], 2)})
            msg = (f"{t.name} {sim}: per-worker rate {rate:,.0f} vectors/s from the first {jobs} piece(s); "
                   f"{todo_vectors:,} vectors on {jobs} worker(s) projected to take "
                   f"{projection['projected_seconds'] / 60:,.1f} min")
            from tqdm import tqdm
            tqdm.write(msg)

    if resume:
        # the vectors still to check (pieces not in the cache), for the projection
        todo_vectors = sum(p.hi - p.lo for p in ps if not (CACHE / f"{p.key()}.json").exists())
    else:
        todo_vectors = sum(p.hi - p.lo for p in ps)
    t0 = time.perf_counter()
    recs = jobrunner.run_pieces(run_piece, ps, jobs=jobs, scheduler=scheduler, key=Piece.key if resume else None,
                                cache=CACHE if resume else None, vectors=lambda p: p.hi - p.lo,
                                describe=Piece.describe, desc=f"{t.name} {sim}", progress=progress,
                                callback=arrived, client=client)
    wall = time.perf_counter() - t0
    rec = merge_records(recs, partial=select is not None)
    rec["resumed"] = len(ps) - len(done)
    rec["workers"] = jobs if client is None and not jobrunner.scheduler_address(scheduler) else None
    # the pieces ran side by side: the run took the wall time
    rec["seconds"] = round(wall, 3)
    rec["vectors_per_second"] = rec["vectors"] / wall if wall else 0.0
    if select is not None:
        rec["fraction"] = rec["vectors"] / len(ps[0].space)
    if projection:
        projection["actual_seconds"] = round(wall, 1)
        projection["ratio"] = round(wall / max(projection["projected_seconds"], 1e-3), 3)
        rec["projection"] = projection
    return rec


def throughput(t: Target, sim: str, vectors: int, *, workers=(1, 2), repeat: int = 3, full: bool = False,
               lo: int | None = None, progress: bool = True) -> dict:
    """Rate of ``sim`` on ``vectors`` rows of target ``t`` (from the middle of its space unless ``lo``) on each
    count of ``workers``, in one run: one local cluster of ``max(workers)`` single-threaded workers, every
    worker warmed up (imports, simulation build) before any clock starts, then ``repeat`` rounds, each running
    the same ``2 * max(workers)`` pieces (one core each: the Dask tasks' setting) on the first 1, then 2, ...
    workers, alternating so that a change of the machine's load hits every count alike.

    Returns every run (wall and CPU seconds, rate), and per worker count the medians over the rounds: rate,
    speed-up over the first count (median of the rounds' ratios), per-worker rate. The projections of the
    whole space: at the median per-worker rate of the largest count (what this machine gave), and on free
    cores from the CPU time (model, vector files and simulator together: what a worker with a core to itself
    would do)."""
    from statistics import median

    if repeat < 1:
        raise ValueError(f"--repeat {repeat}: must be >= 1")
    space = t.make_space(full)
    lo = (len(space) - vectors) // 2 if lo is None else lo
    count = 2 * max(workers)
    ps = pieces(t, sim, count=count, full=full, lo=lo, hi=lo + vectors)
    runs = []
    with jobrunner.cluster(max(workers)) as client:
        addresses = sorted(client.scheduler_info()["workers"])
        warm = pieces(t, sim, count=len(addresses), full=full, lo=lo, hi=lo + 1024 * len(addresses))
        for address, piece in zip(addresses, warm):
            jobrunner.run_pieces(run_piece, [piece], client=client, workers=[address], progress=False)
        for r in range(repeat):
            for n in workers:
                t0 = time.perf_counter()
                recs = jobrunner.run_pieces(run_piece, ps, client=client, workers=addresses[:n], progress=progress,
                                            desc=f"round {r + 1}, {n} worker(s)", vectors=lambda p: p.hi - p.lo)
                wall = time.perf_counter() - t0
                cpu = sum(x["cpu_seconds"] for x in recs)
                runs.append({"round": r + 1, "workers": n, "vectors": vectors, "seconds": round(wall, 3),
                             "vectors_per_second": vectors / wall, "cpu_seconds": round(cpu, 3),
                             "per_cpu_second": vectors / cpu if cpu else None,
                             "ok": all(x["ok"] for x in recs), "load_average": round(os.getloadavg()[0], 2)})
    by = {n: [x for x in runs if x["workers"] == n] for n in workers}
    base = workers[0]
    summary = []
    for n in workers:
        ratios = [x["vectors_per_second"] / y["vectors_per_second"] for x, y in zip(by[n], by[base])]
        rate = median(x["vectors_per_second"] for x in by[n])
        summary.append({"workers": n, "vectors_per_second": round(rate, 1), "per_worker": round(rate / n, 1),
                        "speedup": round(median(ratios), 3),
                        "per_cpu_second": round(median(x["per_cpu_second"] or 0 for x in by[n]), 1)})
    rate = summary[-1]["per_worker"]
    free = median(x["per_cpu_second"] or 0 for x in runs)
    counts = (1, 2, 8, 32, 128)
    return {"unit": t.unit, "preset": t.preset, "simulator": sim, "space": len(space), "range": [lo, lo + vectors],
            "pieces": count, "repeat": repeat, "runs": runs, "summary": summary, "per_worker_rate": rate,
            "load_average": os.getloadavg()[0],
            "projected_seconds": {str(n): round(len(space) / (rate * n), 1) for n in counts},
            "per_cpu_second": free or None,
            "projected_seconds_free_cores": {str(n): round(len(space) / (free * n), 1) for n in counts}
            if free else None}


def parse_select(text: str) -> tuple[int, int]:
    """``"A:B"`` (1-based, ``1 <= A <= B``) to ``(A, B)``; ``ValueError`` naming the bad text."""
    return parse_pair(text, "--select", ":", "AB", "1:16", "pieces")


#: Extra options of this command's parser (``tools.main``).
PARSER_OPTIONS = dict(formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__[__doc__.index("Sharding"):])


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap exhaustive``, :mod:`tools.main`)."""
    ap.add_argument("--sim", default="icarus,verilator",
                    help="comma-separated simulators, or exact (the model against exact math) (default: %(default)s)")
    ap.add_argument("--only", default="", help="comma-separated targets UNIT[:PRESET] (default: all of TARGETS)")
    ap.add_argument("--shard", help="run only shard i of N (1-based) of each target, e.g. 2/8")
    jobrunner.add_arguments(ap, what="pieces of each target")
    ap.add_argument("--pieces", type=int, help="Dask tasks per target (default: pieces of at most PIECE vectors, a "
                                               "multiple of --jobs)")
    ap.add_argument("--no-resume", action="store_true", help="recheck pieces stored by an earlier run")
    ap.add_argument("--throughput", type=int, metavar="N",
                    help="measure the rate on N inputs of each target with 1 and 2 local workers, and project")
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds of --throughput (1 worker, then 2, each round; medians) (default: %(default)s)")
    ap.add_argument("--select", metavar="A:B",
                    help="run only pieces A..B (1-based) of each target's pieces: a partial run, which the whole "
                         "run later resumes from")
    ap.add_argument("--merge", action="store_true", help="only merge complete sets of shard files into the report")
    ap.add_argument("--full", action="store_true", help="every input of every target, not a documented subset")
    ap.add_argument("--chunk", type=int, help="vectors per chunk file (default: cosim.stream.CHUNK)")
    ap.add_argument("--list", action="store_true", help="list the targets and their input spaces")
    ap.add_argument("--record", metavar="FILE",
                    help="also enter the records in FILE (as the report), or with --throughput write them there: "
                         "the committed figures (docs/exhaustive/)")


def _run_throughput(args: argparse.Namespace, targets: list, sims: list) -> int:
    """``--throughput``: measure, record and print the rate of each target and simulator."""
    out = [throughput(t, sim, args.throughput, full=args.full, repeat=args.repeat) for t in targets
           for sim in sims]
    OUT.mkdir(parents=True, exist_ok=True)
    atomic_json((OUT / "throughput.json"), out, indent=1)
    if args.record:
        Path(args.record).parent.mkdir(parents=True, exist_ok=True)
        atomic_json(Path(args.record), out, indent=1)
    for r in out:
        runs = ", ".join(f"{x['workers']} worker(s) {x['vectors_per_second']:,.0f} vectors/s (x{x['speedup']:.2f})"
                         for x in r["summary"])
        proj = ", ".join(f"{n}: {s / 60:,.1f} min" for n, s in r["projected_seconds"].items())
        print(f"{r['unit']}:{r['preset']} {r['simulator']}, medians of {r['repeat']} rounds: {runs} (load "
              f"average {r['load_average']:.1f}); all {r['space']:,} inputs projected (workers: time) {proj}"
              + ("" if all(x["ok"] for x in r["runs"]) else "  FAIL"))
        if r["projected_seconds_free_cores"]:
            free = ", ".join(f"{n}: {s / 60:,.1f} min" for n, s in r["projected_seconds_free_cores"].items())
            print(f"  from the CPU time ({r['per_cpu_second']:,.0f} vectors per CPU second), on free cores: {free}")
    print(f"(throughput: {OUT / 'throughput.json'})")
    return 0 if all(x["ok"] for r in out for x in r["runs"]) else 1


def run(args: argparse.Namespace) -> int:
    try:
        targets = [target(x.strip()) for x in args.only.split(",") if x.strip()] or list(TARGETS)
        if args.list:
            for t in targets:
                print(f"{t.name:<16} {t.make_space(args.full).describe()}")
            return 0
        shard = parse_shard(args.shard) if args.shard else None
        if args.jobs < 1:
            raise ValueError(f"--jobs {args.jobs}: must be >= 1")
        if shard and (args.jobs > 1 or args.scheduler):
            raise ValueError("--shard does not combine with --jobs > 1 or --scheduler: give each process its own "
                             "--shard, or let the Dask cluster run the pieces")
        sims = [] if args.merge else [s.strip() if s.strip() == EXACT else simulator(s.strip())
                                      for s in args.sim.split(",") if s.strip()]
        if args.pieces is not None and args.pieces < 1:
            raise ValueError(f"--pieces {args.pieces}: must be >= 1")
        select = parse_select(args.select) if args.select else None
        if select and shard:
            raise ValueError("--select does not combine with --shard: select pieces of a Dask run")
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.throughput:
        return _run_throughput(args, targets, sims)
    if args.merge:
        records = merge_shards()
        if not records:
            print(f"no complete set of shard files in {SHARDS}", file=sys.stderr)
            return 2
    else:
        records = []
        for t in targets:
            for sim in sims:
                if shard:
                    print(f"{t.name} on {sim}: shard {shard[0]}/{shard[1]}", flush=True)
                    run_target(t, sim, shard=shard, full=args.full, progress=True, chunk=args.chunk)
                else:
                    try:
                        records.append(run_dask(t, sim, jobs=args.jobs, scheduler=args.scheduler, full=args.full,
                                                chunk=args.chunk, count=args.pieces, resume=not args.no_resume,
                                                select=select))
                    except ValueError as exc:
                        print(f"error: {exc}", file=sys.stderr)
                        return 2
        if shard:
            records = merge_shards()
            if not records:
                print(f"shard {shard[0]}/{shard[1]} written to {SHARDS}; the report is merged once all "
                      f"{shard[1]} shards are there (or run --merge)")
                return 0
    update_report(records)
    if args.record:
        update_report(records, Path(args.record))
    print(table(records))
    for r in records:
        if "projection" in r:
            x = r["projection"]
            print(f"{r['unit']}:{r['preset']} on {r['simulator']}: projected {x['projected_seconds'] / 60:,.1f} min "
                  f"({x['vectors']:,} vectors / {x['per_worker_rate']:,.0f} vectors/s a worker / {x['workers']} "
                  f"workers), took {x['actual_seconds'] / 60:,.1f} min: {x['ratio']:.3f} of the projection")
    print(f"(report: {REPORT})")
    bad = _failures(records)
    if bad:
        print(bad, file=sys.stderr)
        return 1
    return 0
