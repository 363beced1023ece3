"""Co-simulation harness of the scan converter: records from :func:`fxmodel.units.raster.setup` through
``rtl/raster.py`` (cocotb testbench ``cosim.raster_tb``), fragments compared with :func:`fxmodel.units.raster.scan` bit
for bit, and the clock count with the model's."""

from __future__ import annotations

import json

import numpy as np

from fxmodel.units.raster import RasterParams, scan

from .harness import build_folder, run_testbench, simulator
from .job import remove_job

__all__ = ["run", "pack", "unpack"]


def pack(ports, rows) -> list[int]:
    """Codes ``(K, ports)`` -> one integer per row, the first port in the low bits (a StructLayout's order)."""
    out = []
    for row in np.asarray(rows, dtype=np.int64).tolist():
        word, shift = 0, 0
        for p, c in zip(ports, row):
            word |= (int(c) & ((1 << p.fmt.width) - 1)) << shift
            shift += p.fmt.width
        out.append(word)
    return out


def unpack(ports, words) -> np.ndarray:
    """The inverse of :func:`pack`: codes ``(K, ports)`` (signed fields sign-extended)."""
    rows = []
    for word in words:
        row, shift = [], 0
        for p in ports:
            bits = (word >> shift) & ((1 << p.fmt.width) - 1)
            if p.fmt.signed and bits >> (p.fmt.width - 1):
                bits -= 1 << p.fmt.width
            row.append(bits)
            shift += p.fmt.width
        rows.append(row)
    return np.array(rows, dtype=np.int64).reshape(-1, len(ports))


def run(params, records, *, p_valid: float = 1.0, p_ready: float = 1.0, seed: int = 1,
        sim: str | None = None, tag: str = "") -> dict:
    """Simulate ``records`` (a :class:`~fxmodel.units.raster.Records` or codes ``(T, fields)``) through the scan
    converter (``params`` a :class:`RasterParams`) or the engine from the triangle (a
    :class:`~fxmodel.pipeline.engine.EngineParams`, through the pixel pipeline's stream interface);
    return a report with ``mismatches`` (outputs differing from the model, or a different count), the RTL's
    ``busy_cycles`` and ``busy_span`` (first to last busy cycle) and the model's ``clocks``; ``report["rtl"]``
    holds the RTL's output codes."""
    sim = simulator(sim)
    mat = records.matrix() if hasattr(records, "matrix") else np.asarray(records, dtype=np.int64)
    engine = not isinstance(params, RasterParams)
    raster = params.raster if engine else params
    if engine:
        want, expected = params.compute(mat)
        ports = params.outputs
    else:
        expected = scan(params, mat)
        want = expected.matrix(params)
        ports = params.fragment
    top, bdir, src, job = build_folder(params, sim, tag)
    budget = int(expected.clocks.sum() / max(min(p_valid, p_ready), 0.05) * 4) + 1000 + 2 * len(mat)
    meta = {"records": [format(w, "x") for w in pack(raster.record, mat)], "p_valid": p_valid,
            "p_ready": p_ready, "seed": seed, "max_cycles": budget,
            "expected": int(len(want))}
    meta["drain"] = raster.latency + (params.latency if engine else 0) + 8   # the fill latency, the pipeline's
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.raster_tb", meta, "fragments.json")
    res = json.loads(out.read_text())
    remove_job(job)                                        # (kept, with the simulator's output, if the run failed)
    got = unpack(ports, [int(w, 16) for w in res["fragments"]])
    n = min(len(got), len(want))
    bad = np.flatnonzero(np.any(got[:n] != want[:n], axis=1))
    first = [{"row": int(r), "rtl": got[r].tolist(), "model": want[r].tolist()} for r in bad[:5]]
    return {"rtl": got, "simulator": sim, "records": int(len(mat)), "fragments": int(len(got)),
            "expected": int(len(want)),
            "mismatches": int(len(bad)) + abs(len(got) - len(want)), "first": first,
            "busy_cycles": res["busy_cycles"], "busy_span": res["busy_span"], "clocks": int(expected.clocks.sum()),
            "cycles": res["cycles"],
            "build_seconds": build_seconds, "seconds": seconds}
