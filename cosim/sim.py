"""``make sim``: co-simulate a unit's RTL against the golden model and print a summary (bit-exact or fail).

Runs the unit's hard cases plus ``--vectors`` random inputs (or the whole input space with ``--exhaustive``)
through the RTL on ``--sim`` (default ``$SIM`` or icarus), compares every output bit with the model, writes
``build/sim/<unit>_<preset>/report.json`` and exits non-zero on any mismatch. ``WAVES=1`` dumps a waveform.
(The whole-scene pixel pipeline will take this command over once it exists.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from fxmodel.unit import preset

from .harness import ROOT, run, simulator


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m cosim.sim", description=__doc__.split("\n")[0])
    ap.add_argument("--unit", default="recip")
    ap.add_argument("--preset", default="default")
    ap.add_argument("--sim", default=None, help="icarus or verilator (default: $SIM or icarus)")
    ap.add_argument("--vectors", type=int, default=100_000, help="random vectors besides the hard cases")
    ap.add_argument("--exhaustive", action="store_true", help="the whole input space instead")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    try:
        params = preset(args.unit, args.preset)
        sim = simulator(args.sim)
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.exhaustive:
        vectors = params.all_inputs()
    else:
        rng = np.random.default_rng(args.seed)
        vectors = np.concatenate([params.hard_cases(), params.random_inputs(rng, args.vectors)])
    os.environ.setdefault("COSIM_PROGRESS", "1")
    result = run(params, vectors, sim=sim, tag="sim")
    out = ROOT / "build" / "sim" / f"{args.unit}_{args.preset}"
    out.mkdir(parents=True, exist_ok=True)
    report = {"unit": args.unit, "preset": args.preset, **result}
    (out / "report.json").write_text(json.dumps(report, indent=2))
    rows = [("unit", f"{args.unit} ({args.preset})"), ("simulator", sim), ("vectors", f"{result['vectors']:,}"),
            ("mismatches", str(result["mismatches"])), ("RTL seconds", f"{result['seconds']:.1f}"),
            ("vectors/s", f"{result['vectors_per_second']:,.0f}"), ("report", str(out / "report.json"))]
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"  {k:<{width}}  {v}" for k, v in rows))
    if result["mismatches"]:
        print(result.describe(), file=sys.stderr)
        return 1
    print("  RTL == model, bit for bit")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
