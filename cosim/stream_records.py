"""The records mode of the streaming co-simulation: inputs that give any number of outputs each (triangle records
in, fragments out), compared here in order (:func:`run_records`).

The mechanism of :func:`cosim.stream.run_stream` (the job core :class:`cosim.stream_job.StreamJob`), in the
wrapper's ``expand`` mode; independent inputs can be cut into shards simulated at once
(:func:`cosim.stream_spaces.shard_weights`).
"""

from __future__ import annotations

import hashlib
import time

import numpy as np

from fxmodel.core.vectors import write_words

from .simulators import simulator, waves_wanted
from .stream_build import Build, build
from .stream_job import StreamJob, StreamResult, chunk_meta, chunk_patterns
from .stream_spaces import shard_weights

__all__ = ["run_records", "RECORD_DEPTH"]

#: Inputs the wrapper's memory holds in ``expand`` mode (:func:`run_records`): triangle records are wide (some
#: thousand bits), so a chunk holds at most this many, and as many as give about ``chunk`` outputs.
RECORD_DEPTH = 1 << 12


def _record_chunks(counts: np.ndarray, chunk: int, depth: int) -> list[tuple[int, int]]:
    """Consecutive input ranges ``[a, b)``, each of at most ``depth`` inputs and, where an input allows, about
    ``chunk`` outputs (an input is never split)."""
    out, a, n = [], 0, 0
    for i, c in enumerate(np.asarray(counts, dtype=np.int64).tolist()):
        if i > a and (n + c > chunk or i - a >= depth):
            out.append((a, i))
            a, n = i, 0
        n += c
    if a < len(counts):
        out.append((a, len(counts)))
    return out




def _record_mismatches(rtl, expected, counts, keep: int, out0: int = 0, in0: int = 0) -> tuple[int, list]:
    """Outputs of ``rtl`` that differ from ``expected`` (a missing or extra output counts as one) and the first
    ``keep`` of them (``index`` the output's row, offset by ``out0``; its input's row offset by ``in0``)."""
    n = min(len(rtl), len(expected))
    bad = np.flatnonzero(np.any(rtl[:n] != expected[:n], axis=1))
    source = np.repeat(np.arange(len(counts)), counts)
    first = [{"index": int(r) + out0, "inputs": f"input {int(source[r]) + in0}", "rtl": rtl[r].tolist(),
              "model": expected[r].tolist()} for r in bad[:keep]]
    return int(len(bad)) + abs(len(rtl) - len(expected)), first




