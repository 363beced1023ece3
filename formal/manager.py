"""The description of one AXI4 read manager with stream ports, as the generic harness of :mod:`formal.readers`
checks it (its entries: :data:`formal.readers.READ_MANAGERS`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = ["ReadManager", "STALL"]

#: The memory's bounded stall (cycles) assumed of every read manager's memory.
STALL = 3


@dataclass(frozen=True)
class ReadManager:
    """One AXI4 read manager with stream ports ``i`` (requests) and ``o`` (answers).

    Parameters
    ----------
    name, design : str
        The property set's name and what it runs (for the record).
    make : callable
        ``make()`` -> the component (a fresh one each call).
    arlen, arsize, arburst : int
        The one burst the design issues (asserted on every ``AR``).
    port : str
        The name of its AXI4 port.
    max_out : int
        Read bursts outstanding at most.
    capacity : int
        Requests accepted and not yet answered at most.
    invariants : callable, optional
        ``invariants(h, sig, rd, inside, inner=, top=)``: the design's white-box invariants (``sig(name, path)``
        finds a signal the design (or its submodule at ``path``) assigns, ``rd`` the
        :class:`~formal.axiread.AxiReadCheck`, ``inside`` the requests inside, ``inner`` the design unwrapped,
        ``top`` its elaborated fragment); they may add their own checks and covers too.
    mode, depth, cover_depth : the run (``prove`` at ``k = depth``, or ``bmc`` to ``depth`` with ``why``).
    """

    name: str
    design: str
    make: Callable
    arlen: int
    arsize: int = 2
    arburst: int = 1
    port: str = "mem"
    max_out: int = 1
    capacity: int = 1
    invariants: Callable | None = None
    mode: str = "prove"
    depth: int = 1
    cover_depth: int = 30
    why: str = ""
    extra: dict = field(default_factory=dict)
