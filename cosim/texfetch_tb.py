"""cocotb testbench of the decoupled texel cache (``rtl/texcache_decoupled.py`` in ``cosim.texfetch.FetchBench``),
driven by :func:`cosim.texfetch.run`.

``job.json`` (folder ``COSIM_JOB``) holds the request words (hex), the memory image of the surfaces and its base,
the bench's latency, the probabilities that the source offers a request in a cycle (``p_valid``; an offered
request stays offered until taken), that the sink is ready (``p_ready``) and of a wait state on each AXI read
channel (``p_pause``). Behind ``mem`` is cocotbext-axi's ``AxiRam``. Recorded: every ``AR`` transfer's address and
length (at the memory, after the delay queue), the ``R`` beats, the outputs, and the cycles from reset to the last
output; written to ``result.json``.
"""

from __future__ import annotations

import cocotb

from cosim.tb_common import job_meta, read_manager_walk


@cocotb.test()
async def texfetch(dut):
    _, meta = job_meta()
    await read_manager_walk(dut, meta, meta["latency"])