def run_records(params, inputs, expected, counts, *, clocks=None, sim: str | None = None, pattern="none",
                seed: int = 1, chunk: int = 4096, depth: int = RECORD_DEPTH, keep: int = 8, tag: str | None = None,
                waves: bool | None = None, progress=None, optimize: bool | None = None,
                shards: int = 1) -> StreamResult:
    """Stream inputs that give any number of outputs each (triangle records in, fragments out) through a design
    with stream ports of its own, and compare every output with the model's, in order.

    The mechanism of :func:`run_stream`, in the wrapper's ``expand`` mode (:func:`wrapper_verilog`): the inputs
    go to the design from binary chunk files (``$fread``), at most ``depth`` and about ``chunk`` outputs' worth a
    chunk; the clock, the gaps on the input valid and the backpressure on the output ready (:data:`PATTERNS`)
    are made inside the wrapper; every output taken is written to a file, and here compared bit for bit with
    ``expected``, counted (none lost, none extra) and kept in order. The outputs are decoded generically, one
    column per ``params.outputs`` field: a field added to the design's output payload comes through as it is.

    Parameters
    ----------
    params
        The design's parameter object: ``NAME``, ``inputs`` and ``outputs`` (ports: the input and output
        payloads' fields, first field in the low bits), ``latency`` (cycles from the last input's work to its
        last output, for the idle rule); ``rtl.build(params)`` is a component with ``i`` and ``o`` stream ports
        (and optionally ``busy``, an output high while the design works on an input: its cycles are counted).
    inputs : array_like, shape (T, len(params.inputs))
        Input codes.
    expected : array_like, shape (K, len(params.outputs))
        The model's outputs in the order the design gives them.
    counts : array_like, shape (T,)
        Outputs of each input (sum ``K``).
    clocks : array_like, shape (T,), optional
        The model's cycles per input: sets each chunk's cycle limit (default: the outputs).
    sim, pattern, seed, keep, tag, waves, progress
        As :func:`run_stream` (a sequence of patterns gives chunk ``k`` pattern ``k mod len``; ``progress``
        counts outputs).
    optimize : bool, optional
        Simulate the Yosys-optimized netlist (default: on Icarus, as :func:`run_stream`). Yosys takes about a
        minute on the whole engine; a run of a few thousand fragments is done sooner on Amaranth's own Verilog.
    shards : int
        Simulate the inputs as this many contiguous shards (:func:`shard_weights`, balanced by the model's clocks
        and outputs), each in its own simulator process, all at once: valid when the inputs are independent
        (triangles without the depth test), and as many times faster as there are free cores. Each shard starts
        from reset, so each shard's ``busy`` cycles are the model's clocks of its inputs
        (``shard_busy_cycles``); the outputs are joined in order. With waveforms, one shard (one file).

    Returns
    -------
    StreamResult
        As :func:`run_stream` (``vectors`` the outputs compared, ``expected_vectors`` ``K``), plus ``inputs``,
        ``shards`` (the ranges of inputs ``[a, b)`` simulated apart) and, when the design has ``busy``,
        ``busy_cycles`` and ``shard_busy_cycles`` (one per shard); ``result.rtl`` the output codes ``(K',
        outputs)``. ``sim_cpu_seconds`` adds the shards' simulator CPU, ``sim_seconds`` is the longest shard's.
    """
    sim, waves = simulator(sim), waves_wanted(waves)
    inputs = np.asarray(inputs, dtype=np.int64).reshape(-1, len(params.inputs))
    expected = np.asarray(expected, dtype=np.int64).reshape(-1, len(params.outputs))
    counts = np.asarray(counts, dtype=np.int64)
    if counts.shape != (len(inputs),) or int(counts.sum()) != len(expected):
        raise ValueError(f"counts: {counts.shape} entries summing to {int(counts.sum())}, for {len(inputs)} inputs "
                         f"and {len(expected)} expected outputs")
    chunk_patterns(pattern, 1)                             # a bad pattern name fails before the build
    if not len(inputs):
        raise ValueError("no inputs: nothing to check")
    clocks = counts if clocks is None else np.asarray(clocks, dtype=np.int64)
    if not isinstance(shards, int) or shards < 1:
        raise ValueError(f"shards={shards!r}: must be an int >= 1")
    bld = build(params, params, "", sim, keep, waves, expand=True, depth=depth, optimize=optimize)
    parts = shard_weights(clocks + counts, 1 if waves else shards)
    if len(parts) > 1:
        return _run_record_shards(params, inputs, expected, counts, clocks, parts, bld, sim=sim, pattern=pattern,
                                  seed=seed, chunk=chunk, depth=depth, keep=keep, tag=tag, progress=progress,
                                  optimize=optimize)
    return _run_one(params, bld, inputs, expected, counts, clocks, sim=sim, waves=waves, pattern=pattern, seed=seed,
                    chunk=chunk, depth=depth, keep=keep, tag=tag, progress=progress)


def _run_one(params, bld: Build, inputs, expected, counts, clocks, *, sim, waves, pattern, seed, chunk, depth, keep,
             tag, progress) -> StreamResult:
    """:func:`run_records` of all ``inputs`` in one simulator process."""
    ranges = _record_chunks(counts, chunk, depth)
    sizes = [int(counts[a:b].sum()) for a, b in ranges]
    ends = np.cumsum(sizes).tolist()
    outs = [(e - n, e) for n, e in zip(sizes, ends)]
    patterns = chunk_patterns(pattern, len(ranges))
    job = StreamJob(params, bld, sim, waves, tag, {
        "mode": "records", "build": bld.bdir.name, "inputs": _digest(inputs), "expected": _digest(expected),
        "counts": _digest(counts), "clocks": _digest(clocks), "patterns": patterns, "seed": seed, "chunk": chunk,
        "depth": depth, "keep": keep})
    ins = [(p.name, p.fmt) for p in params.inputs[::-1]]         # the input payload: first port lowest
    for k, (a, b) in enumerate(ranges):
        write_words(job.path / f"chunk_{k}.bin", ins, inputs[a:b, ::-1])
    limits = [min(32 * int(clocks[a:b].sum() + counts[a:b].sum() + b - a) + 20000 + 64 * params.latency,
                  (1 << 32) - 1) for a, b in ranges]
    job.write_meta({**chunk_meta(params, [b - a for a, b in ranges], patterns, seed, keep, True),
                    "bases": [0] * len(ranges), "counter": False, "out_lens": sizes, "limits": limits,
                    "busy": bld.busy})
    job.simulate(outs, progress)
    res = job.report()
    rtl = job.read_dump(len(ranges))
    mismatches, first = _record_mismatches(rtl, expected, counts, keep)
    result = job.result(res, vectors=len(rtl), expected=len(expected), mismatches=mismatches, valid_errors=0,
                        patterns=patterns, first=first, space=f"{len(inputs)} inputs giving {len(expected)} outputs",
                        span=(0, len(inputs)), chunks=len(ranges), variant=None, inputs=len(inputs),
                        shards=[[0, len(inputs)]])
    if bld.busy:
        result["busy_cycles"] = res["busy_cycles"]
        result["shard_busy_cycles"] = [res["busy_cycles"]]
    return job.finish(result, rtl)


