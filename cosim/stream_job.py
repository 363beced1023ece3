"""The job core of the streaming co-simulation, shared by its two run modes (:func:`cosim.stream.run_stream`,
:func:`cosim.stream_records.run_records`).

A :class:`StreamJob` is one simulator run of a built wrapper (:mod:`cosim.stream_build`), composed of the steps
both modes take: a job folder of its own (:func:`cosim.job.job_folder`: new, under the build folder, named by a
digest of the job), ``meta.json`` for the testbench (:func:`StreamJob.write_meta`, the per-chunk stimulus from
:func:`chunk_patterns` and :func:`chunk_meta`), the cocotb run with a progress bar and, in
:func:`~cosim.stream.run_stream`, the model's producer thread beside it (:meth:`StreamJob.simulate`), the
testbench's report (:meth:`StreamJob.report`), the :class:`StreamResult` (:meth:`StreamJob.result`) and the
clean-up (:meth:`StreamJob.finish`: the folder is deleted after a successful run unless waveforms were dumped).
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import ROOT

from .job import job_folder, remove_job
from .stream_build import Build, tail, verbose
from .stream_wrapper import MAX_PATH, PATTERNS, PERIOD_NS

__all__ = ["StreamResult", "StreamJob", "chunk_patterns", "chunk_meta", "CHUNK_TIMEOUT", "TESTBENCH"]

#: Seconds the testbench waits for a chunk file before giving up.
CHUNK_TIMEOUT = 600.0
TESTBENCH = "cosim.stream_tb"


class StreamResult(dict):
    """One streaming run.

    Keys: ``unit``, ``simulator``, ``vectors`` (outputs compared), ``expected_vectors``, ``mismatches``,
    ``first`` (up to ``keep`` dicts ``index, inputs, rtl, model``; ``index`` is the row of the input space),
    ``valid_errors`` (under pattern ``none``: cycles where ``o__valid`` was not the input handshake delayed by
    the latency), ``missing`` (vectors whose output never came), ``extra`` (outputs nobody asked for),
    ``protocol_errors`` (an output offered, not taken, then changed or withdrawn), ``patterns`` (the stimulus of
    each chunk), ``cycles`` (clock cycles of the chunks), ``stalled`` / ``starved`` (cycles an output / an input
    waited for ready), ``rtl`` (the output codes, when the run dumped them), ``seconds`` (wall time of the
    check: model, files and simulation, the HDL build excluded), ``vectors_per_second``, ``sim_seconds`` (inside
    the simulator, from the first chunk to the last, waiting for the model included), ``sim_cpu_seconds`` (CPU time of
    the simulator process meanwhile: on a loaded machine the rate it gives, ``vectors / sim_cpu_seconds``, is the one
    to compare), ``build_seconds``,
    ``space``, ``range`` (``[lo, hi)`` of the space), ``chunks``, ``variant``, ``started``/``finished`` (Unix
    times).
    """

    @property
    def ok(self) -> bool:
        """Every vector compared exactly once, none differed, and the handshake held on every cycle."""
        return (self["mismatches"] == 0 and self["valid_errors"] == 0 and self["missing"] == 0
                and self["extra"] == 0 and self["protocol_errors"] == 0
                and self["vectors"] == self["expected_vectors"])

    def describe(self) -> str:
        lines = [f"{self['unit']} [{self['simulator']}]: {self['vectors']:,} vectors, {self['mismatches']:,} "
                 f"mismatches, {self['seconds']:.1f} s, {self['vectors_per_second']:,.0f} vectors/s"]
        if self["valid_errors"] or self["missing"] or self["extra"] or self["protocol_errors"]:
            lines.append(f"  stream protocol broken: {self['valid_errors']} cycles with o_valid != the input "
                         f"handshake delayed by the latency (no stalls), {self['missing']} vectors without output, "
                         f"{self['extra']} outputs without input, {self['protocol_errors']} outputs changed "
                         "while waiting")
        if self["vectors"] != self["expected_vectors"]:
            lines.append(f"  only {self['vectors']:,} outputs compared of {self['expected_vectors']:,} vectors")
        for f in self["first"]:
            lines.append(f"  index {f['index']}: inputs {f['inputs']} rtl {f['rtl']} model {f['model']}")
        return "\n".join(lines)


def chunk_patterns(pattern, chunks: int) -> list[str]:
    """The stimulus pattern of each of ``chunks`` chunks: ``pattern`` a name of :data:`PATTERNS` or a sequence of
    them (chunk ``k`` takes entry ``k mod len``); ``ValueError`` for a name that is not one."""
    patterns = [pattern] if isinstance(pattern, str) else list(pattern)
    if not patterns or any(p not in PATTERNS for p in patterns):
        raise ValueError(f"pattern={pattern!r}: one or more of {', '.join(PATTERNS)}")
    return [patterns[k % len(patterns)] for k in range(chunks)]


def chunk_meta(params, sizes: list, patterns: list, seed: int, keep: int, dump: bool) -> dict:
    """The part of ``meta.json`` both run modes write: chunk lengths, the stimulus of each chunk (its pattern's
    valid and ready modes, seed ``seed + k``), records kept, timeout, clock period, payload widths."""
    return {"chunks": list(sizes), "keep": keep, "timeout": CHUNK_TIMEOUT, "period_ns": PERIOD_NS, "dump": bool(dump),
            "patterns": [PATTERNS[p][0] | PATTERNS[p][1] << 2 for p in patterns],
            "seeds": [(seed + k) & 0xFFFFFFFF for k in range(len(sizes))],
            "iw": sum(p.fmt.width for p in params.inputs), "ow": sum(p.fmt.width for p in params.outputs)}


class StreamJob:
    """One run of the testbench :data:`TESTBENCH` on the build ``bld``, in a job folder of its own.

    Parameters
    ----------
    params : Unit
        The unit (its name for messages, its output ports for the dump).
    bld : Build
        The built simulation.
    sim : str
        The simulator.
    waves : bool
        Waveforms are dumped (the folder is then kept).
    label : str, optional
        A readable part of the folder's name (made safe: :func:`cosim.job.safe_label`).
    definition : dict
        Everything that defines the job: its digest names the folder.
    """

    def __init__(self, params, bld: Build, sim: str, waves: bool, label: str | None, definition: dict):
        self.params, self.bld, self.sim, self.waves = params, bld, sim, waves
        self.path = job_folder(bld.bdir, label, definition)
        if len(str(self.path)) + 32 > MAX_PATH:
            remove_job(self.path)
            raise ValueError(f"job folder path too long for the wrapper's file-name register ({len(str(self.path))} "
                             f"> {MAX_PATH - 32} characters): {self.path}")
        self.started = self.seconds = None
        self.failure = self.log = None

    def write_meta(self, meta: dict):
        """Write ``meta.json``, the testbench's instructions."""
        (self.path / "meta.json").write_text(json.dumps(meta))

    def simulate(self, ends: list, progress, producer=None):
        """Run the testbench, with a progress bar moved by the chunks it reports done (``ends``: ``(start, end)``
        of each chunk in the unit the bar counts) and ``producer(stop)`` in a thread beside it (until ``stop``
        is set); the chunk files are deleted once the run ends. Sets ``failure``, ``log``, ``started`` and
        ``seconds``."""
        stop = threading.Event()
        self.started = time.time()
        t0 = time.perf_counter()
        thread = None
        if producer is not None:
            thread = threading.Thread(target=producer, args=(stop,), daemon=True)
            thread.start()
        watcher = _progress(self.path, ends, f"{self.params.NAME} {self.sim}", progress, stop)
        try:
            self.failure, self.log = _testbench(self.bld, self.path, self.sim, self.waves)
        finally:
            stop.set()
            if thread is not None:
                thread.join()
            if watcher is not None:
                watcher.join()
            for f in self.path.glob("chunk_*"):
                f.unlink()
        self.seconds = time.perf_counter() - t0

    def report(self) -> dict:
        """The testbench's ``result.json``; ``RuntimeError`` naming the log if the run failed."""
        return _testbench_result(self.params, self.path, self.sim, self.failure, self.log)

    def read_dump(self, chunks: int) -> np.ndarray:
        """The output codes the wrapper wrote for ``chunks`` chunks, ``(vectors, outputs)``."""
        return _read_dump(self.params, self.path, chunks)

    def result(self, res: dict, *, vectors: int, expected: int, mismatches: int, valid_errors: int, patterns: list,
               first: list, space: str, span: tuple, chunks: int, variant, **more) -> StreamResult:
        """The :class:`StreamResult` of the run from the testbench's report ``res`` and what the mode found."""
        return StreamResult(
            unit=self.params.NAME, simulator=self.sim, vectors=vectors, expected_vectors=expected,
            mismatches=mismatches, valid_errors=valid_errors, missing=res["missing"], extra=res["extra"],
            protocol_errors=res["protocol_errors"], patterns=sorted(set(patterns)), cycles=res["cycles"],
            stalled=res["stalled"], starved=res["starved"], first=first, seconds=round(self.seconds, 3),
            vectors_per_second=vectors / self.seconds, sim_seconds=round(res["sim_seconds"], 3),
            sim_cpu_seconds=round(res["sim_cpu_seconds"], 3), build_seconds=round(self.bld.seconds, 2), space=space,
            range=list(span), chunks=chunks, variant=variant, started=self.started, finished=time.time(), **more)

    def finish(self, result: StreamResult, rtl=None) -> StreamResult:
        """Attach the output codes ``rtl`` (not part of the JSON report) and the waveform file; delete the job
        folder unless waveforms were dumped (the result holds all the run found; a failed run raised before
        this and keeps its folder and log)."""
        result.rtl = rtl
        if self.waves:
            result["waves"] = _waves_file(self.bld, self.path)
        else:
            remove_job(self.path)
        return result


