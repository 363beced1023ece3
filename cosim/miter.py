"""Two builds of one design side by side in Icarus (``tests/rtl/test_dsp.py``, ``tests/rtl/test_bram.py``): the
same random inputs into both, a reset at the start and one in the middle, every output compared on every clock.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

__all__ = ["needs_icarus", "miter", "run_icarus"]

needs_icarus = pytest.mark.skipif(shutil.which("iverilog") is None, reason="no iverilog (make setup installs it)")

_PORT = re.compile(r"^\s*(input|output)\s+(?:signed\s+)?(?:\[(\d+):0\]\s+)?(\\?\S+)\s*;", re.M)


def _ports(text: str, module: str):
    """``[(direction, width, name)]`` of ``module`` in Amaranth's Verilog."""
    start = text.index(f"module {module}(")
    body = text[start:text.index("endmodule", start)]
    return [(d, int(hi) + 1 if hi else 1, n) for d, hi, n in _PORT.findall(body)]


def _random_bits(width: int) -> str:
    words = -(-width // 32)
    return "{" + ", ".join(["$urandom"] * words) + "}"


def miter(ref: str, alt: str, cycles: int, draw: dict | None = None) -> str:
    """A testbench driving ``ref`` and ``alt`` (same ports) with random inputs, reset at the start and once in
    the middle, printing each output that differs and ``DONE <clocks compared>``. ``draw``: a Verilog expression
    for an input's random value where not every value is in its range (a cube face: ``"$urandom % 6"``)."""
    ports = _ports(ref, "fab")
    ins = [(w, n) for d, w, n in ports if d == "input" and n not in ("clk", "rst")]
    outs = [(w, n) for d, w, n in ports if d == "output"]
    lines = ["module tb;", "  reg clk = 0, rst = 1;", "  integer i, bad = 0, unknown = 0;"]
    lines += [f"  reg [{w - 1}:0] {n};" for w, n in ins]
    lines += [f"  wire [{w - 1}:0] r_{n}, a_{n};" for w, n in outs]
    for tag, mod in (("r", "fab"), ("a", "blk")):
        conns = [".clk(clk)", ".rst(rst)"] + [f".{n}({n})" for _, n in ins] + [f".{n}({tag}_{n})" for _, n in outs]
        lines.append(f"  {mod} u_{tag} ({', '.join(conns)});")
    lines += ["  initial begin", f"    for (i = 0; i < {cycles}; i = i + 1) begin",
              f"      rst = (i < 2) || (i == {cycles // 2});"]
    lines += [f"      {n} = {(draw or {}).get(n, _random_bits(w))};" for w, n in ins]
    lines += ["      #1 clk = 1; #1 clk = 0;"]
    # An unknown bit (x) in either output while the pipeline first fills: a block RAM's output register has no
    # initial value in Verilog, and Icarus evaluates an ``always @*`` block only once an input changes (registers
    # held at reset change nothing); on the device every register starts at 0. Counted apart, and only allowed
    # in the first quarter of the run (so an unknown cannot hide a difference after the second reset).
    lines += [f"      if (^r_{n} === 1'bx || ^a_{n} === 1'bx) begin unknown = unknown + 1; "
              f"if (i >= {cycles // 4}) bad = bad + 1; end else if (r_{n} !== a_{n}) begin bad = bad + 1; "
              f"if (bad < 5) $display(\"DIFF {n} %0d %h %h\", i, r_{n}, a_{n}); end" for _, n in outs]
    done = f"    $display(\"DONE %0d %0d UNKNOWN %0d OF %0d\", i, bad, unknown, i * {len(outs)});"
    lines += ["    end", done, "    $finish;", "  end", "endmodule"]
    return "\n".join(lines)


def run_icarus(tmp_path, sources: dict[str, str]) -> str:
    for name, text in sources.items():
        (tmp_path / name).write_text(text)
    subprocess.run(["iverilog", "-g2012", "-o", str(tmp_path / "sim"), *[str(tmp_path / n) for n in sources]],
                   check=True, capture_output=True, text=True)
    return subprocess.run(["vvp", "-n", str(tmp_path / "sim")], check=True, capture_output=True, text=True).stdout


