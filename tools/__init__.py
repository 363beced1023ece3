"""Tools built on the model, the RTL and the co-simulation: scene-driven presets (``fit``), the ECP5 flow (``fpga``),
the design-space sweeps, benchmarks, the exhaustive run, the README's tables and figures, and the ``fxmodel``
command line (``cli``). The top layer: nothing in ``fxmodel/``, ``rtl/`` or ``cosim/`` imports it, except the
``__main__`` entry points."""
