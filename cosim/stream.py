"""Streaming co-simulation: exhaustive RTL equivalence at simulator speed.

The per-vector harness (:mod:`cosim.harness`) drives every input from Python and tops out at some ten
thousand vectors a second. Here Python never touches a vector inside the simulation:

1. The golden model (``params.compute``) produces the expected outputs of a chunk of input vectors, and
   :func:`fxmodel.core.vectors.write_words` writes inputs and expected outputs as binary words for ``$fread``
   (the input payload then the output payload, each field where ``rtl.streams`` packs it, ``ceil(width / 8)``
   bytes a word; the wrapper's header comment documents the layout). When the run walks the whole input space
   in order (:class:`FullSpace`, inputs up to 64 bits) the wrapper counts the inputs itself (row ``i`` is the
   bits of ``i``, each signed field's top bit inverted) and the file's input fields are zero.
2. A wrapper generated from the parameter object (:func:`~cosim.stream_wrapper.wrapper_verilog`) instantiates
   the unit's generated Verilog by its port names, loads a chunk with ``$fread``, streams it through the unit at
   one vector per clock, compares every output bit with ``!==`` (an ``x`` or ``z`` bit is a mismatch on Icarus)
   and counts the mismatches, keeping the first few ``(index, vector, got)``. It also checks the valid protocol
   on every cycle: ``o_valid`` must be ``i_valid`` delayed by exactly ``params.latency``.
3. The cocotb test :mod:`cosim.stream_tb` orchestrates: reset, then for each chunk a handshake (file ready ->
   ``load_seq``, chunk checked -> ``done_seq``), and finally reads the counters and the first mismatches.
4. The model (in a thread of this process) writes chunk ``k + 1`` while the simulator checks chunk ``k``; at
   most ``ahead`` (default :data:`AHEAD`) chunk files exist at a time, each deleted once checked, so any input
   space streams in bounded memory and disk. With ``ahead=1`` the model and the simulator take turns (one core
   at a time: the exhaustive runs' Dask tasks, :mod:`tools.exhaustive`).

Input spaces (:class:`Space`) are enumerated by index, so a run or a shard of a run is an index range
``[lo, hi)``: :func:`shard_range` cuts a space into ``N`` independent shards for processes or machines.

Choices, measured (recip ``default``, this 2-core machine): chunks of :data:`CHUNK` = 2**20 vectors keep
the simulator small (measured: a 2**24-word memory costs Icarus 0.65 GB) and let the model (about 3 million
vectors/s) run ahead of the simulator. Binary words instead of ``$readmemh`` text: writing a 2**20-vector chunk
of the 32-bit reciprocal takes the model 0.02 s of CPU instead of 0.10 s, and the simulator reads bytes
instead of parsing hex. The
clock is generated inside the wrapper (no simulator-to-Python callback per cycle; cocotb wakes once a chunk)
as a zero-width pulse where possible (one time step a cycle instead of two: 1.3 times faster on Verilator, see
``_CLOCKS`` in :mod:`cosim.stream_wrapper`). Verilator therefore builds with ``--timing``, whose coroutines need
C++20 (:data:`cosim.simulators.VERILATOR_TIMING_ARGS`). Icarus simulates the Yosys-optimized
netlist of the unit, as :mod:`cosim.harness` does. Rates: Verilator about 1.45 million vectors/s (all 2**24
inputs in 12 s); Icarus about 85 thousand a CPU second on the reciprocal without stalls, 20 thousand with valid
and ready each high half the time (``bumpmap bench --stream-only --sim icarus``), bound by Icarus 11
itself: every variable a procedural statement reads costs it a C++ ``dynamic_cast`` (about half its
instructions), so the unit's netlist is written with every register in one clocked block
(:func:`rtl.verilog.one_clocked_block`) and the wrapper reads its conditions from continuous assignments; the
README's Speed section has the profile (``bumpmap bench --icarus-profile UNIT``).

Environment: ``SIM`` (``icarus`` default, or ``verilator``); ``WAVES=1`` dumps waveforms (slow: use short runs).

Modules: :mod:`cosim.stream_spaces` (input spaces, shards), :mod:`cosim.stream_wrapper` (the generated HDL
wrapper), :mod:`cosim.stream_build` (the build cache), :mod:`cosim.stream_job` (the job core both run modes
share), :mod:`cosim.stream_records` (the records mode, :func:`run_records`); this module runs the unit mode
(:func:`run_stream`) and re-exports the public names.
"""

