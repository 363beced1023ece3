"""Co-simulation of the RTL against the golden model, bit for bit, with cocotb (see ``cosim.harness``)."""
