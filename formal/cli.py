"""``bumpmap formal`` (``make formal``): run the property sets and
the broken variants, write the record.

Exit codes: 0 every set proven (or bounded) with its covers reached and every broken variant caught; 1 a proof
failed or a variant was not caught; 2 bad input or a missing tool.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from .runner import tools_missing

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser):
    parser.add_argument("--only", nargs="+", metavar="NAME", help="only these property sets or broken variants")
    parser.add_argument("--fast", action="store_true", help="the fast subset (the one make test runs)")
    parser.add_argument("--no-covers", action="store_true", help="skip the cover runs")
    parser.add_argument("--no-broken", action="store_true", help="skip the broken variants")
    parser.add_argument("--out", type=Path, default=Path("build/formal"), help="job folders (default build/formal)")
    parser.add_argument("--record", type=Path, help="write the record (JSON) here, e.g. docs/formal/proofs.json")
    parser.add_argument("--timeout", type=int, default=900, help="seconds per solver run (default 900)")
    parser.add_argument("--list", action="store_true", help="list the property sets and variants, run nothing")


def _write_json(path: Path, obj):
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(obj, indent=1) + "\n")
    os.replace(tmp, path)


def _command(args) -> str:
    """The command line that reruns this run (from the parsed arguments)."""
    words = ["bumpmap formal"]
    if args.only:
        words.append("--only " + " ".join(args.only))
    words += [flag for flag, on in (("--fast", args.fast), ("--no-covers", args.no_covers),
                                    ("--no-broken", args.no_broken)) if on]
    if args.record:
        words.append(f"--record {args.record}")
    return " ".join(words)


def run(args) -> int:
    from .sets import FAST_SETS, FAST_VARIANTS, SCOPE, machine, property_sets, run_set, run_variant, variants
    sets, vars_ = property_sets(), variants()
    if args.list:
        for s in sets:
            print(f"{s.name:24s} {s.mode} {s.depth:3d}  {s.design}")
        for v in vars_:
            print(f"{v.name:24s} broken    {v.bug}")
        return 0
    names = {s.name for s in sets} | {v.name for v in vars_}
    if args.only:
        bad = [n for n in args.only if n not in names]
        if bad:
            print(f"error: --only {' '.join(bad)}: no such property set or variant (see --list)", file=sys.stderr)
            return 2
        sets = [s for s in sets if s.name in args.only]
        vars_ = [v for v in vars_ if v.name in args.only]
    elif args.fast:
        sets = [s for s in sets if s.name in FAST_SETS]
        vars_ = [v for v in vars_ if v.name in FAST_VARIANTS]
    if args.no_broken:
        vars_ = []
    missing = tools_missing()
    if missing:
        print(f"error: {missing}", file=sys.stderr)
        return 2
    record = {"command": _command(args), "machine": machine(), "scope": list(SCOPE), "sets": [], "broken": []}
    start = time.monotonic()
    ok = True
    for s in sets:
        entry = run_set(s, args.out, covers=not args.no_covers, timeout=args.timeout)
        ok &= entry["status"] == "PASS"
        record["sets"].append(entry)
        print(f"{s.name:24s} {entry['status']:5s} {entry['verdict']:32s} {entry['seconds']:8.1f} s", flush=True)
    for v in vars_:
        entry = run_variant(v, args.out, timeout=args.timeout)
        ok &= entry["caught"]
        record["broken"].append(entry)
        print(f"{v.name:24s} {'caught' if entry['caught'] else 'MISSED'} {', '.join(entry['failed'])} "
              f"{entry['seconds']:8.1f} s  {entry['trace'] or ''}", flush=True)
    record["seconds"] = round(time.monotonic() - start, 1)
    if args.record:
        _write_json(args.record, record)
    return 0 if ok else 1