from __future__ import annotations

import hashlib
import os
import threading
import time
from pathlib import Path

import numpy as np

from fxmodel.core.vectors import write_words

from .simulators import simulator, waves_wanted
from .stream_build import BUILD, STAND_IN, build
from .stream_job import CHUNK_TIMEOUT, StreamJob, StreamResult, chunk_meta, chunk_patterns
from .stream_records import RECORD_DEPTH, run_records
from .stream_spaces import (
    ArraySpace,
    ConcatSpace,
    FullSpace,
    ProductSpace,
    Space,
    as_space,
    edge_codes,
    full_space,
    grid_space,
    parse_pair,
    parse_shard,
    shard_range,
    shard_weights,
)
from .stream_wrapper import (
    DEPTH,
    MAX_PATH,
    PATTERNS,
    PERIOD_NS,
    memory_fields,
    render,
    split_word,
    stand_in_verilog,
    word_codes,
    wrapper_verilog,
)

__all__ = ["PATTERNS", "render", "Space", "FullSpace", "ProductSpace", "ArraySpace", "ConcatSpace", "full_space",
           "grid_space", "edge_codes", "as_space", "shard_range", "shard_weights", "parse_pair", "parse_shard",
           "wrapper_verilog", "stand_in_verilog", "run_stream", "run_records", "measure_throughput", "StreamResult",
           "DEPTH", "CHUNK", "AHEAD", "BUILD", "RECORD_DEPTH", "STAND_IN", "CHUNK_TIMEOUT", "MAX_PATH", "PERIOD_NS"]

#: Default vectors per chunk.
CHUNK = 1 << 20
#: Chunk files written ahead of the simulator.
AHEAD = 2


def _producer(params, space: Space, lo: int, chunks: list, counter: bool, job: Path, stop: threading.Event,
              errors: list, ahead: int = AHEAD):
    """Write ``chunk_<k>.bin`` (inputs and the model's expected outputs, :func:`fxmodel.core.vectors.write_words`; the
    input fields zero in counter mode), at most ``ahead`` unchecked (``1``: chunk ``k + 1`` is computed only once
    the simulator has checked chunk ``k``, so the two never run at once)."""
    fields = memory_fields(params)
    n_in = len(params.inputs)
    try:
        for k, (a, b) in enumerate(chunks):
            while k >= ahead and (job / f"chunk_{k - ahead}.bin").exists() and not stop.is_set():
                time.sleep(0.002)
            if stop.is_set():
                return
            inputs = np.asarray(space.take(lo + a, lo + b), dtype=np.int64)
            if inputs.shape != (b - a, n_in):
                raise RuntimeError(f"the input space gave shape {inputs.shape} for rows {lo + a}..{lo + b}")
            codes = word_codes(np.zeros_like(inputs) if counter else inputs, params.compute(inputs))
            os.replace(write_words(job / f"chunk_{k}.tmp", fields, codes), job / f"chunk_{k}.bin")
    except BaseException as exc:                        # the testbench sees ABORT and stops waiting
        errors.append(exc)
        (job / "ABORT").write_text(f"{type(exc).__name__}: {exc}")


def _decode(params, rec: dict, lo: int, space: Space, counter: bool) -> dict:
    """A wrapper mismatch record (memory word, outputs) as codes; in counter mode the inputs are the row's."""
    ow = sum(p.fmt.width for p in params.outputs)
    got, index = rec["got"], lo + rec["index"]
    inputs = space.take(index, index + 1)[0].tolist() if counter else split_word(rec["vector"], params.inputs, ow)
    return {"index": index, "inputs": inputs,
            "rtl": split_word(got, params.outputs) if isinstance(got, int) else f"x/z bits: {got}",
            "model": split_word(rec["vector"], params.outputs)}


