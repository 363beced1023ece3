"""Generic co-simulation harness: any unit, any vectors, Icarus or Verilator, through cocotb's Python runner.

``run(params, inputs)`` generates the unit's Verilog from its parameter object (cached per parameter hash),
computes the expected outputs with the golden model, hands both to the cocotb testbench ``cosim.tb`` (which
streams one vector per clock into the RTL and records every output) and compares the RTL's outputs with the
model's, bit for bit, here in numpy. Nothing is sampled or tolerated: a single differing bit is a mismatch,
reported with its row, inputs, the RTL's and the model's codes.

Environment: ``SIM`` (``icarus`` default, or ``verilator``), ``WAVES=1`` dumps a waveform into the build folder.
"""

from __future__ import annotations

import fcntl
import json
import os
import time
from pathlib import Path

import numpy as np

from fxmodel.core.paths import ROOT, build_dir
from rtl.digest import params_key

from .job import job_folder, remove_job
from .simulators import SIMULATORS, build_args, simulator, verilator_env, waves_wanted

BUILD = build_dir("cosim")

__all__ = ["component_build", "run_testbench", "run", "simulator", "build_and_test", "build_folder", "CosimResult",
           "SIMULATORS", "verilator_env", "params_key"]


class CosimResult(dict):
    """Results of one run: ``vectors, mismatches, first`` (list of dicts), ``seconds``, ``vectors_per_second``."""

    def describe(self) -> str:
        lines = [f"{self['unit']} [{self['simulator']}]: {self['vectors']} vectors, {self['mismatches']} mismatches, "
                 f"{self['seconds']:.1f} s, {self['vectors_per_second']:.0f} vectors/s"]
        for f in self["first"]:
            lines.append(f"  row {f['row']}: inputs {f['inputs']} rtl {f['rtl']} model {f['model']}")
        return "\n".join(lines)


def _verilog(params, bdir: Path, top: str, sim: str) -> Path:
    """The unit's Verilog in the build folder: optimized by Yosys for Icarus (event-driven, much faster on a
    flattened, optimized netlist), as Amaranth writes it for Verilator (which optimizes itself)."""
    from rtl import write_verilog
    path = bdir / f"{top}.v"
    if not path.exists():
        write_verilog(params, path, optimize=(sim == "icarus"), flat=True)
    return path


