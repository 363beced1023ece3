"""Tools built on the model, the RTL and the co-simulation: scene-driven presets (``fit``), the ECP5 flow (``fpga``),
the design-space sweeps, benchmarks, the exhaustive run and the model-side proofs (``prove``), the README's tables
and figures, the ``fxmodel`` command line (``cli``), and the Dask job runner they share for long runs (``jobs``).
The top layer: nothing in ``fxmodel/``, ``rtl/`` or ``cosim/`` imports it, except the ``__main__`` entry points."""
