"""The documentation generator: every table and reference page that would drift if typed by hand.

``bumpmap docs`` writes ``docs/generated/<name>.md`` for every entry of :data:`PAGES`, from three
sources: the presets (formats, latencies, documented bounds: the functions below), the code
(:mod:`tools.docs_reference`: the command reference from the argument parsers, the layout from the
import-linter contract, the parameter objects' ``mkdocstrings`` directives) and the committed records of the
commands that measured something (:mod:`tools.docs_records`, :mod:`tools.docs_board`, ``docs/records/``). The
pages of ``docs/`` include them with ``pymdownx.snippets`` (``--8<-- "generated/<name>.md"``). The README, read
outside the site, holds
blocks between the markers ::

    <!-- BEGIN GENERATED <name>: bumpmap docs -->
    ...
    <!-- END GENERATED <name> -->

whose content is :data:`PAGES[name] <PAGES>`, rewritten in place. ``bumpmap docs --check`` only reports
what is stale (exit status 1); ``tests/tools/test_docs.py`` runs it, so a changed preset, parser, layer or record
without regenerating fails the test suite with the command to run. ``make docs`` then builds the site
(``mkdocs build --strict`` into ``build/site``).
"""

from __future__ import annotations

import argparse
import re
import sys
from fractions import Fraction
from pathlib import Path

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import ROOT
from fxmodel.core.unit import preset, unit_class, units
from host.atomic import atomic_write_text

from . import docs_board as board
from . import docs_records as rec
from . import docs_reference as ref
from .docs_reference import UNIT_ORDER

__all__ = ["PAGES", "DOCUMENTS", "GENERATED", "COMMAND", "port_groups", "unit_formats", "pipeline_data_flow",
           "recip_presets", "reciprocals", "formal_proofs", "render_pages", "write_pages", "regenerate",
           "generated_spans", "stale", "add_arguments", "run"]

#: The documents holding generated blocks in place (relative to the repository root).
DOCUMENTS = ("README.md",)
#: The folder of the generated pages.
GENERATED = ROOT / "docs" / "generated"
#: The formal proofs' record (written by the ``formal`` package; the page says so while it is absent).
PROOFS = ROOT / "docs" / "formal" / "proofs.json"
#: The command that regenerates them (quoted in failure messages).
COMMAND = "bumpmap docs"

_BLOCK = re.compile(r"(<!-- BEGIN GENERATED (?P<name>[\w-]+): bumpmap docs -->\n)(?P<body>.*?)"
                    r"(<!-- END GENERATED (?P=name) -->)", re.S)

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
    if name == "lod":
        return f"{_num(p.error_bound())} level for kappa ≤ {2 ** p.kappa_bits}, unless saturated"
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


def scene_schema() -> str:
    """The scene file's commented example (``host.scene.SCHEMA_EXAMPLE``, itself a parsed scene)."""
    from host.scene import SCHEMA_EXAMPLE
    return "```toml\n" + SCHEMA_EXAMPLE + "```\n"


def make_targets(makefile: Path = ROOT / "Makefile") -> str:
    """The ``make`` targets as ``make help`` prints them (the ``@echo "make ..."`` lines of the Makefile)."""
    rows: list[list[str]] = []
    for line in makefile.read_text(encoding="utf-8").splitlines():
        m = re.match(r'\t@echo "(make \S+)?\s*(.*)"$', line)
        if not m:
            continue
        text = m.group(2).replace("\\$$", "$").replace("$$", "$")
        if m.group(1):
            rows.append([f"`{m.group(1)}`", text])
        elif rows:
            rows[-1][1] += " " + text
    return _table(("target", "does"), [(t, d.replace("|", "\\|")) for t, d in rows])


def formal_proofs() -> str:
    """The formal proofs' table from ``docs/formal/proofs.json`` (``formal.report.markdown_table``)."""
    if not PROOFS.is_file():
        return ("*No proof record yet: the formal proofs write `formal/proofs.json` under `docs/`; this page shows "
                "their table once it is committed.*\n")
    import json

    from formal.report import markdown_table
    return markdown_table(json.loads(PROOFS.read_text(encoding="utf-8"))).rstrip() + "\n"


