"""The SDRAM controller: LiteDRAM's standalone core generated from ``board/sdram.yml`` into the build folder (never
committed), with the SDRAM pins (the board build) or with its behavioural DRAM model inside (``--sim``, for the
end-to-end simulation), and a record of what it gave: its ports and their widths.

``bumpmap litedram OUT.json`` generates both, each also with the texture port (``textures``: a second AXI4 user
port for the texel caches' misses), and writes the record (needs ``litedram``, ``litex``,
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

__all__ = ["config", "core", "core_dir", "generate", "ports", "add_arguments", "run", "ADDR_BITS", "DATA_BITS",
           "ID_BITS", "SDRAM_BYTES", "SDRAM_HZ", "CLOCK_LINE", "PORTS_LINE", "TEXTURE_PORT", "TEXTURE_DATA_BITS"]

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


#: The line of ``board/sdram.yml`` that sets the core's clock; :func:`config` replaces it for another clock.
CLOCK_LINE = '"sys_clk_freq":  100e6,'
#: The line of ``board/sdram.yml`` that opens its user ports; :func:`config` adds the texture port after it.
PORTS_LINE = '"user_ports": {'
#: The core's second AXI4 user port, for the texel caches' misses (``textures=True``): its name in the
#: configuration and its data bits, the caches' bus (:attr:`fxmodel.units.texcache.TexCacheParams.bus_bytes`;
#: LiteDRAM converts its 32-bit words to the chip's 16 in its crossbar). Same address and ID bits as the first.
TEXTURE_PORT = "axi_1"
TEXTURE_DATA_BITS = 32


def config(clk_hz: int, textures: bool = False) -> str:
    """``board/sdram.yml`` for a core clocked at ``clk_hz`` (the board's SDRAM clock: LiteDRAM turns the chip's
    timings, refresh interval included, into clocks of ``sys_clk_freq``, so a core generated for 100 MHz and run
    slower would refresh the chip less often than its datasheet asks), with ``textures`` a second AXI4 user port
    (:data:`TEXTURE_PORT`, :data:`TEXTURE_DATA_BITS`) after :data:`PORTS_LINE`. ``ValueError`` if the file does not
    set the clock on :data:`CLOCK_LINE` or open its ports on :data:`PORTS_LINE`, or ``clk_hz`` is above the chip's
    and the core's :data:`SDRAM_HZ`."""
    text = CONFIG.read_text()
    for line, what in ((CLOCK_LINE, "set the clock"), (PORTS_LINE, "open its user ports")):
        if text.count(line) != 1:
            raise ValueError(f"{CONFIG.name} does not {what} once as '{line}': update board/litedram.py")
    if not (isinstance(clk_hz, int) and 0 < clk_hz <= SDRAM_HZ):
        raise ValueError(f"clk_hz={clk_hz!r}: the SDRAM core's clock must be an int in 1..{SDRAM_HZ} Hz")
    text = text.replace(CLOCK_LINE, f'"sys_clk_freq":  {clk_hz},')
    if textures:
        port = (f'\n        "{TEXTURE_PORT}": {{"type": "axi", "id_width": {ID_BITS}, '
                f'"data_width": {TEXTURE_DATA_BITS}}},   # the texel caches\' misses')
        text = text.replace(PORTS_LINE, PORTS_LINE + port)
    return text


def core_dir(sim: bool, clk_hz: int = SDRAM_HZ, textures: bool = False) -> Path:
    """Where :func:`generate` puts a core by default: ``build/litedram`` (``build/litedram-sim`` with ``sim``),
    with ``-tex`` added for the core with the texture port and ``_<clk_hz>`` for another clock than
    :data:`SDRAM_HZ`."""
    name = ("litedram-sim" if sim else "litedram") + ("-tex" if textures else "")
    return build_dir(name if clk_hz == SDRAM_HZ else f"{name}_{clk_hz}")


def core(sim: bool, clk_hz: int = SDRAM_HZ, textures: bool = False) -> Path:
    """The core's ``litedram_core.v`` in :func:`core_dir`, generated there (:func:`generate`) unless it is there
    already from the same configuration (the ``sdram.yml`` kept beside it equal to :func:`config`'s)."""
    out = core_dir(sim, clk_hz, textures)
    verilog, kept = out / "gateware" / "litedram_core.v", out / "sdram.yml"
    if verilog.exists() and kept.exists() and kept.read_text() == config(clk_hz, textures):
        return verilog
    return generate(sim, out, clk_hz, textures)


def generate(sim: bool, out: Path | None = None, clk_hz: int = SDRAM_HZ, textures: bool = False) -> Path:
    """Run ``litedram_gen`` (``--no-compile``) on :func:`config` of ``clk_hz`` and ``textures``; return the
    generated ``litedram_core.v`` (in ``out``, by default :func:`core_dir`)."""
    tool = shutil.which("litedram_gen")
    if tool is None:
        raise RuntimeError("litedram_gen not found: pip install litedram litex migen pyyaml "
                           "(and liteeth litescope pythondata-misc-tapcfg for --sim)")
    out = out or core_dir(sim, clk_hz, textures)
    out.mkdir(parents=True, exist_ok=True)
    cfg = out / "sdram.yml"
    write_text_atomic(cfg, config(clk_hz, textures))
    cmd = [tool, str(cfg), "--no-compile", "--output-dir", str(out)] + (["--sim"] if sim else [])
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
        for textures in (False, True):
            for sim in (False, True):
                t0 = time.perf_counter()
                v = generate(sim, textures=textures)
                p = ports(v)
                names = ("axi_0", TEXTURE_PORT) if textures else ("axi_0",)
                axi = {k.removeprefix("user_port_axi_0_"): p[k] for k in sorted(p) if "axi_0" in k}
                entry = {"seconds": round(time.perf_counter() - t0, 1),
                         "verilog_lines": len(v.read_text().splitlines()), "axi_port": axi}
                if textures:
                    entry["texture_port"] = {k.removeprefix(f"user_port_{TEXTURE_PORT}_"): p[k] for k in sorted(p)
                                             if TEXTURE_PORT in k}
                entry["other_ports"] = {k: p[k] for k in sorted(p) if not any(n in k for n in names)}
                record[("sim" if sim else "board") + ("_textures" if textures else "")] = entry
    except RuntimeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    write_text_atomic(args.out, json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))
    return 0
