"""Reading nextpnr's timing reports: each clock's Fmax from its log (:func:`clock_fmax`, ``bumpmap bitstream``'s
report and ``bumpmap fpga --no-route``'s estimate), the RTL register behind a packed cell (:func:`register_name`,
also ``bumpmap fpga``'s critical paths) and every endpoint of a clock that misses its period
(:func:`timing_misses`, ``bumpmap bitstream --misses``). Pure functions, tested on canned reports
(``tests/board/test_top.py``).
"""

from __future__ import annotations

import re

__all__ = ["clock_fmax", "register_name", "timing_misses"]


def clock_fmax(log: str) -> dict:
    """``{clock: {"fmax_mhz", "target_mhz", "met"}}`` from nextpnr's log: each clock's last ``Max frequency for
    clock`` summary (after routing, or after placement when nextpnr did not route)."""
    out = {}
    for name, mhz, target in re.findall(r"Max frequency for clock\s+'([^']+)': ([\d.]+) MHz \((?:PASS|FAIL) at "
                                        r"([\d.]+) MHz\)", log):
        out[name] = {"fmax_mhz": float(mhz), "target_mhz": float(target), "met": float(mhz) >= float(target)}
    return out

_CELL_SUFFIX = re.compile(r"(_TRELLIS_|_MULT18X18D|_DP16KD|_LUT4|_CCU2C|_PFUMX|_L6MUX21|\$).*$")


_PRIMITIVE = re.compile(r"(MULT18X18D|ALU54B|DP16KD|TRELLIS_RAMW|TRELLIS_IO)")


def register_name(cell: str) -> str:
    """The RTL signal behind a packed cell name (``s2_xn_TRELLIS_FF_Q_19`` -> ``s2_xn``); a cell with no RTL
    name (``$330_MULT18X18D_P9``) is named by its primitive (``MULT18X18D``)."""
    cell = cell.lstrip("\\")
    name = _CELL_SUFFIX.sub("", cell)
    if name:
        return name
    prim = _PRIMITIVE.search(cell)
    return prim.group(1) if prim else cell


#: The kind of a timing endpoint by its input pin (:func:`timing_misses`): ECP5 cells' pin names, in order.
_ENDPOINT_KINDS = (("multiplier block", r"^([ABC]\d+|SIGNED[AB]|CE\d|RST\d)$"),
                   ("block RAM", r"^(AD[AB]\d+|DI[AB]\d+|WE[AB]|CE[AB]|OCE[AB]|CS[AB]\d|RST[AB])$"),
                   ("LUT RAM", r"^(WRE|WD\d*|WAD\d*)$"), ("clock enable", r"^CE$"), ("set/reset", r"^LSR$"),
                   ("register", r""))


def _endpoint_kind(port: str) -> str:
    return next(kind for kind, pin in _ENDPOINT_KINDS if re.search(pin, port))


def _endpoint_unit(cell: str, prefixes: tuple) -> str:
    """The design unit an endpoint belongs to: its cell's hierarchy with ``prefixes`` (wrappers, in order)
    removed, without the cell itself (``system.engine.pipeline.core.unit.diffuse.s5_b1_...`` -> ``diffuse``). A
    cell with no hierarchy left whose name is a stage register of a pipe with a prefix (``rtl.unit.Pipe``:
    ``texture_s2_pb2_mult``, a sampler's blend built inside the back of ``rtl/pixel_fetch.py``) belongs to the
    prefix's unit (``texture``)."""
    path = cell.lstrip("\\")
    for prefix in prefixes:
        path = path[len(prefix):] if path.startswith(prefix) else path
    parts = path.split(".")
    name, parts = parts[-1], parts[:-1]
    # LUT RAM bits and block-RAM slices carry numeric path parts (``rows.storage.0.105``): the memory's name
    while parts and parts[-1].isdigit():
        parts.pop()
    # a submodule Amaranth or Yosys renamed apart from a twin carries a ``$n`` suffix (``lod$1067``): its name
    unit = ".".join(re.sub(r"\$\d+$", "", p) for p in parts if p != "storage")
    if not unit and (pipe := _PIPE_STAGE.match(name)):
        return pipe[1]
    return unit or "(top)"


#: A stage register of a pipe with a prefix (``rtl.unit.Pipe``: ``{prefix}s{stage}_{name}``), the prefix's unit.
_PIPE_STAGE = re.compile(r"([A-Za-z][A-Za-z0-9]*?(?:_[A-Za-z][A-Za-z0-9]*?)*?)_s\d+_")


def timing_misses(report: dict, clock: str, period_ns: float, prefixes: tuple = (), worst: int = 25) -> dict:
    """Every endpoint of ``clock`` whose arrival misses ``period_ns``, from nextpnr's ``--report`` JSON written
    with ``--detailed-timing-report`` (each net's endpoints with their arrival, ``[min, max]`` ns, after the
    clock edge; the setup time is not in it, so the count is a floor).

    Returns ``{"clock", "period_ns", "endpoints", "by_unit", "by_kind", "worst"}``: the number of endpoints
    arriving later than the period, how many per unit (:func:`_endpoint_unit`, ``prefixes`` removed) and per
    kind (a multiplier block's operand, a block RAM's pin, a LUT RAM's write, a clock enable, a set/reset, a
    register's data), and the ``worst`` endpoints, one per register (``{"ns", "unit", "register", "pin"}``).

    Raises
    ------
    ValueError
        The report has no per-net timing (nextpnr ran without ``--detailed-timing-report``) or none for ``clock``.
    """
    nets = report.get("detailed_net_timings")
    if not nets:
        raise ValueError("the report has no detailed_net_timings: run nextpnr with --detailed-timing-report")
    misses, seen = [], False
    for net in nets:
        if clock not in net.get("event", ""):
            continue
        for e in net.get("endpoints", []):
            if clock not in e.get("event", ""):
                continue
            seen = True
            delay = e["delay"]
            arrival = max(delay) if isinstance(delay, list) else float(delay)
            if arrival > period_ns:
                misses.append((arrival, _endpoint_unit(e["cell"], prefixes), e["cell"], e["port"]))
    if not seen:
        raise ValueError(f"no endpoint of clock {clock!r} in the report")
    by_unit: dict = {}
    by_kind: dict = {}
    for _, unit, _, port in misses:
        kind = _endpoint_kind(port)
        by_unit[unit] = by_unit.get(unit, 0) + 1
        by_kind[kind] = by_kind.get(kind, 0) + 1
    rows, names = [], set()
    for arrival, unit, cell, port in sorted(misses, reverse=True):
        name = (unit, register_name(cell.split(".")[-1]), re.sub(r"\d+$", "", port))
        if name not in names and len(rows) < worst:
            names.add(name)
            rows.append({"ns": round(arrival, 2), "unit": name[0], "register": name[1], "pin": name[2]})
    order = lambda d: dict(sorted(d.items(), key=lambda kv: (-kv[1], kv[0])))  # noqa: E731
    return {"clock": clock, "period_ns": period_ns, "endpoints": len(misses), "by_unit": order(by_unit),
            "by_kind": order(by_kind), "worst": rows}