def component_build(top: str, key: str, sim: str, component) -> tuple[str, Path, Path]:
    """``(top, build folder, Verilog source)`` of a testbench design: the folder ``BUILD/<sim>/<top>_<key>``, the
    Verilog of ``component()`` written once (under a lock: parallel workers share it), optimized by Yosys for Icarus
    and as Amaranth writes it for Verilator. ``key`` names everything the design is built from (parameters and
    sources: :func:`rtl.digest.params_key`)."""
    from rtl.verilog import component_verilog
    bdir = BUILD / sim / f"{top}_{key}"
    bdir.mkdir(parents=True, exist_ok=True)
    src = bdir / f"{top}.v"
    with open(bdir / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not src.exists():
            src.write_text(component_verilog(component(), top, optimize=(sim == "icarus"), rename=True))
    return top, bdir, src


def build_folder(params, sim: str, tag: str = ""):
    """``(top, build folder, Verilog source, job folder)`` of a design named ``params.NAME``: the folder is keyed
    by the parameters and the sources, the Verilog written once (under a lock: parallel workers share it); the job
    folder is new, labelled ``tag`` (:func:`cosim.job.job_folder`)."""
    top = params.NAME
    bdir = BUILD / sim / f"{top}_{params_key(params)}"
    bdir.mkdir(parents=True, exist_ok=True)
    with open(bdir / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        src = _verilog(params, bdir, top, sim)
    job = job_folder(bdir, tag or "job", {"unit": top, "sim": sim, "tag": tag})
    return top, bdir, src, job


def build_and_test(sim: str, src, top: str, bdir: Path, job: Path, test_module: str,
                   waves: bool = False) -> tuple[float, float]:
    """Compile ``src`` (top ``top``) in ``bdir`` under its lock (parallel workers share a build folder) and run
    the cocotb ``test_module`` with ``COSIM_JOB=job``; return ``(build seconds, test seconds)``."""
    from cocotb_tools.runner import get_runner

    runner = get_runner(sim)
    if sim == "verilator":
        verilator_env()
    t0 = time.perf_counter()
    with open(bdir / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        runner.build(sources=[src], hdl_toplevel=top, build_dir=bdir, timescale=("1ns", "1ps"), waves=waves,
                     build_args=build_args(sim))
    t1 = time.perf_counter()
    env = {"COSIM_JOB": str(job), "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    runner.test(hdl_toplevel=top, test_module=test_module, build_dir=bdir, test_dir=job, extra_env=env,
                waves=waves, results_xml=str(job / "results.xml"))
    return round(t1 - t0, 2), round(time.perf_counter() - t1, 2)


def run_testbench(sim: str, src, top: str, bdir: Path, job: Path, test_module: str, meta: dict,
                  result: str) -> tuple[Path, float, float]:
    """One testbench run in its job folder: write its inputs (``job.json``: ``meta`` and ``out``, the path of the
    ``result`` file it writes), build and run the cocotb ``test_module`` (:func:`build_and_test`), and return
    ``(result path, build seconds, test seconds)``; ``RuntimeError`` when the testbench wrote no result."""
    out = job / result
    (job / "job.json").write_text(json.dumps({**meta, "out": str(out)}))
    build_seconds, seconds = build_and_test(sim, src, top, bdir, job, test_module)
    if not out.exists():
        raise RuntimeError(f"the testbench wrote no results ({out}); see the simulator log above")
    return out, build_seconds, seconds


def run(params, inputs: np.ndarray, *, sim: str | None = None, waves: bool | None = None,
        tag: str = "", keep_first: int = 8) -> CosimResult:
    """Stream ``inputs`` (codes ``(K, inputs)``) through the unit's RTL and compare with the model."""
    sim = simulator(sim)
    waves = waves_wanted(waves)
    inputs = np.asarray(inputs, dtype=np.int64)
    if inputs.ndim == 1:
        inputs = inputs[:, None]
    expected = params.compute(inputs)
    top, bdir, src, job = build_folder(params, sim, tag)
    in_bits = np.stack([p.fmt.to_bits(inputs[:, i]) for i, p in enumerate(params.inputs)], axis=1)
    np.save(job / "inputs.npy", in_bits.astype(np.uint64))
    meta = {"inputs": [p.name for p in params.inputs], "outputs": [p.name for p in params.outputs],
            "latency": params.latency, "vectors": int(len(inputs)), "result": str(job / "rtl_outputs.npy")}
    (job / "meta.json").write_text(json.dumps(meta))
    result_file = job / "rtl_outputs.npy"
    build_seconds, seconds = build_and_test(sim, src, top, bdir, job, "cosim.tb", waves=waves)
    if not result_file.exists():
        raise RuntimeError(f"the testbench wrote no results ({result_file}); see the simulator log above")
    raw = np.load(result_file)
    got = np.stack([p.fmt.from_bits(raw[:, i].astype(np.int64)) for i, p in enumerate(params.outputs)], axis=1)
    if got.shape != expected.shape:
        raise RuntimeError(f"the RTL produced {got.shape[0]} results for {expected.shape[0]} vectors")
    bad = np.flatnonzero(np.any(got != expected, axis=1))
    first = [{"row": int(r), "inputs": inputs[r].tolist(), "rtl": got[r].tolist(), "model": expected[r].tolist()}
             for r in bad[:keep_first]]
    result = CosimResult(unit=params.NAME, simulator=sim, vectors=int(len(inputs)), mismatches=int(len(bad)),
                         first=first, build_seconds=build_seconds, seconds=seconds,
                         vectors_per_second=len(inputs) / seconds if seconds else float("inf"),
                         waves=str(job) if waves else None)
    result.rtl = got                       # every output code the RTL produced (not part of the JSON report)
    if not waves:
        remove_job(job)
    return result