def _digest(array) -> str:
    """SHA-256 (16 hex digits) of an array's shape and bytes: part of a job's definition."""
    array = np.ascontiguousarray(array)
    return hashlib.sha256(repr(array.shape).encode() + array.tobytes()).hexdigest()[:16]


def _run_record_shards(params, inputs, expected, counts, clocks, parts, bld: Build, *, sim, tag, keep, progress,
                       **kw) -> StreamResult:
    """:func:`run_records` of each range of ``parts`` in a thread of its own (each thread waits on its own
    simulator process), joined into one result in input order."""
    from concurrent.futures import ThreadPoolExecutor

    ends = np.concatenate([[0], np.cumsum(counts)])
    outs = [(int(ends[a]), int(ends[b])) for a, b in parts]
    if progress is None:
        progress = len(expected) > 4 * kw["chunk"]
    bar = None
    if progress is True:
        from tqdm import tqdm
        bar = progress = tqdm(total=len(expected), desc=f"{params.NAME} {sim}", unit="vec", unit_scale=True)
    started = time.time()
    t0 = time.perf_counter()
    try:
        with ThreadPoolExecutor(len(parts)) as pool:
            futures = [pool.submit(run_records, params, inputs[a:b], expected[oa:ob], counts[a:b], clocks=clocks[a:b],
                                   sim=sim, tag=tag and f"{tag}_shard{k + 1}", keep=keep,
                                   progress=progress, waves=False, shards=1, **kw)
                       for k, ((a, b), (oa, ob)) in enumerate(zip(parts, outs))]
            results = [f.result() for f in futures]
    finally:
        if bar is not None:
            bar.close()
    seconds = time.perf_counter() - t0
    mismatches, first = 0, []
    for r, (a, b), (oa, ob) in zip(results, parts, outs):
        n, f = _record_mismatches(r.rtl, expected[oa:ob], counts[a:b], keep, oa, a)
        mismatches += n
        first += f
    rtl = np.concatenate([r.rtl for r in results])
    total = {k: sum(r[k] for r in results) for k in ("missing", "extra", "protocol_errors", "cycles", "stalled",
                                                      "starved")}
    result = StreamResult(
        unit=params.NAME, simulator=sim, vectors=len(rtl), expected_vectors=len(expected), mismatches=mismatches,
        valid_errors=0, patterns=sorted({p for r in results for p in r["patterns"]}), first=first[:keep],
        seconds=round(seconds, 3), vectors_per_second=len(rtl) / seconds,
        sim_seconds=max(r["sim_seconds"] for r in results),
        sim_cpu_seconds=round(sum(r["sim_cpu_seconds"] for r in results), 3), build_seconds=round(bld.seconds, 2),
        space=f"{len(inputs)} inputs giving {len(expected)} outputs, in {len(parts)} shards", range=[0, len(inputs)],
        chunks=sum(r["chunks"] for r in results), variant=None, started=started, finished=time.time(),
        inputs=len(inputs), shards=[list(p) for p in parts], **total)
    if bld.busy:
        result["shard_busy_cycles"] = [r["busy_cycles"] for r in results]
        result["busy_cycles"] = sum(result["shard_busy_cycles"])
    result.rtl = rtl
    return result