def _testbench(bld: Build, job: Path, sim: str, waves: bool):
    """Run the cocotb side (:data:`TESTBENCH`) on the built wrapper with the job folder ``job``: ``(failure, log)``,
    the exception the run raised (``None``) and the simulator's log file."""
    from cocotb_tools.runner import get_runner

    env = {"STREAM_JOB": str(job), "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    log = job / "sim.log"
    try:
        get_runner(sim).test(hdl_toplevel=bld.top, hdl_toplevel_lang="verilog", test_module=TESTBENCH,
                             build_dir=bld.bdir, test_dir=job, extra_env=env, waves=waves,
                             plusargs=[f"+STREAM_DIR={job}"], results_xml=str(job / "results.xml"),
                             log_file=None if verbose() else log)
    except (Exception, SystemExit) as exc:              # judged with the testbench's own report
        return exc, log
    return None, log


def _testbench_result(params, job: Path, sim: str, failure, log: Path) -> dict:
    """The testbench's ``result.json``; ``RuntimeError`` naming the log if the run failed."""
    result_file = job / "result.json"
    res = json.loads(result_file.read_text()) if result_file.exists() else {"error": f"no {result_file}"}
    if res.get("error") or failure is not None:
        raise RuntimeError(f"the streaming simulation of {params.NAME} on {sim} failed: "
                           f"{res.get('error') or failure}; log: {log}\n{tail(log)}")
    return res


def _waves_file(bld: Build, job: Path) -> str | None:
    """The newest waveform dump of a run."""
    dumps = sorted(list(bld.bdir.glob("*.fst")) + list(bld.bdir.glob("*.vcd")) + list(job.glob("*.vcd"))
                   + list(job.glob("*.fst")), key=lambda f: f.stat().st_mtime)
    return str(dumps[-1]) if dumps else None


def _read_dump(params, job: Path, chunks: int) -> np.ndarray:
    """The output codes the wrapper wrote (``out_<k>.hex``, one hex word of the output payload a line, first
    output lowest), ``(vectors, outputs)``."""
    words = []
    for k in range(chunks):
        path = job / f"out_{k}.hex"
        text = path.read_text().split() if path.exists() else []
        words += [int(w, 16) if set(w) <= set("0123456789abcdef") else -1 for w in text]
    words = np.array(words, dtype=object)
    if (words == -1).any():
        raise RuntimeError(f"{params.NAME}: the RTL wrote outputs with x/z bits ({job})")
    cols, lsb = [], 0
    for p in params.outputs:                              # the output payload: first port lowest
        cols.append(p.fmt.from_bits(((words >> lsb) & ((1 << p.fmt.width) - 1)).astype(np.int64)))
        lsb += p.fmt.width
    return np.stack(cols, axis=1) if len(words) else np.zeros((0, len(params.outputs)), dtype=np.int64)


def _progress(job: Path, chunks: list, desc: str, progress, stop: threading.Event):
    """A thread moving a tqdm bar by the chunks the testbench reports done (its ``progress`` file)."""
    if progress is None:
        progress = len(chunks) > 4
    if progress is False:
        return None
    if progress is True:
        from tqdm import tqdm
        bar, own = tqdm(total=chunks[-1][1], desc=desc, unit="vec", unit_scale=True, smoothing=0.1), True
    else:
        bar, own = progress, False

    def watch():
        shown = 0
        while True:
            try:
                done = int((job / "progress").read_text() or 0)
            except (OSError, ValueError):
                done = 0
            now = chunks[done - 1][1] if done else 0
            if now > shown:
                bar.update(now - shown)
                shown = now
            if done >= len(chunks) or stop.is_set():
                break
            time.sleep(0.1)
        if own:
            bar.close()

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    return t
