"""One job runner for the long, embarrassingly parallel jobs: exhaustive proofs, sweeps, fits, place and route.

A job is a list of *pieces* (a shard of an input space, a sweep point, a candidate preset, a place-and-route run)
and one top-level function ``fn(piece) -> result``. :func:`run_pieces` runs ``fn`` on every piece as a Dask task
and returns the results in the order of the pieces; the caller merges them as a single-process run would.

Where the tasks run
-------------------
* ``--scheduler ADDRESS`` (or the ``DASK_SCHEDULER_ADDRESS`` environment variable): on that Dask cluster
  (``dask scheduler`` on one machine, ``dask worker ADDRESS --nthreads 1`` on each machine, or dask-jobqueue on a
  batch system). Every worker runs a checkout of the same commit (``pip install -e .`` in it): each result
  carries the digest of the worker's sources (:func:`code_digest`) and the client refuses a result made by other
  code. Nothing else is shared: a piece carries its inputs (parameter objects, ranges), its result comes back to
  the client, and builds (Verilator models, netlists) are made once per worker machine and cached there by
  content, as on one machine.
* otherwise ``--jobs N`` > 1: a ``LocalCluster`` of ``N`` single-threaded worker processes on this machine,
  started for the job and closed after it;
* ``--jobs 1`` (no scheduler): in this process, no cluster.

Faults
------
* A piece that raises is retried :data:`RETRIES` times (``client.map(..., retries=RETRIES)``), then the job
  stops with the piece's error.
* A piece whose worker process dies (killed, out of memory, machine lost) is rescheduled on another worker by
  the scheduler; after :data:`ALLOWED_FAILURES` deaths of workers running it the piece fails (``KilledWorker``).
  On a ``LocalCluster`` each worker's nanny also restarts its dead worker. (On a cluster of your own the second
  number is the scheduler's ``distributed.scheduler.allowed-failures``, 3 by default.)
* With ``cache``, each result is stored as ``<cache>/<key>.json`` as soon as it arrives, ``key`` a digest of
  what the piece checks (``key(piece)``: e.g. unit, parameter object, simulator, RTL digest, range). A rerun
  after an interruption loads those and runs only the missing pieces; a changed parameter object, simulator,
  source file or range changes the key, so a stale result is never reused.

Progress: a tqdm bar counts tasks, and vectors where ``vectors(piece)`` tells a piece's count.

Nothing here is imported by the model (``fxmodel``) or the RTL; Dask itself is imported only when a cluster
is used.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import socket
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from functools import cache
from pathlib import Path

from fxmodel.core.paths import ROOT, build_dir, source_digest

#: Default folder of the result caches (``build/jobs/<job name>/``).
CACHE = build_dir("jobs")
#: Retries of a piece that raised, before the job fails.
RETRIES = 2
#: Deaths of workers running one piece before it is declared failed (the scheduler's ``allowed-failures``).
ALLOWED_FAILURES = 3
#: The packages whose sources a piece's result depends on (their digest is checked on every result).
CODE = ("fxmodel", "host", "rtl", "cosim", "tools")

__all__ = ["RETRIES", "ALLOWED_FAILURES", "CACHE", "add_arguments", "scheduler_address", "cluster",
           "run_pieces", "content_key", "code_digest", "cpu_seconds", "JobError"]


class JobError(RuntimeError):
    """A piece failed after its retries (the message names the piece and gives its error)."""


@cache
def code_digest() -> str:
    """12 hex digits of the sources of :data:`CODE` (every ``*.py``, names and contents), taken once a process."""
    return hashlib.sha1(source_digest(CODE)).hexdigest()[:12]


def content_key(*parts) -> str:
    """A file name for a result: the SHA-1 of ``parts`` (JSON-able or ``repr``-able values, e.g. a frozen
    parameter object) and of :func:`code_digest`."""
    text = json.dumps([p if isinstance(p, (str, int, float, bool, type(None), list, dict)) else repr(p)
                       for p in parts], sort_keys=True, default=repr)
    return hashlib.sha1((text + code_digest()).encode()).hexdigest()[:20]


def add_arguments(ap: argparse.ArgumentParser, jobs: int = 1, what: str = "pieces") -> None:
    """``--jobs`` and ``--scheduler`` for a command line (the same two options for every long job)."""
    from host.args import int_range
    ap.add_argument("--jobs", type=int_range(1, 1024), default=jobs,
                    help=f"{what} run at once on a local Dask cluster of that many single-threaded worker "
                         f"processes; 1: in this process (default: %(default)s)")
    ap.add_argument("--scheduler", default=None,
                    help="address of a running Dask scheduler (tcp://HOST:8786) to run on instead; default: "
                         "$DASK_SCHEDULER_ADDRESS if set")


def scheduler_address(scheduler: str | None = None) -> str | None:
    """``scheduler``, else ``$DASK_SCHEDULER_ADDRESS``, else ``None`` (a local cluster or this process)."""
    return scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


@contextmanager
def cluster(jobs: int = 1, scheduler: str | None = None):
    """A Dask ``Client``: connected to ``scheduler`` (or ``$DASK_SCHEDULER_ADDRESS``), else to a new
    ``LocalCluster`` of ``jobs`` single-threaded worker processes (closed on exit)."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    address = scheduler_address(scheduler)
    if address:
        with Client(address) as client:
            yield client
        return
    if jobs < 1:
        raise ValueError(f"--jobs {jobs}: must be >= 1")
    # the workers import this checkout, whatever the installed package points at
    env = {"PYTHONPATH": os.pathsep.join(x for x in (str(ROOT), os.environ.get("PYTHONPATH", "")) if x)}
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                          # the pieces bound their own memory; a shared machine's load must not make the nanny
                          # pause or kill a worker
                          "distributed.worker.memory.target": False, "distributed.worker.memory.spill": False,
                          "distributed.worker.memory.pause": False}):
        with LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                          memory_limit=0, silence_logs=logging.ERROR, env=env) as lc, Client(lc) as client:
            yield client


