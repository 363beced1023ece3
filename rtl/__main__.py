"""``python -m rtl verilog [--unit U ...] [--preset P ...] [--out DIR]``: write ``DIR/<unit>_<preset>.v``.

Without ``--unit`` every registered unit is written; without ``--preset`` every preset of each unit.
"""

from __future__ import annotations

import argparse
import sys

from fxmodel.unit import preset, preset_names, units

from .unit import write_verilog


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rtl", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    v = sub.add_parser("verilog", help="generate Verilog for units and presets")
    v.add_argument("--unit", action="append", help="unit name (repeatable; default: all)")
    v.add_argument("--preset", action="append", help="preset name (repeatable; default: all of each unit)")
    v.add_argument("--out", default="build/verilog", help="output folder (default: %(default)s)")
    args = ap.parse_args(argv)
    try:
        for unit in args.unit or units():
            for name in args.preset or preset_names(unit):
                path = write_verilog(preset(unit, name), f"{args.out}/{unit}_{name}.v")
                print(f"wrote {path}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
