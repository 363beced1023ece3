"""cocotb testbench of the texture fetch with its maps in LiteDRAM's simulation core (``cosim/texfetch_dram.py``'s
``FetchDramBench``), driven by :func:`cosim.texfetch.run_fetch` with ``dram_ns``.

``job.json`` (folder ``COSIM_JOB``) holds what ``cosim/texfetch_tb.py``'s does and the SDRAM's clock period
(``dram_ns``). With the engine's clock held in reset, the SDRAM's clock starts, the core's init sequence opens its
ports (``ready``), the memory image is written at its base (the maps' place in the SDRAM) through the core's
first port (``load``, cocotbext-axi's ``AxiMaster``) and read back (the load must be exact); then the requests run
as in that testbench, the fetch's bursts and beats counted at its own port (``mem``, the engine's clock).
"""

from __future__ import annotations

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge

from cosim.tb_common import job_meta, read_manager_walk


@cocotb.test()
async def texfetch_dram(dut):
    from cocotbext.axi import AxiBus, AxiMaster
    _, meta = job_meta()
    image = bytes.fromhex(meta["image"])

    async def memory(dut):
        cocotb.start_soon(Clock(dut.dram_clk, meta["dram_ns"], unit="ns").start())
        dut.dram_rst.value = 1
        master = AxiMaster(AxiBus.from_prefix(dut, "load_"), dut.dram_clk, dut.dram_rst)
        for side in (master.write_if, master.read_if):
            side.log.setLevel("WARNING")
        for _ in range(4):
            await FallingEdge(dut.dram_clk)
        dut.dram_rst.value = 0
        for _ in range(meta["max_cycles"]):
            await FallingEdge(dut.dram_clk)
            if int(dut.ready.value):
                break
        assert int(dut.ready.value), "the SDRAM core's port did not open"
        await master.write(meta["base"], image)
        back = await master.read(meta["base"], len(image))
        assert bytes(back.data) == image, "the maps read back from the SDRAM differ from those written"

    await read_manager_walk(dut, meta, memory=memory)
