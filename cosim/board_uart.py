"""Co-simulation harness of the board's UART command link (``board/command.py``'s
:class:`~board.command.CommandLink`): the host protocol's bytes (``host/protocol.py``) into the ``rx`` line through
cocotbext-uart's ``UartSource``, the board's replies from ``tx`` through its ``UartSink``, the parsed commands
recorded by ``cosim.board_uart_tb``; compared with :func:`host.protocol.parse`."""

from __future__ import annotations

import hashlib
import json

from board.command import CommandLink
from fxmodel.core.paths import source_digest

from .harness import build_and_test, component_build, simulator

__all__ = ["run", "CLOCK_NS", "DIVISOR"]

#: The simulation's clock period and clocks a bit: 6.25 MBd, a whole number of nanoseconds a bit.
CLOCK_NS, DIVISOR = 10, 16


def run(data: bytes, record_len: int, *, sim: str | None = None) -> dict:
    """Send ``data``; return ``commands`` [(cmd, payload bytes)], ``replies`` (bytes from ``tx``), ``error``,
    ``code`` (the error state at the end) and the times."""
    sim = simulator(sim)
    key = hashlib.sha1(f"{DIVISOR} {record_len}".encode() + source_digest(("board", "host"))).hexdigest()[:12]
    top, bdir, src = component_build("command_link", key, sim, lambda: CommandLink(DIVISOR, record_len))
    job = bdir / f"job_{hashlib.sha1(data).hexdigest()[:8]}"
    job.mkdir(exist_ok=True)
    out = job / "parsed.json"
    if out.exists():
        out.unlink()
    (job / "job.json").write_text(json.dumps({"data": data.hex(), "clock_ns": CLOCK_NS, "divisor": DIVISOR,
                                              "out": str(out)}))
    build_seconds, seconds = build_and_test(sim, src, top, bdir, job, "cosim.board_uart_tb")
    res = json.loads(out.read_text())
    res["commands"] = [(c, bytes.fromhex(p)) for c, p in res["commands"]]
    res["replies"] = bytes.fromhex(res["replies"])
    res.update(build_seconds=build_seconds, seconds=seconds, simulator=sim)
    return res
