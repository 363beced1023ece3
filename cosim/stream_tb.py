"""cocotb side of the streaming co-simulation (:mod:`cosim.stream`): orchestration only, no vector in Python.

The job folder named by ``STREAM_JOB`` holds ``meta.json`` (chunk lengths, mismatch records kept, widths) and
receives ``chunk_<k>.bin`` files from the model (binary words for ``$fread``). For each chunk this test waits for its
file, hands it to the
wrapper (``chunk_len``, then ``load_seq = k + 1``), waits until the wrapper raises ``done_seq`` to ``k + 1``,
deletes the file and records progress. At the end it reads the wrapper's counters and first mismatch records and
writes ``result.json``; the caller judges them. Each chunk has its own stimulus pattern and seed (gaps on the
input valid, backpressure on the output ready), generated inside the wrapper. The clock runs inside the wrapper:
Python wakes once a chunk.
In the wrapper's ``expand`` mode (:func:`cosim.stream.run_records`) ``meta.json`` also gives each chunk's output
count (``out_lens``) and cycle limit (``limits``).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import cocotb
from cocotb.triggers import Timer


def _write(path: Path, text: str):
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


_PARENT = os.getppid()


def _wait_for(path: Path, job: Path, timeout: float):
    """Block (the simulator has nothing to do meanwhile) until the model has written ``path``."""
    t0 = time.monotonic()
    while not path.exists():
        if (job / "ABORT").exists():
            raise RuntimeError(f"the vector generator failed: {(job / 'ABORT').read_text()}")
        if os.getppid() != _PARENT:
            raise RuntimeError("the process that writes the vectors has gone")
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(f"no {path.name} after {timeout:.0f} s")
        time.sleep(0.001)


def _slots(value, width: int, keep: int) -> list:
    """Split a flat record vector into ``keep`` slots (slot ``s`` at bits ``[s*width +: width]``); a slot with
    x/z bits stays a string."""
    bits = str(value)
    out = []
    for s in range(keep):
        part = bits[len(bits) - (s + 1) * width:len(bits) - s * width]
        out.append(int(part, 2) if set(part) <= {"0", "1"} else part)
    return out


@cocotb.test()
async def stream(dut):
    job = Path(os.environ["STREAM_JOB"])
    meta = json.loads((job / "meta.json").read_text())
    result = {"error": None}
    try:
        dut.rst.value = 1
        dut.load_seq.value = 0
        dut.chunk_len.value = 0
        dut.chunk_base.value = 0
        dut.counter.value = int(meta["counter"])
        dut.pattern.value = 0
        dut.seed.value = 1
        dut.dump.value = int(meta["dump"])
        await Timer(3 * meta["period_ns"], unit="ns")
        dut.rst.value = 0
        await Timer(meta["period_ns"], unit="ns")
        t0, c0 = time.perf_counter(), time.process_time()
        for k, n in enumerate(meta["chunks"]):
            path = job / f"chunk_{k}.bin"
            _wait_for(path, job, meta["timeout"])
            dut.chunk_len.value = n
            dut.chunk_base.value = meta["bases"][k]
            dut.pattern.value = meta["patterns"][k]
            dut.seed.value = meta["seeds"][k]
            if "out_lens" in meta:
                dut.out_len.value = meta["out_lens"][k]
                dut.limit.value = meta["limits"][k]
            dut.load_seq.value = k + 1
            while int(dut.done_seq.value) != k + 1:
                await dut.done_seq.value_change
            path.unlink()
            _write(job / "progress", str(k + 1))
        result["sim_seconds"] = time.perf_counter() - t0
        result["sim_cpu_seconds"] = time.process_time() - c0       # the simulator process: HDL and cocotb
        keep, w = meta["keep"], meta["iw"] + meta["ow"]
        for name in ("checked", "mismatches", "valid_errors", "missing", "extra", "protocol_errors", "cycles",
                     "stalled", "starved") + (("busy_cycles",) if meta.get("busy") else ()):
            result[name] = int(getattr(dut, name).value)
        stored = min(keep, result["mismatches"])              # (expand mode: none, the caller compares)
        if stored:
            index = _slots(dut.rec_index.value, 64, keep)
            vector = _slots(dut.rec_vector.value, w, keep)
            got = _slots(dut.rec_got.value, meta["ow"], keep)
        result["records"] = [{"index": index[s], "vector": vector[s], "got": got[s]} for s in range(stored)]
    except BaseException as exc:
        result["error"] = f"{type(exc).__name__}: {exc}"
        raise
    finally:
        _write(job / "result.json", json.dumps(result))