def cpu_seconds() -> float:
    """CPU seconds (user and system) of this process and of its finished child processes (a simulator)."""
    import resource
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _call(fn: Callable, piece):
    """Run one piece on a worker: its result, the worker's code digest, host and process, and seconds."""
    t0 = time.perf_counter()
    result = fn(piece)
    return {"result": result, "code": code_digest(), "worker": f"{socket.gethostname()}:{os.getpid()}",
            "seconds": time.perf_counter() - t0}


def _check(out: dict, describe: str):
    if out["code"] != code_digest():
        raise JobError(f"{describe}: the worker {out['worker']} runs other sources (digest {out['code']}, "
                       f"here {code_digest()}): start every worker from a checkout of this commit")
    return out["result"]


def run_pieces(fn: Callable, pieces: Sequence, *, jobs: int = 1, scheduler: str | None = None,
               retries: int = RETRIES, key: Callable | None = None, cache: Path | str | None = None,
               vectors: Callable | None = None, describe: Callable = repr, desc: str = "pieces",
               progress: bool = True, callback: Callable | None = None, client=None,
               workers: Sequence[str] | None = None) -> list:
    """Run ``fn(piece)`` for every piece, on Dask (see the module docstring), and return the results in order.

    Parameters
    ----------
    fn : callable
        A module-level function (pickled by reference for the workers); its result must be JSON-able when a
        ``cache`` is given.
    pieces : sequence
        The pieces; each carries everything ``fn`` needs (no shared file system is assumed).
    jobs, scheduler
        Where to run (module docstring). ``jobs == 1`` without a scheduler runs in this process.
    retries : int
        Retries of a piece that raised.
    key : callable
        ``key(piece) -> str``, a content key (:func:`content_key`) of what the piece checks; with ``cache``, the
        file name of its stored result.
    cache : path
        Folder of the stored results (resume); ``None``: nothing stored.
    vectors : callable
        ``vectors(piece) -> int`` for the progress bar's vector count.
    describe : callable
        ``describe(piece) -> str`` for messages.
    desc : str
        Progress bar label.
    callback : callable
        ``callback(index, result)`` as each result arrives (after it is stored).
    client : distributed.Client
        Use this client instead of starting one (``jobs`` and ``scheduler`` are then ignored).
    workers : sequence of str
        With ``client``: run the pieces on these workers (addresses) only, e.g. to measure one worker of a
        cluster against two.

    Raises
    ------
    JobError
        A piece failed after ``retries`` retries (or its worker died :data:`ALLOWED_FAILURES` times), or a worker
        runs other sources. Results already stored in ``cache`` stay for the next run.
    """
    from tqdm import tqdm

    pieces = list(pieces)
    if (key is None) != (cache is None):
        raise ValueError("run_pieces: give both key and cache (resume), or neither")
    if retries < 0:
        raise ValueError(f"retries={retries}: must be >= 0")
    results, todo, paths = _cached(pieces, key, cache)
    counts = [vectors(p) for p in pieces] if vectors else None
    bar = tqdm(total=len(pieces), initial=len(pieces) - len(todo), desc=desc, unit="task", disable=not progress,
               smoothing=0.1)
    done_vectors = sum(counts[i] for i in range(len(pieces)) if i not in set(todo)) if counts else 0

    def finish(i, result):
        nonlocal done_vectors
        if cache is not None:
            tmp = paths[i].with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps(result))
            tmp.replace(paths[i])
        results[i] = result
        bar.update(1)
        if counts:
            done_vectors += counts[i]
            bar.set_postfix_str(f"{done_vectors:,} of {sum(counts):,} vectors", refresh=False)
        if callback is not None:
            callback(i, result)

    try:
        if not todo:
            return results
        if client is None and jobs == 1 and not scheduler_address(scheduler):
            for i in todo:
                finish(i, _run_local(fn, pieces[i], retries, describe))
            return results
        if client is not None:
            _run_dask(client, fn, pieces, todo, retries, describe, finish, workers)
        else:
            with cluster(jobs, scheduler) as c:
                _run_dask(c, fn, pieces, todo, retries, describe, finish)
        return results
    finally:
        bar.close()


