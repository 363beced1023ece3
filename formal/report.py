"""The record of ``make formal`` (``docs/formal/proofs.json``) as markdown tables, for the generated docs."""

from __future__ import annotations

__all__ = ["markdown_table"]


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _runs(entry: dict) -> str:
    return ", ".join(f"{r['kind']} {r['mode']} {r['depth']}: {r['status']} {r['seconds']:.1f} s"
                     for r in entry["runs"])


def markdown_table(record: dict) -> str:
    """The property sets (design, properties, proven or bounded and to what depth, status, solver time) and the
    broken variants (the property that must fail, whether it did), with the command and the machine.

    Parameters
    ----------
    record : dict
        As written by ``bumpmap formal --record PATH`` (keys ``sets``, ``broken``, ``command``, ``machine``).
    """
    lines = ["| Property set | Design | Properties | Checks | Verdict | Status | Solver time (s) | Runs |",
             "|---|---|---|---|---|---|---:|---|"]
    for s in record.get("sets", []):
        verdict = s["verdict"] + (f" ({s['why']})" if s.get("why") else "")
        checks = f"{len(s.get('checks', []))} asserted, {len(s.get('covers', []))} covered"
        lines.append(f"| {_cell(s['name'])} | {_cell(s['design'])} | {_cell(s['properties'])} | {checks} "
                     f"| {_cell(verdict)} "
                     f"| {s['status']} | {s['seconds']:.1f} | {_cell(_runs(s))} |")
    if record.get("broken"):
        lines += ["", "| Broken variant | Bug | Must fail | Steps checked | Failed | Caught | Solver time (s) |",
                  "|---|---|---|---|---|---|---:|"]
        for b in record["broken"]:
            failed = ", ".join(b["failed"]) or b["status"]
            steps = f"{b.get('skip', 0)}-{b['depth'] - 1}" if "depth" in b else "?"
            lines.append(f"| {_cell(b['name'])} | {_cell(b['bug'])} | {_cell(b['expect'])}* | {steps} "
                         f"| {_cell(failed)} | {'yes' if b['caught'] else 'NO'} | {b['seconds']:.1f} |")
    if record.get("scope"):
        lines += [""] + [f"- {_cell(note)}" for note in record["scope"]]
    m = record.get("machine", {})
    load = ", ".join(str(x) for x in m.get("loadavg", []))
    lines += ["", f"Command: `{record.get('command', '?')}`; {m.get('nproc', '?')} cores, load average {load} "
              f"at the start; {record.get('seconds', 0):.0f} s in all; {m.get('date', '')}."]
    return "\n".join(lines) + "\n"
