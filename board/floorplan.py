"""Floorplans: the sites of the engine's multiplier and block RAM cells, taken from a routed build and given to
nextpnr for another build of the same engine.

Why: the engine meets its 100 MHz target with the frame on chip at the board's seed, but beside LiteDRAM's core
and the frame's copy (the frame in SDRAM) no placer seed tried routed it there: the late endpoints moved to
another unit with every seed and every change (``docs/board.md``, "Left"). Where the multiplier blocks and the
block RAMs of the engine sit decides most of its long routes, and those two kinds of cell have stable names (the
RTL's, through Yosys and nextpnr's packer unchanged), while the LUTs' names do not survive synthesis. So a
floorplan is the site of each such cell of a build that met its clock; another build of the same engine takes
them as nextpnr's generic placement constraint (a ``BEL`` attribute on the cell in the JSON netlist: nextpnr
binds the cell there before placing the rest; its regions would need its Python scripting, which YoWASP's build
does not have). Everything else is placed freely around them.

What: :func:`placed_sites` reads a placed and routed netlist (nextpnr's ``--write``) for the cells of
:data:`CELL_TYPES` under :data:`ENGINE_PREFIX`; :func:`write_floorplan` keeps them as a record (JSON, written
atomically, with the build it came from); :func:`read_floorplan` checks one (every key, every site's form, by
name in the error); :func:`constrain` gives a synthesized netlist its sites and refuses a floorplan whose cells
are not the netlist's (another engine, another preset: a floorplan only helps the netlist it was placed for).
``bumpmap bitstream --floorplan PATH`` (``board/top.py``) runs it between Yosys and nextpnr.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

__all__ = ["CELL_TYPES", "ENGINE_PREFIX", "placed_sites", "constrain", "write_floorplan", "read_floorplan",
           "FloorplanError", "constrain_file"]

#: The kinds of cell a floorplan places: the multiplier blocks and the block RAMs.
CELL_TYPES = ("MULT18X18D", "DP16KD")

#: The engine's cells in the board top's netlist (``board.frame.EngineSystem`` is ``system``, its engine ``engine``).
ENGINE_PREFIX = "system.engine."

#: A site as nextpnr-ecp5 names a bel: ``X<column>/Y<row>/<bel>``.
_SITE = re.compile(r"X\d+/Y\d+/[A-Z0-9_]+")


class FloorplanError(ValueError):
    """A floorplan that cannot be used: the message names the file, the key or cell, and what is wrong."""


def _cells(netlist: dict):
    for module in netlist.get("modules", {}).values():
        yield from module.get("cells", {}).items()


def placed_sites(placed: dict, types=CELL_TYPES, prefix: str = ENGINE_PREFIX) -> dict[str, str]:
    """The site (nextpnr's ``NEXTPNR_BEL``) of every cell of ``types`` whose name begins with ``prefix`` in a
    placed netlist, by cell name."""
    return {name: cell["attributes"]["NEXTPNR_BEL"] for name, cell in _cells(placed)
            if cell.get("type") in types and name.startswith(prefix) and "NEXTPNR_BEL" in cell.get("attributes", {})}


def constrain(netlist: dict, sites: dict[str, str], types=CELL_TYPES, prefix: str = ENGINE_PREFIX) -> int:
    """Give each cell of ``netlist`` named in ``sites`` its site (a ``BEL`` attribute, in place); returns how many.
    Raises :class:`FloorplanError` when the netlist's cells of ``types`` under ``prefix`` are not exactly those of
    ``sites`` (the first few differences named)."""
    ours = {name: cell for name, cell in _cells(netlist) if cell.get("type") in types and name.startswith(prefix)}
    missing, extra = sorted(set(sites) - set(ours)), sorted(set(ours) - set(sites))
    if missing or extra:
        raise FloorplanError(
            f"the floorplan is not this netlist's: {len(missing)} of its cells are not in it "
            f"{missing[:3]}, {len(extra)} cells of the netlist are not in it {extra[:3]} (a floorplan fits only "
            f"the engine and preset it was placed for: write one from a routed build of this netlist)")
    for name, cell in ours.items():
        cell.setdefault("attributes", {})["BEL"] = sites[name]
    return len(ours)


def write_floorplan(path: Path, sites: dict[str, str], source: dict) -> None:
    """Keep ``sites`` as a floorplan record at ``path`` (atomically), with ``source``: what it was placed by."""
    from host.atomic import atomic_json
    atomic_json(Path(path), {"source": source, "types": list(CELL_TYPES), "prefix": ENGINE_PREFIX,
                            "cells": dict(sorted(sites.items()))})


def read_floorplan(path: Path) -> dict[str, str]:
    """The sites of the floorplan record at ``path``; :class:`FloorplanError` naming the file and the key or cell
    when it is not one (not JSON, ``types`` or ``prefix`` not :data:`CELL_TYPES` and :data:`ENGINE_PREFIX`, no
    ``cells``, a cell not of the engine, a site not of nextpnr's form, one site for two cells)."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise FloorplanError(f"{path}: not a floorplan record ({e})") from None
    if not isinstance(rec, dict):
        raise FloorplanError(f"{path}: not a floorplan record (a JSON object with 'types', 'prefix' and 'cells')")
    for key, ours in (("types", list(CELL_TYPES)), ("prefix", ENGINE_PREFIX)):
        if rec.get(key) != ours:          # a record of other kinds of cell, or of another unit, is not this build's
            raise FloorplanError(f"{path}: key {key!r} is {rec.get(key)!r}, this build places {ours!r}")
    cells = rec.get("cells")
    if not isinstance(cells, dict) or not cells:
        raise FloorplanError(f"{path}: key 'cells' must be an object of cell name -> site, and not empty")
    seen = {}
    for name, site in cells.items():
        if not name.startswith(ENGINE_PREFIX):
            raise FloorplanError(f"{path}: cell {name!r} is not the engine's (its name must begin {ENGINE_PREFIX!r})")
        if not (isinstance(site, str) and _SITE.fullmatch(site)):
            raise FloorplanError(f"{path}: cell {name!r}: site {site!r} is not of the form X<n>/Y<n>/<bel>")
        if site in seen:
            raise FloorplanError(f"{path}: cells {seen[site]!r} and {name!r} have the same site {site!r}")
        seen[site] = name
    return dict(cells)


def constrain_file(netlist: Path, floorplan: Path, out: Path) -> int:
    """:func:`constrain` the JSON netlist file ``netlist`` with the record ``floorplan`` into ``out``."""
    from host.atomic import atomic_json
    data = json.loads(Path(netlist).read_text())
    n = constrain(data, read_floorplan(floorplan))
    atomic_json(Path(out), data, indent=None)
    return n


def main(argv=None) -> int:
    """``python -m board.floorplan NETLIST FLOORPLAN OUT``: the step the board's build runs between Yosys and
    nextpnr (``board.top.build`` with a floorplan)."""
    import argparse
    ap = argparse.ArgumentParser(prog="python -m board.floorplan", description=main.__doc__)
    ap.add_argument("netlist", type=Path, help="Yosys' JSON netlist")
    ap.add_argument("floorplan", type=Path, help="the floorplan record (bumpmap bitstream --save-floorplan)")
    ap.add_argument("out", type=Path, help="the netlist with the sites, for nextpnr")
    args = ap.parse_args(argv)
    try:
        n = constrain_file(args.netlist, args.floorplan, args.out)
    except FloorplanError as e:
        ap.exit(2, f"error: {e}\n")
    print(f"floorplan: {n} cells of {', '.join(CELL_TYPES)} at the sites of {args.floorplan}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
