"""Co-simulation under stress, by discovery: every registered unit and every preset (a new preset is co-simulated
without touching this file) streams its hard cases and random vectors through its stream version
(``rtl/streams.py``) under four stimulus patterns, every output compared bit for bit with the model and counted.

The patterns (:data:`cosim.stream.PATTERNS`, one per chunk of the run): ``none`` (valid and ready always high:
the exact latency and one result per clock are checked on every cycle), ``random`` (valid and ready each high
half the time), ``bursts`` (both on and off in runs of 1 to 64 cycles), ``stalls`` (random gaps on the input,
ready held low for 256 to 767 cycles at a time). Counted and required zero: mismatches, results missing,
results nobody asked for, outputs that changed or were withdrawn while waiting for ready; and the run must have
stalled both the output and the input, or it proved nothing about backpressure.

Why the stimulus is generated in the HDL wrapper (``cosim/stream_wrapper.v.j2``, two xorshift generators and run
counters) and not by a cocotb driver such as cocotbext-axi's ``AxiStreamSource`` / ``AxiStreamSink`` with
``set_pause_generator``: those drive and sample both interfaces from Python on every clock edge, and the
per-vector harness built that way (``cosim/tb.py``, one coroutine) already tops out at about ten thousand vectors a
second on Icarus (the pipeline: about 900); the wrapper clocks itself and cocotb wakes once a
chunk, so the same stress runs at the streaming harness' rate (tens of thousands of vectors a second on Icarus,
over a million on Verilator), which is what lets every preset be stressed in ``make test``. The wrapper also
checks the handshake rules cocotbext-axi would not count for us (results nobody asked for, outputs changed while
waiting). Quick tier: hard cases and 2000 random vectors a preset; ``-m slow``: 100 000 more.
"""

from __future__ import annotations

import numpy as np
import pytest

from cosim.stream import PATTERNS, run_stream
from fxmodel.core.unit import preset, preset_names, units

CASES = [(u, n) for u in units() for n in preset_names(u)]


def stress(sim, unit, name, random_vectors, seed=0):
    params = preset(unit, name)
    rng = np.random.default_rng([seed, *map(ord, unit + name)])
    vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, random_vectors)])
    chunk = -(-len(vectors) // len(PATTERNS))
    result = run_stream(params, vectors, sim=sim, chunk=chunk, pattern=list(PATTERNS), seed=seed + 1)
    assert result["chunks"] == len(PATTERNS) and result["patterns"] == sorted(PATTERNS)
    assert result["vectors"] == len(vectors), result.describe()
    assert result.ok, result.describe()
    assert result["stalled"] > 0 and result["starved"] > 0, "no backpressure happened: the test proved nothing"
    return result


@pytest.mark.parametrize("unit, name", CASES, ids=[f"{u}-{n}" for u, n in CASES])
def test_every_unit_and_preset_under_stalls(sim, unit, name):
    stress(sim, unit, name, 2000)


@pytest.mark.slow
@pytest.mark.parametrize("unit, name", CASES, ids=[f"{u}-{n}" for u, n in CASES])
def test_every_unit_and_preset_under_stalls_long(sim, unit, name):
    stress(sim, unit, name, 100_000, seed=7)