#: Page name -> function returning its Markdown (``docs/generated/<name>.md``; a README block of that name).
PAGES = {
    # from the presets
    "unit-formats": unit_formats, "pipeline-data-flow": pipeline_data_flow, "recip-presets": recip_presets,
    "reciprocals": reciprocals,
    # from the code
    "commands": ref.commands, "layout": ref.layout, "parameters": ref.parameters,
    # from the records
    "quickstart-sim": lambda: rec.quickstart("quickstart-sim", head=30),
    "quickstart-test": lambda: rec.quickstart("quickstart-test", head=0, tail=1),
    "quickstart-render": lambda: rec.quickstart("quickstart-render", head=20),
    "refusal": lambda: rec.quickstart("refusal", head=20),
    "timed-commands": rec.timed_commands, "scene-results": rec.scene_results,
    "triangle-results": rec.triangle_results, "scenes-stress": rec.scenes_stress, "depth": rec.depth,
    "precision": rec.precision,
    "exhaustive-rcp32": rec.exhaustive_rcp32, "exhaustive-throughput": rec.exhaustive_throughput,
    "fpga-resources": rec.fpga_resources, "fpga-placement": rec.fpga_placement, "bench": rec.bench,
    "fpga-placement-texcache": lambda: rec.fpga_placement(
        "placement-texcache", "--unit engine --scene berlin-wall --textures --router router1 --misses --no-cache "
                              "--placer-timing-weight 30 --placer-crit-exp 4"),
    "fpga-placement-units": lambda: rec.fpga_placement("placement-units", "--unit U ... --router router1"),
    "raster-guard": rec.raster_guard,
    "formal-proofs": formal_proofs, "records": rec.records_index, "scene-schema": scene_schema,
    "make-targets": make_targets, "recip-errors": rec.recip_errors, "rop-throughput": rec.rop_throughput,
    "texcache": rec.texcache, "texcache-mip": lambda: rec.texcache("texcache-mip"),
    "texcache-rate": rec.texcache_rate, "texcache-rate-frame": lambda: rec.texcache_rate("texcache-rate-frame"),
    "texcache-engine": rec.texcache_engine,
    "texcache-engine-mip": lambda: rec.texcache_engine("texcache-engine-mip"),
    "filtering-scenes": rec.filtering_scenes, "filtering-study": rec.filtering_study,
    "filtering-mip": rec.filtering_mip,
    "board-budget": board.board_budget, "board-bitstream": board.board_bitstream, "board-sim": board.board_sim,
    "board-sdram-bandwidth": board.board_sdram_bandwidth, "board-sim-sdram": lambda: board.board_sim("board-sim-sdram"),
    "board-sim-uploads": lambda: board.board_sim("board-sim-uploads"),
    "board-sim-textures": lambda: board.board_sim("board-sim-textures"),
    "board-animation": board.board_animation, "board-engine-misses": board.board_engine_misses,
    "board-bitstream-sdram": lambda: board.board_bitstream("bitstream-sdram"),
    "board-bitstream-textures": lambda: board.board_bitstream("bitstream-textures"),
}


def render_pages(names=None) -> dict[str, str]:
    """``{name: markdown}`` of the generated pages (all, or ``names``)."""
    return {name: fn() for name, fn in PAGES.items() if names is None or name in names}


def write_pages(folder: Path = GENERATED, pages: dict | None = None) -> list[Path]:
    """Write every generated page into ``folder`` (``<name>.md``) and remove pages no longer generated; the paths
    whose content changed."""
    pages = render_pages() if pages is None else pages
    changed = []
    for name, text in pages.items():
        path = folder / f"{name}.md"
        if not path.is_file() or path.read_text(encoding="utf-8") != text:
            atomic_write_text(path, text)
            changed.append(path)
    for path in folder.glob("*.md"):
        if path.stem not in pages:
            path.unlink()
            changed.append(path)
    return changed


def regenerate(text: str, where: str = "text", pages: dict | None = None) -> str:
    """``text`` with every generated block's body recomputed (``ValueError`` for an unknown block name)."""
    cache = dict(pages or {})

    def body(match):
        name = match.group("name")
        if name not in cache:
            if name not in PAGES:
                raise ValueError(f"{where}: unknown generated block {name!r} (known: {', '.join(PAGES)})")
            cache[name] = PAGES[name]()
        return match.group(1) + cache[name] + match.group(4)

    return _BLOCK.sub(body, text)


def generated_spans(text: str) -> list[tuple[int, int]]:
    """Character spans of the generated blocks' bodies in ``text``."""
    return [m.span("body") for m in _BLOCK.finditer(text)]


def stale(root: Path = ROOT, pages: dict | None = None) -> list[str]:
    """The generated pages and documents that differ from what the presets, the code and the records give now."""
    pages = render_pages() if pages is None else pages
    out = []
    folder = root / "docs" / "generated"
    for name, text in pages.items():
        path = folder / f"{name}.md"
        if not path.is_file() or path.read_text(encoding="utf-8") != text:
            out.append(path.relative_to(root).as_posix())
    out += [p.relative_to(root).as_posix() for p in folder.glob("*.md") if p.stem not in pages]
    for rel in DOCUMENTS:
        text = (root / rel).read_text(encoding="utf-8")
        if regenerate(text, rel, pages) != text:
            out.append(rel)
    return out


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """``bumpmap docs [--check]``."""
    ap.add_argument("--check", action="store_true", help="only report stale pages and documents (exit status 1)")


def run(args: argparse.Namespace) -> int:
    """Write the generated pages (docs/generated/) and the README's blocks."""
    try:
        pages = render_pages()
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        bad = stale(pages=pages)
        for rel in bad:
            print(f"{rel}: stale; run `{COMMAND}`", file=sys.stderr)
        return 1 if bad else 0
    for path in write_pages(GENERATED, pages):
        print(f"updated {path.relative_to(ROOT)}")
    for rel in DOCUMENTS:
        path = ROOT / rel
        text = path.read_text(encoding="utf-8")
        new = regenerate(text, rel, pages)
        if new != text:
            atomic_write_text(path, new)
            print(f"updated {rel}")
    return 0

