"""Tables of the documentation generated from the presets: formats, latencies and error bounds.

Formats quoted in prose drift when a preset changes, so the documents do not type them: ``README.md`` and
``docs/design.md`` hold blocks between the markers ::

    <!-- BEGIN GENERATED <name>: python -m tools.docs -->
    ...
    <!-- END GENERATED <name> -->

whose content is the output of :data:`BLOCKS[name] <BLOCKS>`, computed from the registered units' presets.
``python -m tools.docs`` rewrites every block in place; ``python -m tools.docs --check`` only reports stale
blocks (exit status 1). ``tests/tools/test_docs.py`` runs the check, so a change of a preset, a port or a unit without
regenerating the documents fails the test suite with the command to run.
"""

from __future__ import annotations

import argparse
import re
import sys
from fractions import Fraction
from pathlib import Path

from fxmodel.core.paths import ROOT
from fxmodel.core.fixed import Fmt
from fxmodel.core.unit import preset, unit_class, units

__all__ = ["BLOCKS", "DOCUMENTS", "COMMAND", "port_groups", "unit_formats", "pipeline_data_flow",
           "recip_presets", "reciprocals", "regenerate", "stale", "main"]

#: The documents holding generated blocks (relative to the repository root).
DOCUMENTS = ("README.md", "docs/design.md")
#: The command that regenerates them (quoted in failure messages).
COMMAND = "python -m tools.docs"

_BLOCK = re.compile(r"(<!-- BEGIN GENERATED (?P<name>[\w-]+): python -m tools\.docs -->\n)(?P<body>.*?)"
                    r"(<!-- END GENERATED (?P=name) -->)", re.S)

#: Units in the order of the pixel's path; registered units not listed here follow in name order.
UNIT_ORDER = ("recip", "divide", "persp", "sampler", "bump", "reflect", "cube", "shade", "pipeline")
FLAG = Fmt(False, 1, 0)


def _fmt(fmt: Fmt) -> str:
    return str(fmt)


def _num(x) -> str:
    """A short number: three significant digits, exponents without padding (``7.52e-6``)."""
    text = f"{float(x):.3g}"
    return re.sub(r"e([+-])0*(\d)", lambda m: "e" + m.group(1).replace("+", "") + m.group(2), text)


def _ulps(x) -> str:
    return "½" if x == Fraction(1, 2) else _num(x)


def port_groups(ports) -> str:
    """Ports as ``"U, V <fmt>; W <fmt>; dbz"``: consecutive ports of one format share it; a one-bit flag is named
    without its format."""
    groups: list[tuple[list[str], Fmt]] = []
    for p in ports:
        if groups and groups[-1][1] == p.fmt and p.fmt != FLAG:
            groups[-1][0].append(p.name)
        else:
            groups.append(([p.name], p.fmt))
    return "; ".join(", ".join(names) + ("" if fmt == FLAG else f" {_fmt(fmt)}") for names, fmt in groups)


