"""Clock-domain crossing pieces shared by the board's frame stores (``board/frame.py`` on chip,
``board/sdram_system.py`` in SDRAM): a toggle handed to another clock domain, and how long the engine must be quiet
before a frame is copied (``docs/board.md``)."""

from __future__ import annotations

from amaranth import Module, Signal
from amaranth.lib.cdc import FFSynchronizer

__all__ = ["QUIET", "toggle_sync"]

#: Clocks the engine must be quiet before SWAP copies its tile: beyond the pixel pipeline's latency and the scan
#: converter's set-up, at the engine's clock a negligible wait.
QUIET = 1024


def toggle_sync(m: Module, name: str, src, domain: str):
    """A pulse in ``domain`` for each change of ``src`` (a toggle of another domain), after two registers of
    ``domain`` (the synchroniser is submodule ``<name>_ff`` of ``m``)."""
    synced, last = Signal(name=f"{name}_s"), Signal(name=f"{name}_last")
    m.submodules[f"{name}_ff"] = FFSynchronizer(src, synced, o_domain=domain)
    m.d[domain] += last.eq(synced)
    return synced ^ last