def _cached(pieces: list, key: Callable | None, cache: Path | str | None) -> tuple[list, list, dict]:
    """``(results, todo, paths)``: the stored result of each piece (``None`` where there is none), the indices of
    the pieces still to run and, with a ``cache``, each piece's result file (the folder is made)."""
    results: list = [None] * len(pieces)
    if cache is None:
        return results, list(range(len(pieces))), {}
    cache = Path(cache)
    cache.mkdir(parents=True, exist_ok=True)
    todo, paths = [], {}
    for i, piece in enumerate(pieces):
        paths[i] = cache / f"{key(piece)}.json"
        try:
            results[i] = json.loads(paths[i].read_text())
        except (OSError, json.JSONDecodeError):
            todo.append(i)
    return results, todo, paths


def _run_local(fn, piece, retries, describe):
    for attempt in range(retries + 1):
        try:
            return fn(piece)
        except Exception as exc:
            if attempt == retries:
                raise JobError(f"{describe(piece)} failed after {retries} retries: {exc!r}") from exc


def _run_dask(client, fn, pieces, todo, retries, describe, finish, workers=None):
    from distributed import as_completed

    where = {"workers": list(workers), "allow_other_workers": False} if workers else {}
    futures = client.map(_call, [fn] * len(todo), [pieces[i] for i in todo], retries=retries, pure=False, **where)
    index = {f.key: i for f, i in zip(futures, todo)}
    try:
        for future in as_completed(futures):
            i = index[future.key]
            try:
                out = future.result()
            except Exception as exc:
                raise JobError(f"{describe(pieces[i])} failed after {retries} retries: {exc!r}") from exc
            finish(i, _check(out, describe(pieces[i])))
    finally:
        client.cancel([f for f in futures if not f.done()])

