"""The SDRAM controller: LiteDRAM's standalone core generated from ``board/sdram.yml`` into the build folder (never
committed), with the SDRAM pins (the board build) or with its behavioural DRAM model inside (``--sim``, for the
end-to-end simulation), and a record of what it gave: its ports and their widths.

``bumpmap litedram OUT.json`` generates both and writes the record (needs ``litedram``, ``litex``,
``migen``, ``pyyaml``, and for ``--sim`` ``liteeth``, ``litescope``, ``pythondata-misc-tapcfg``).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from fxmodel.core.paths import ROOT, build_dir

from .budget import write_text_atomic

__all__ = ["generate", "ports", "add_arguments", "run", "ADDR_BITS", "DATA_BITS", "ID_BITS", "SDRAM_BYTES", "SDRAM_HZ"]

CONFIG = ROOT / "board" / "sdram.yml"

#: The ULX3S's SDRAM chip (IS42S16160 or MT48LC16M16, ``board/sdram.yml``): rows, columns, banks, data bits (x16).
ROWS, COLUMNS, BANKS, DATA_BITS = 8192, 512, 4, 16
SDRAM_BYTES = ROWS * COLUMNS * BANKS * DATA_BITS // 8
#: The AXI4 user port's byte address bits (the whole chip) and its ID bits (``id_width`` in ``board/sdram.yml``);
#: ``tests/board/test_litedram.py`` checks them against the generated core's ports (``docs/board/litedram.json``).
ADDR_BITS = (SDRAM_BYTES - 1).bit_length()
ID_BITS = 4
#: The core's clock (``sys_clk_freq`` in ``board/sdram.yml``): one 16-bit word a clock at the peak.
SDRAM_HZ = 100_000_000
_PORT = re.compile(r"^\s*(input|output|inout)\s+wire\s+(?:\[(\d+):0\]\s+)?(\w+),?$")


def generate(sim: bool, out: Path | None = None) -> Path:
    """Run ``litedram_gen`` (``--no-compile``); return the generated ``litedram_core.v``."""
    tool = shutil.which("litedram_gen")
    if tool is None:
        raise RuntimeError("litedram_gen not found: pip install litedram litex migen pyyaml "
                           "(and liteeth litescope pythondata-misc-tapcfg for --sim)")
    out = out or build_dir("litedram-sim" if sim else "litedram")
    cmd = [tool, str(CONFIG), "--no-compile", "--output-dir", str(out)] + (["--sim"] if sim else [])
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{run.stderr[-2000:]}")
    return out / "gateware" / "litedram_core.v"


def ports(verilog: Path) -> dict[str, tuple[str, int]]:
    """The top module's ports: name -> (direction, width)."""
    out = {}
    for line in verilog.read_text().splitlines()[:200]:
        m = _PORT.match(line)
        if m:
            out[m.group(3)] = (m.group(1), int(m.group(2)) + 1 if m.group(2) else 1)
        elif line.startswith(");"):
            break
    return out


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The command line (``bumpmap litedram``, :mod:`tools.main`)."""
    ap.add_argument("out", type=Path, help="the JSON record to write")


def run(args: argparse.Namespace) -> int:
    record = {"command": f"bumpmap litedram {args.out}", "config": "board/sdram.yml"}
    try:
        for sim in (False, True):
            t0 = time.perf_counter()
            v = generate(sim)
            p = ports(v)
            record["sim" if sim else "board"] = {
                "seconds": round(time.perf_counter() - t0, 1), "verilog_lines": len(v.read_text().splitlines()),
                "axi_port": {k.removeprefix("user_port_axi_0_"): p[k] for k in sorted(p) if "axi_0" in k},
                "other_ports": {k: p[k] for k in sorted(p) if "axi_0" not in k}}
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    write_text_atomic(args.out, json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))
    return 0
