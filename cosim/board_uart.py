"""Co-simulation harness of the board's UART command link (``board/command.py``'s
:class:`~board.command.CommandLink`): the host protocol's bytes (``host/protocol.py``) into the ``rx`` line through
cocotbext-uart's ``UartSource``, the board's replies from ``tx`` through its ``UartSink``, the parsed commands
recorded by ``cosim.board_uart_tb``; compared with :func:`host.protocol.parse`."""

from __future__ import annotations

import hashlib
import json

from board.command import CommandLink
from fxmodel.core.paths import source_digest

from .harness import component_build, run_testbench, simulator
from .job import job_folder, remove_job

__all__ = ["run", "CLOCK_NS", "DIVISOR"]

#: The simulation's clock period and clocks a bit: 6.25 MBd, a whole number of nanoseconds a bit.
CLOCK_NS, DIVISOR = 10, 16


def run(data: bytes, record_len: int, tile: tuple[int, int] | None = None, board_state: int = 0, *,
        grid: tuple[int, int] = (1, 1), maps: str | None = None, sim: str | None = None) -> dict:
    """Send ``data`` to ``CommandLink(DIVISOR, record_len, tile, grid, maps)`` with ``board_state`` on its
    ``state``; return ``commands`` [(cmd, payload bytes)], ``replies`` (bytes from ``tx``), ``error``, ``code``
    (the error state at the end) and the times."""
    sim = simulator(sim)
    key = hashlib.sha1(f"{DIVISOR} {record_len} {tile} {grid} {maps}".encode()
                       + source_digest(("board", "host"))).hexdigest()[:12]
    top, bdir, src = component_build("command_link", key, sim, lambda: CommandLink(DIVISOR, record_len, tile, grid,
                                                                                         maps))
    job = job_folder(bdir, "uart", {"data": hashlib.sha1(data).hexdigest(), "record_len": record_len,
                                    "board_state": board_state})
    out, build_seconds, seconds = run_testbench(sim, src, top, bdir, job, "cosim.board_uart_tb",
                                                {"data": data.hex(), "clock_ns": CLOCK_NS, "divisor": DIVISOR,
                                                 "board_state": board_state},
                                                "parsed.json")
    res = json.loads(out.read_text())
    remove_job(job)
    res["commands"] = [(c, bytes.fromhex(p)) for c, p in res["commands"]]
    res["replies"] = bytes.fromhex(res["replies"])
    res.update(build_seconds=build_seconds, seconds=seconds, simulator=sim)
    return res
