"""``python -m rtl verilog [--unit U ...] [--preset P ...] [--scene SCENE] [--out DIR]``: write Verilog.

Without ``--scene``: ``DIR/<unit>_<preset>.v``; without ``--unit`` every registered unit is written, without
``--preset`` every preset of each unit.

With ``--scene`` (a name in ``scenes/`` or a ``.toml`` file): the pixel pipeline with that scene's memories (bump
map, texture, reflectance cubes) and each pipeline ``--preset`` (built in or ``presets/<name>.toml``, e.g. one
``python -m fxmodel fit`` wrote; default ``default``), as ``DIR/pipeline_<preset>_<scene>.v`` (see
:func:`tools.fpga.design_list`).
"""

from __future__ import annotations

import argparse
import sys

from fxmodel.unit import preset, preset_names, units

from .verilog import write_verilog


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rtl", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    v = sub.add_parser("verilog", help="generate Verilog for units and presets")
    v.add_argument("--unit", action="append", help="unit name (repeatable; default: all)")
    v.add_argument("--preset", action="append", help="preset name (repeatable; default: all of each unit; "
                   "with --scene: pipeline presets, default 'default')")
    v.add_argument("--scene", help="the pipeline with this scene's tables (name in scenes/ or a .toml file)")
    v.add_argument("--out", default="build/verilog", help="output folder (default: %(default)s)")
    args = ap.parse_args(argv)
    try:
        if args.scene is not None:
            from tools.fpga import design_list
            for label, params in design_list(args.unit, args.preset, scene=args.scene):
                path = write_verilog(params, f"{args.out}/{'_'.join(label.values())}.v")
                print(f"wrote {path}")
            return 0
        for unit in args.unit or units():
            for name in args.preset or preset_names(unit):
                path = write_verilog(preset(unit, name), f"{args.out}/{unit}_{name}.v")
                print(f"wrote {path}")
    except ValueError as exc:
        from tools.fpga import scene_hint
        print(f"error: {exc}{scene_hint(args.preset) if args.scene is None else ''}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
