"""White-box access to an elaborated Amaranth design, for properties that need a design's internal state.

A property that links the outside counts of a stream to the state inside (``used``, a FIFO's ``level``, the
valid delay line of a unit) is what lets k-induction close: without it an unreachable state whose inside and
outside disagree would be a false counterexample forever. The designs in ``rtl/`` keep these as local signals of
``elaborate``; this module elaborates a component once (with ``platform="formal"``, so that Amaranth's own
``SyncFIFO`` adds its pointer and level assertions) and finds a signal by the name its statements assign to. The
properties then read those signals: the design itself is not changed.

Reads Amaranth's private statement API (``_lhs_signals``); pinned by ``amaranth==0.5.10`` in ``pyproject.toml``.
"""

from __future__ import annotations

from amaranth.hdl import Fragment, Signal

__all__ = ["elaborate", "attach", "subfragment", "signal", "origin", "has_signal"]


def elaborate(dut) -> Fragment:
    """The design's fragment, elaborated for the formal platform (add it to a harness as a submodule)."""
    return Fragment.get(dut, "formal")


def attach(h, inner, wrap=None) -> tuple:
    """``inner`` (wrapped by ``wrap``, a broken variant's wrapper, when given) elaborated into the harness ``h`` as
    its submodule ``dut``: ``(dut, frag, top)``, ``top`` the fragment of ``inner`` itself."""
    dut = wrap(inner) if wrap else inner
    frag = elaborate(dut)
    h.m.submodules.dut = frag
    return dut, frag, subfragment(frag, "dut" if wrap else "")


def subfragment(frag: Fragment, path: str) -> Fragment:
    """The fragment at ``path`` (submodule names joined by ``/``, e.g. ``"core/unit"``)."""
    for part in [p for p in path.split("/") if p]:
        found = [sub for sub, name, _ in frag.subfragments if name == part]
        if not found:
            names = [name for _, name, _ in frag.subfragments]
            raise LookupError(f"no submodule {part!r} (has {names})")
        frag = found[0]
    return frag


def _driven(frag: Fragment) -> dict[str, list[Signal]]:
    by_name: dict[str, list[Signal]] = {}
    for stmts in frag.statements.values():
        for stmt in stmts:
            for sig in stmt._lhs_signals():
                lst = by_name.setdefault(sig.name, [])
                if not any(s is sig for s in lst):
                    lst.append(sig)
    return by_name


def has_signal(frag: Fragment, name: str, path: str = "") -> bool:
    """Whether a statement of the fragment at ``path`` assigns a signal named ``name``."""
    return name in _driven(subfragment(frag, path))


def signal(frag: Fragment, name: str, path: str = "") -> Signal:
    """The one signal named ``name`` that a statement of the fragment at ``path`` assigns."""
    found = _driven(subfragment(frag, path)).get(name, [])
    if len(found) != 1:
        raise LookupError(f"{len(found)} signals named {name!r} assigned in {path or 'the top'}")
    return found[0]


def origin(frag: Fragment, path: str, cls: type):
    """The elaboratable of class ``cls`` that produced the fragment at ``path`` (e.g. a ``SyncFIFO``)."""
    for obj in subfragment(frag, path).origins or ():
        if isinstance(obj, cls):
            return obj
    raise LookupError(f"the fragment at {path!r} was not made by a {cls.__name__}")
