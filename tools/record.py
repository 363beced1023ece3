"""Records of measurements: the JSON a command writes so that the documents can quote its figures.

Every measured table of the documentation is generated (``bumpmap docs``) from a record under
``docs/records/``: the figures, the command that measured them and the machine it ran on (processors, load
average, date, commit). :func:`write` writes one atomically (a temporary file beside it, then ``os.replace``);
the measuring tools call it for their ``--record PATH`` option.

``bumpmap record NAME [--as SHOWN] [--stderr] -- COMMAND ...`` runs a command and records what it printed on
standard output (``docs/records/NAME.json``: ``stdout`` as lines, ``returncode``, ``seconds``): the sample output
of the README's quick start is generated from such records, so it is never typed by hand.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

from fxmodel.core.paths import ROOT
from host.atomic import atomic_json

__all__ = ["RECORDS", "command_line", "machine", "write", "read", "transcript", "add_record_option",
           "write_if_asked", "add_arguments", "run"]

#: Where the records of the documentation's figures live.
RECORDS = ROOT / "docs" / "records"


def _commit() -> str | None:
    """The checkout's commit (short), with ``+dirty`` when tracked files differ from it; ``None`` outside git."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+dirty" if dirty else "")


def command_line(prog: str, argv=None) -> str:
    """The command as typed: ``prog`` and the arguments (``sys.argv[1:]`` when ``argv`` is ``None``), an absolute
    path inside the working folder written relative to it (a record names no one machine's folders)."""
    here = Path.cwd().resolve()

    def rel(arg: str) -> str:
        path = Path(arg).resolve() if os.path.isabs(arg) else None
        return str(path.relative_to(here)) if path is not None and path.is_relative_to(here) else arg

    return " ".join([prog, *(shlex.quote(rel(a)) for a in (sys.argv[1:] if argv is None else argv))])


def machine() -> dict:
    """The machine a measurement ran on: processors, the 1/5/15-minute load averages, UTC date, commit."""
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        load = None
    return {"nproc": os.cpu_count(), "load_average": load,
            "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "commit": _commit(), "python": sys.version.split()[0]}


def write(path, command: str, data, machine_before: dict | None = None) -> Path:
    """Write the record ``{"command", "machine", "result"}`` to ``path`` atomically and return the path.

    Parameters
    ----------
    path : str or Path
        The record's file (its folder is created).
    command : str
        The command line that measured ``data``, as a reader would re-run it.
    data : object
        The figures (anything ``json`` writes).
    machine_before : dict, optional
        :func:`machine` taken when the measurement started; the record keeps it as ``machine_at_start`` beside the
        machine at the end (the load average of a long run changes).
    """
    record = {"command": command, "machine": machine(), "result": data}
    if machine_before is not None:
        record["machine_at_start"] = machine_before
    return atomic_json(path, record, indent=1)


def read(path) -> dict:
    """A record (``ValueError`` naming the file when it is not one): :func:`write`'s form, or a flat one whose
    figures sit beside ``command`` and ``machine`` (then gathered into ``result``; a top-level ``date`` moves into
    ``machine``)."""
    path = Path(path)
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a readable record ({exc})") from exc
    if not isinstance(record, dict) or not {"command", "machine"} <= set(record) \
            or not isinstance(record["machine"], dict):
        raise ValueError(f"{path}: not a record (expected the keys command and machine)")
    if "result" not in record:
        machine = dict(record["machine"])
        machine.setdefault("date", record.get("date"))
        record = {"command": record["command"], "machine": machine,
                  "result": {k: v for k, v in record.items() if k not in ("command", "machine", "date")}}
    return record


def transcript(path, argv: list[str], shown_as: str | None = None, stderr: bool = False) -> int:
    """Run ``argv``, pass its standard output through and record it in ``path``; the command's exit status.

    The record's ``command`` is ``shown_as`` when given (``make sim`` for the command line ``make sim`` runs), and
    ``result`` holds ``stdout`` (a list of lines; paths under the checkout made relative to it), ``returncode``
    and ``seconds`` of wall time. ``stderr``: record standard error too, in order with standard output (an error
    message the documents show).
    """
    before = machine()
    t0 = time.perf_counter()
    lines = []
    with subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT if stderr else None, text=True,
                          cwd=ROOT) as proc:
        for line in proc.stdout:
            sys.stdout.write(line)
            lines.append(line.rstrip("\n").replace(f"{ROOT}/", ""))
    seconds = round(time.perf_counter() - t0, 1)
    write(path, shown_as or " ".join(argv),
          {"argv": argv, "stdout": lines, "returncode": proc.returncode, "seconds": seconds}, before)
    return proc.returncode


def add_record_option(ap: argparse.ArgumentParser, what: str) -> None:
    """``--record PATH`` for a measuring command: also write ``what``, the command and the machine there."""
    ap.add_argument("--record", metavar="PATH", help=f"also write {what}, the command and the machine to this JSON "
                    "record (docs/records/)")


def write_if_asked(args: argparse.Namespace, data, machine_before: dict | None = None) -> None:
    """Write ``data`` to the record ``args.record`` if the command was given ``--record`` (the command line as
    :mod:`tools.main` parsed it)."""
    if getattr(args, "record", None):
        print(f"wrote {write(args.record, getattr(args, 'command_line', 'bumpmap'), data, machine_before)}")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """``bumpmap record NAME [--as SHOWN] [--stderr] -- COMMAND ...`` (the command after ``--``)."""
    ap.add_argument("name", help="record name: writes docs/records/NAME.json (or --out)")
    ap.add_argument("--as", dest="shown_as", metavar="SHOWN", help="the command as the documents show it")
    ap.add_argument("--out", help="record file (default: docs/records/NAME.json)")
    ap.add_argument("--stderr", action="store_true", help="record standard error too (an error message)")



def run(args: argparse.Namespace) -> int:
    """Run a command and record what it printed on standard output (the documents' sample output)."""
    command = getattr(args, "trailing", [])          # everything after --, set by tools.main
    if not command:
        print("error: no command to run (give it after --)", file=sys.stderr)
        return 2
    path = Path(args.out) if args.out else RECORDS / f"{args.name}.json"
    try:
        return transcript(path, command, args.shown_as, args.stderr)
    except OSError as exc:
        print(f"error: {command[0]}: {exc}", file=sys.stderr)
        return 2