def run_stream(params, space=None, *, sim: str | None = None, lo: int = 0, hi: int | None = None,
               shard=None, chunk: int = CHUNK, keep: int = 8, rtl_params=None, variant: str = "",
               progress=None, tag: str | None = None, waves: bool | None = None, pattern="none", seed: int = 1,
               dump: bool = False, ahead: int = AHEAD) -> StreamResult:
    """Stream rows ``lo..hi`` of ``space`` through the unit's RTL and compare every output with ``params.compute``.

    Parameters
    ----------
    params : Unit
        The unit's parameter object: golden model, ports, latency.
    space : Space, array or None
        The input vectors: a :class:`Space`, codes ``(K, inputs)``, or ``None`` for the whole input space.
    sim : str
        ``icarus`` or ``verilator`` (default: ``SIM``, else ``icarus``).
    lo, hi : int
        Row range of ``space`` to check (default: all of it).
    shard : "i/N" or (i, N)
        Check only shard ``i`` of ``N`` (1-based) of ``[lo, hi)``; see :func:`shard_range`.
    chunk : int
        Vectors per chunk file, 1 to :data:`DEPTH`.
    keep : int
        Mismatches recorded in full (all of them are counted), 1 to 64.
    rtl_params : Unit
        Generate the RTL from this parameter object instead (the model stays ``params``): how a deliberately
        broken variant is checked. Needs ``variant`` unless it is ``params`` itself.
    variant : str
        Name of the RTL variant, part of its build folder's name.
    progress : bool or tqdm
        Show a progress bar (default: when the run has more than 4 chunks), or update this tqdm bar.
    tag : str
        A label in the job folder's name (:func:`cosim.job.job_folder`: the folder is always new, under the build
        folder, and removed after the run unless the simulation failed or waveforms were dumped).
    waves : bool
        Dump waveforms (default: ``WAVES`` environment variable).
    pattern : str or sequence of str
        Gaps on the input valid and backpressure on the output ready (:data:`PATTERNS`); a sequence gives chunk
        ``k`` pattern ``k mod len``.
    seed : int
        Seed of the wrapper's pattern generators (chunk ``k`` uses ``seed + k``).
    dump : bool
        Also write out every output code: ``result.rtl`` (codes ``(vectors, outputs)``).
    ahead : int
        Chunk files the model may have written and the simulator not yet checked, 1 or more. The default
        (:data:`AHEAD`) lets the model compute chunk ``k + 1`` while the simulator checks chunk ``k``: faster on a
        free core, but the run takes more than one core. ``1``: the model and the simulator take turns, and the
        run uses one core at a time: what a Dask task (:mod:`tools.exhaustive`) takes, so that ``N`` workers on
        ``N`` cores run ``N`` times as fast.

    Returns
    -------
    StreamResult
        Counts, timings and the first mismatches; :attr:`StreamResult.ok` tells whether the RTL matched.

    Raises
    ------
    ValueError
        For a bad argument. ``RuntimeError`` if the build, the vector generation or the simulation failed
        (the message names the log file).
    """
    sim, waves = simulator(sim), waves_wanted(waves)
    rtl_params = _check_variant(params, rtl_params, variant)
    if not isinstance(chunk, int) or not 1 <= chunk <= DEPTH:
        raise ValueError(f"chunk={chunk!r}: must be an int from 1 to DEPTH={DEPTH}")
    if not isinstance(ahead, int) or ahead < 1:
        raise ValueError(f"ahead={ahead!r}: must be an int >= 1")
    space = as_space(params, space)
    lo, hi = _run_range(len(space), lo, hi, shard)
    n = hi - lo
    chunks = [(s, min(s + chunk, n)) for s in range(0, n, chunk)]
    patterns = chunk_patterns(pattern, len(chunks))

    bld = build(params, rtl_params, variant, sim, keep, waves, stand_in=variant == STAND_IN)
    # the whole input space in order: the wrapper counts the inputs itself and reads only the expected outputs
    counter = isinstance(space, FullSpace) and sum(p.fmt.width for p in params.inputs) <= 64
    job = StreamJob(params, bld, sim, waves, tag, {
        "mode": "stream", "build": bld.bdir.name, "space": space.describe(), "range": [lo, hi], "chunk": chunk,
        "patterns": patterns, "seed": seed, "keep": keep, "dump": bool(dump), "codes": _space_digest(space)})
    job.write_meta({**chunk_meta(params, [e - s for s, e in chunks], patterns, seed, keep, dump),
                    "bases": [lo + s for s, _ in chunks], "counter": counter})
    errors = []
    job.simulate(chunks, progress, producer=lambda stop: _producer(params, space, lo, chunks, counter, job.path,
                                                                   stop, errors, ahead))
    rtl = job.read_dump(len(chunks)) if dump and not errors and job.failure is None else None
    if errors:
        raise RuntimeError(f"generating the vectors of {params.NAME} failed: {errors[0]!r}") from errors[0]
    res = job.report()
    result = job.result(res, vectors=res["checked"], expected=n, mismatches=res["mismatches"],
                        valid_errors=res["valid_errors"], patterns=patterns,
                        first=[_decode(params, r, lo, space, counter) for r in res["records"]],
                        space=space.describe(), span=(lo, hi), chunks=len(chunks), variant=variant or None)
    return job.finish(result, rtl)


