"""Formal verification of the handshakes (``make formal``, ``bumpmap formal``): properties in Amaranth,
proven by SymbiYosys with the Yices 2 solver; a verification layer that the hardware build (``rtl``) leaves out."""