def _table(header: tuple, rows: list) -> str:
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join("---:" if h.endswith("(cycles)") or h == "latency" else "---" for h in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


# -- documented bound of each unit, in words -----------------------------------------------------------------
def _recip_bound(p) -> str:
    b = float(p.error_bound_ulp)
    return f"{b:.3f} ulp" + (" (faithful)" if p.error_bound_ulp < 1 else "")


def _bound(p) -> str:
    """The unit's documented error bound, from its parameter object."""
    name = p.NAME
    if name == "recip":
        return _recip_bound(p)
    if name == "divide":
        return f"{_num(p.max_error)} for \\|n/d\\| ≤ {p.quotient_limit}"
    if name == "persp":
        return f"{_num(p.error_bound(Fraction(16)))} for \\|s\\| ≤ 16"
    if name == "bump":
        return f"{_ulps(p.max_error / p.out_fmt.ulp)} ulp unless saturated"
    if name == "reflect":
        return f"< 1 ulp per component, {_num(p.direction_bound)} rad"
    if name == "cube":
        return f"{_num(p.st_bound)} on s, t; face exact"
    if name == "sampler":
        return "½ ulp (bilinear)" if p.bilinear else "exact (nearest)"
    if name == "shade":
        return "½ LSB unless saturated"
    if name == "pipeline":
        return "see Results"
    return f"`bumpmap info {name}`"


def _ordered_units() -> list[str]:
    known = units()
    return [u for u in UNIT_ORDER if u in known] + sorted(u for u in known if u not in UNIT_ORDER)


def unit_formats() -> str:
    """README's table of every unit's ``default`` preset: ports and formats, latency, documented bound."""
    rows = []
    for name in _ordered_units():
        p = preset(name, "default")
        rows.append((f"`{name}`", port_groups(p.inputs), port_groups(p.outputs), p.latency, _bound(p)))
    return _table(("unit", "inputs", "outputs", "latency", "documented bound"), rows)


#: The pixel's path through :class:`~fxmodel.pipeline.pixel.PipelineParams`: ``(stage, parameter field, key of
#: stage_latency)``.
_STAGES = (("perspective coordinates", "persp", "persp"),
           ("bump-map lookup (`s`, `t`)", "bump_map", "samples"),
           ("color-texture lookup (`sc`, `tc`)", "texture", "samples"),
           ("bump engine", "bump", "bump"),
           ("reflection vector (`N'`, `E`)", "reflect", "reflect"),
           ("cube address, twice (`N'`, `R`)", "cube", "cubes"),
           ("diffuse-cube lookup", "diffuse", "lookups"),
           ("specular-cube lookup", "specular", "lookups"),
           ("shading", "shade", "shade"))


def pipeline_data_flow() -> str:
    """docs/design.md's table: every stage of the ``default`` pipeline preset with its ports' formats."""
    P = unit_class("pipeline").PRESETS["default"]
    T = P.stage_latency
    rows = [("fragment", "", "", port_groups(P.inputs), 0)]
    for stage, field, key in _STAGES:
        p = getattr(P, field)
        rows.append((stage, f"`{field}`", port_groups(p.inputs), port_groups(p.outputs), T.get(key, "")))
    rows.append(("output register", "", "", port_groups(P.outputs), P.latency))
    return _table(("stage", "field of `PipelineParams`", "inputs", "outputs", "ready (cycles)"), rows)


def _recip_rows(configs) -> list:
    rows = []
    for label, r in configs:
        lo, hi = r._raw_error
        ulp = 1 << r.fo
        rows.append((label, _fmt(r.in_fmt), f"{r.p} bits", f"{r.entries} × {r.rom_bits} bits", r.t, f"`{r.table}`",
                     f"{float(lo * ulp):+.3f} … {float(hi * ulp):+.3f}", _recip_bound(r)))
    return rows


_RECIP_HEADER = ("configuration", "input", "result", "table", "terms", "mode", "error before centring (ulp)",
                 "documented bound")


def recip_presets() -> str:
    """README's table of the reciprocal presets."""
    cls = unit_class("recip")
    return _table(_RECIP_HEADER, _recip_rows((f"`{n}`", p) for n, p in cls.PRESETS.items()))


def reciprocals() -> str:
    """docs/design.md's table: the reciprocal presets and the reciprocals inside the other units' defaults."""
    configs = [(f"`recip` preset `{n}`", p) for n, p in unit_class("recip").PRESETS.items()]
    configs += [("`persp.recip` (texture addresses)", preset("persp", "default").recip),
                ("`cube.divide.recip`", preset("cube", "default").divide.recip)]
    return _table(_RECIP_HEADER, _recip_rows(configs))


#: Block name -> function returning its markdown.
BLOCKS = {"unit-formats": unit_formats, "pipeline-data-flow": pipeline_data_flow, "recip-presets": recip_presets,
          "reciprocals": reciprocals}


def regenerate(text: str, where: str = "text") -> str:
    """``text`` with every generated block's body recomputed (``ValueError`` for an unknown block name)."""
    cache = {}

    def body(match):
        name = match.group("name")
        if name not in BLOCKS:
            raise ValueError(f"{where}: unknown generated block {name!r} (known: {', '.join(BLOCKS)})")
        if name not in cache:
            cache[name] = BLOCKS[name]()
        return match.group(1) + cache[name] + match.group(4)

    return _BLOCK.sub(body, text)


def generated_spans(text: str) -> list[tuple[int, int]]:
    """Character spans of the generated blocks' bodies in ``text``."""
    return [m.span("body") for m in _BLOCK.finditer(text)]


def stale(root: Path = ROOT) -> list[str]:
    """The documents whose generated blocks differ from what the presets give now."""
    out = []
    for rel in DOCUMENTS:
        path = root / rel
        text = path.read_text(encoding="utf-8")
        if regenerate(text, rel) != text:
            out.append(rel)
    return out


def main(argv=None) -> int:
    """``python -m tools.docs [--check]``: regenerate the generated tables of README.md and docs/design.md."""
    ap = argparse.ArgumentParser(prog=COMMAND, description=main.__doc__)
    ap.add_argument("--check", action="store_true", help="only report stale documents (exit status 1)")
    args = ap.parse_args(argv)
    if args.check:
        bad = stale()
        for rel in bad:
            print(f"{rel}: generated tables are stale; run `{COMMAND}`", file=sys.stderr)
        return 1 if bad else 0
    for rel in DOCUMENTS:
        path = ROOT / rel
        text = path.read_text(encoding="utf-8")
        new = regenerate(text, rel)
        if new != text:
            path.write_text(new, encoding="utf-8")
            print(f"updated {rel}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