def _check_variant(params, rtl_params, variant: str):
    """The parameter object the RTL is generated from: ``params`` unless ``rtl_params`` (a named ``variant`` of
    the same unit, same ports and latency)."""
    if rtl_params is None:
        rtl_params = params
    elif rtl_params is not params and not variant:
        raise ValueError("rtl_params is not params: name the RTL variant (variant=...) so that its build folder "
                         "differs from the true unit's")
    if type(rtl_params) is not type(params) or rtl_params.inputs != params.inputs \
            or rtl_params.outputs != params.outputs or rtl_params.latency != params.latency:
        raise ValueError("rtl_params must be a parameter object of the same unit with the same ports and latency "
                         "as params")
    return rtl_params


def _run_range(total: int, lo: int, hi: int | None, shard) -> tuple[int, int]:
    """Rows ``[lo, hi)`` of a space of ``total`` vectors (``hi`` default: the end), then shard ``shard`` of
    them; ``ValueError`` if outside the space or empty."""
    hi = total if hi is None else hi
    if not 0 <= lo <= hi <= total:
        raise ValueError(f"range [{lo}, {hi}) is not inside the space of {total} vectors")
    a, b = shard_range(hi - lo, shard)
    lo, hi = lo + a, lo + b
    if hi == lo:
        raise ValueError(f"empty range [{lo}, {hi}): nothing to check")
    return lo, hi


def _space_digest(space: Space) -> str | None:
    """For a space of explicit vectors, a digest of its codes (part of a job's definition; others are described
    in full by :meth:`Space.describe`)."""
    if not isinstance(space, ArraySpace):
        return None
    return hashlib.sha256(np.ascontiguousarray(space.codes).tobytes()).hexdigest()[:16]


def measure_throughput(params, sim: str | None = None, vectors: int | None = None, seed: int = 0,
                       inputs: str = "random", pattern: str = "none", stand_in: bool = False) -> StreamResult:
    """Streaming co-simulation throughput in vectors/s, for ``make bench`` beside the per-vector figure.

    ``inputs="random"``: the unit's hard cases and random inputs (uniform over every input's codes), read from
    the vector files; ``"exhaustive"``: the first ``vectors`` rows of the whole input space, counted by the wrapper
    (how ``make exhaustive`` runs). ``pattern``: the stimulus (:data:`PATTERNS`; ``random`` puts backpressure in
    the loop). Returns the run's :class:`StreamResult` (``vectors_per_second`` on the wall clock,
    ``sim_cpu_seconds`` for the rate on a loaded machine). ``stand_in=True`` runs the same through
    :func:`stand_in_verilog` instead of the unit (its outputs are not the model's and are not judged): the
    harness' own cost. ``vectors`` defaults to 2**22 on Verilator and 2**18 on Icarus. Every output
    is checked bit for bit; the time counts the model, the vector files and the simulation, not the HDL build
    (done first). Raises ``AssertionError`` if the RTL does not match, ``ValueError`` for a bad argument.
    """
    sim = simulator(sim)
    vectors = vectors or (1 << 22 if sim == "verilator" else 1 << 18)
    extra = {"rtl_params": params, "variant": STAND_IN} if stand_in else {}
    if inputs == "random":
        rng = np.random.default_rng(seed)
        codes = np.concatenate([params.hard_cases(), params.random_inputs(rng, vectors)])[:vectors]
        result = run_stream(params, ArraySpace(codes, "hard cases and random vectors"), sim=sim, progress=False,
                            pattern=pattern, **extra)
    elif inputs == "exhaustive":
        result = run_stream(params, sim=sim, hi=min(vectors, params.input_space()), progress=False,
                            pattern=pattern, **extra)
    else:
        raise ValueError(f"inputs={inputs!r}: 'random' or 'exhaustive'")
    assert stand_in or result.ok, result.describe()
    return result

