"""cocotb testbench of the texel cache (``rtl/texcache.py``), driven by :func:`cosim.texcache.run`.

``job.json`` in the folder named by ``COSIM_JOB`` holds the request words (hex), the memory image of the map and its
base address, the probabilities that the source offers a request in a cycle (``p_valid``; an offered request stays
offered until taken), that the sink is ready (``p_ready``) and of a wait state on each AXI read channel
(``p_pause``). Behind ``mem`` is cocotbext-axi's ``AxiRam``. The testbench records every ``AR`` transfer's address
and length, counts the ``R`` beats and collects the outputs, and writes them to ``result.json``.
"""

from __future__ import annotations

import cocotb

from cosim.tb_common import job_meta, read_manager_walk


@cocotb.test()
async def texcache(dut):
    _, meta = job_meta()
    await read_manager_walk(dut, meta)
