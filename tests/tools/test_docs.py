"""The documentation stays true to the code: generated pages are current, the site builds without a warning,
the README stays a short guide, formats and measured figures in prose are never typed by hand, and nothing refers
to a file outside the repository or to a tracker the repository does not ship."""

from __future__ import annotations

import ast
import io
import json
import math
import re
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

from fxmodel.core.paths import ROOT
from tools import docs, docs_reference, record


def tracked(*suffixes: str) -> list[str]:
    """Tracked files (``git ls-files``) ending in one of ``suffixes`` (all if none)."""
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):          # not a git checkout: the source files on disk
        skip = {".venv", "build", "sim_build", ".git", ".hypothesis", ".pytest_cache", "__pycache__"}
        out = [str(p.relative_to(ROOT)) for p in ROOT.rglob("*")
               if p.is_file() and not skip.intersection(p.relative_to(ROOT).parts)]
    return [f for f in out if not suffixes or f.endswith(suffixes) or Path(f).name in suffixes]


# -- generated pages --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pages():
    return docs.render_pages()


def test_generated_pages_are_current(pages, tmp_path):
    written = docs.write_pages(tmp_path, pages)
    assert {p.name for p in written} == {f"{n}.md" for n in pages}
    committed = {p.name: p.read_text(encoding="utf-8") for p in docs.GENERATED.glob("*.md")}
    fresh = {p.name: p.read_text(encoding="utf-8") for p in tmp_path.glob("*.md")}
    bad = sorted(n for n in committed.keys() | fresh.keys() if committed.get(n) != fresh.get(n))
    bad += [rel for rel in docs.DOCUMENTS
            if docs.regenerate((ROOT / rel).read_text(encoding="utf-8"), rel, pages)
            != (ROOT / rel).read_text(encoding="utf-8")]
    assert not bad, (f"{', '.join(bad)}: stale (a preset, a parser, a layer, the Makefile or a record changed); "
                     f"run `{docs.COMMAND}` and commit the result")


def test_regenerate_fills_a_block_and_rejects_unknown_names():
    text = "x\n<!-- BEGIN GENERATED unit-formats: bumpmap docs -->\nold\n<!-- END GENERATED unit-formats -->\n"
    new = docs.regenerate(text)
    assert "old" not in new and "| `recip` |" in new and new.startswith("x\n") and docs.regenerate(new) == new
    with pytest.raises(ValueError, match="nope"):
        docs.regenerate(text.replace("unit-formats", "nope"))


def test_write_pages_removes_pages_no_longer_generated(tmp_path):
    (tmp_path / "gone.md").write_text("old")
    docs.write_pages(tmp_path, {"kept": "new\n"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.md"]
    assert docs.write_pages(tmp_path, {"kept": "new\n"}) == []


def test_port_groups_share_formats_and_name_flags_bare():
    from fxmodel.core.unit import preset
    assert docs.port_groups(preset("persp", "default").outputs) == "s, t u0.22; dbz"


def test_every_included_page_is_generated_and_every_generated_page_is_used(pages):
    included = set()
    for path in (ROOT / "docs").glob("*.md"):
        included |= set(re.findall(r'--8<-- "generated/([\w-]+)\.md"', path.read_text(encoding="utf-8")))
    readme = set(re.findall(r"<!-- BEGIN GENERATED ([\w-]+):", (ROOT / "README.md").read_text(encoding="utf-8")))
    assert included <= set(pages), f"pages include snippets nobody generates: {sorted(included - set(pages))}"
    unused = set(pages) - included - readme
    assert not unused, f"generated pages no document includes: {sorted(unused)}"


def test_mkdocs_builds_the_site_without_a_warning(tmp_path):
    """``make docs``: mkdocs-material and mkdocstrings (the ``docs`` extra), warnings are errors."""
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "-d", str(tmp_path)],
                         cwd=ROOT, capture_output=True, text=True, env={**__import__("os").environ,
                                                                          "NO_MKDOCS_2_WARNING": "1"})
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}\n{run.stderr}"
    params = (tmp_path / "parameters.html").read_text(encoding="utf-8")
    assert "RecipParams" in params and "doc-heading" in params, "mkdocstrings rendered no parameter object"


# -- the README ------------------------------------------------------------------------------------------------
README_MAX_LINES = 200


def test_readme_is_a_short_guide():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES}): " \
                                           "move the detail into docs/"
    text = "\n".join(lines)
    for needed in ("make sim", "make test", "make render", "docs/img/tin-plane.png", "LICENSE", "@inproceedings"):
        assert needed in text, f"README.md: {needed!r} missing from the guide"


# -- the generated reference pages ---------------------------------------------------------------------------------
def test_layout_names_every_module_of_the_contract(pages):
    layers = docs_reference.contract_layers()
    assert layers and layers[0][1], "no layers contract in pyproject.toml"
    for package in ("fxmodel", "host", "rtl", "cosim", "tools"):
        for path in (ROOT / package).rglob("*.py"):
            rel = path.relative_to(ROOT).with_suffix("")
            if rel.name == "__init__" and rel.parts[0] == "fxmodel":     # the model's packages: shown by their modules
                continue
            name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
            if name.endswith("__main__"):
                continue
            assert f"`{name}`" in pages["layout"], f"{name} is missing from the generated layout"


def test_layout_labels_come_from_the_contract_comments(tmp_path):
    toml = tmp_path / "pyproject.toml"
    toml.write_text('[tool.importlinter]\nroot_packages = ["a"]\n[[tool.importlinter.contracts]]\nname = "x"\n'
                    'type = "layers"\nlayers = [\n    # top: the tools\n    "a.top",\n    "a.low : a.other",\n]\n')
    assert docs_reference.contract_layers(toml) == [("a.low", ["a.low", "a.other"]), ("top", ["a.top"])]


def test_command_reference_documents_every_option_of_every_parser(pages):
    for command, parser in docs_reference.parsers().items():
        assert f"`{command}`" in pages["commands"]
        for action in parser._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}" in pages["commands"], f"{command} {option} missing from the reference"


# -- records ---------------------------------------------------------------------------------------------------
def test_record_is_written_atomically_with_command_and_machine(tmp_path):
    path = record.write(tmp_path / "sub" / "r.json", "python -m tools.x --y", {"a": 1})
    got = record.read(path)
    assert got["command"] == "python -m tools.x --y" and got["result"] == {"a": 1}
    assert got["machine"]["nproc"] >= 1 and len(got["machine"]["load_average"]) == 3 and got["machine"]["date"]
    assert [p.name for p in path.parent.iterdir()] == ["r.json"]          # no temporary file left
    (tmp_path / "bad.json").write_text('{"a": 1}')
    with pytest.raises(ValueError, match="bad.json"):
        record.read(tmp_path / "bad.json")
    (tmp_path / "flat.json").write_text('{"command": "c", "date": "d", "machine": {"nproc": 2}, "x": 1}')
    assert record.read(tmp_path / "flat.json") == {"command": "c", "machine": {"nproc": 2, "date": "d"},
                                                   "result": {"x": 1}}


def test_transcript_records_what_a_command_printed(tmp_path):
    code = "import sys; print('one'); print('two', file=sys.stderr); sys.exit(3)"
    assert record.transcript(tmp_path / "t.json", [sys.executable, "-c", code], "shown", stderr=True) == 3
    got = record.read(tmp_path / "t.json")
    assert got["command"] == "shown" and got["result"]["returncode"] == 3
    assert sorted(got["result"]["stdout"]) == ["one", "two"]


def test_every_record_is_readable_and_names_its_machine():
    for path in record.RECORDS.glob("*.json"):
        r = record.read(path)
        assert r["machine"].get("nproc") and r["machine"].get("date"), f"{path.name}: no machine"


# -- references ------------------------------------------------------------------------------------------------
#: Patterns of references that leave the repository (assembled so that this file does not match itself).
OUTSIDE = [
    (re.compile(r"\.\./" + "shared"), "a path outside the repository"),
    (re.compile(r"/" + r"work/"), "an absolute path of one machine"),
    (re.compile(r"(?i)(?<!docs/)(?<!\]\()\b" + "design" + r"\.md"),
     "the design notes: cite docs/design.md (or the paper)"),
    (re.compile(r"(?i)\b" + "issue" + r"s?\s*#?\d+"), "an issue number of a tracker the repository does not ship"),
]


def test_nothing_refers_outside_the_repository():
    problems = []
    for rel in tracked(".py", ".md", ".toml", "Makefile"):
        for no, line in enumerate((ROOT / rel).read_text(encoding="utf-8").splitlines(), 1):
            for pattern, what in OUTSIDE:
                m = pattern.search(line)
                if m:
                    problems.append(f"{rel}:{no}: {m.group(0)!r} is {what}")
    assert not problems, "\n".join(problems)


#: A repository path in backticks: ``fxmodel/units/recip.py``, ``docs/img/pareto.png``.
PATH = re.compile(r"`((?:fxmodel|rtl|cosim|tools|tests|scenes|presets|docs)/[\w./-]+)`")


def test_paths_named_in_the_documents_exist():
    missing = []
    for rel in tracked(".md"):
        for no, line in enumerate((ROOT / rel).read_text(encoding="utf-8").splitlines(), 1):
            for m in PATH.finditer(line):
                path = m.group(1).rstrip(".")
                if not (ROOT / path).exists():
                    missing.append(f"{rel}:{no}: {path}")
    assert not missing, "documents name files that do not exist:\n" + "\n".join(missing)


# -- formats in prose ------------------------------------------------------------------------------------------
#: A literal format such as ``s2.16`` or ``u0.22``.
LITERAL_FMT = re.compile(r"(?<![\w.])[su]-?\d+\.\d+(?!\w|\.\d)")
#: Files whose prose writes formats as examples of the notation or of a swept design point, not of a preset.
NOTATION_FILES = {"fxmodel/core/fixed.py", "tools/fit.py", "tools/sweep.py", "tools/sweep_units.py"}
#: Sections reporting swept design points (named by their knobs), not presets.
POINT_SECTIONS = ("## Speed against error",)
#: Generated pages: their figures come from the presets, the code and the records.
GENERATED_DIR = "docs/generated/"


def hand_written(suffix: str = ".md") -> list[str]:
    """Tracked documents written by hand (not the generated pages)."""
    return [rel for rel in tracked(suffix) if not rel.startswith(GENERATED_DIR)]
HOW = ("name the parameter field instead (``persp.uv_fmt``; `bumpmap info UNIT` prints the formats), "
       f"or quote it from a table generated by `{docs.COMMAND}`")


def python_prose(source: str):
    """``(line, text)`` of every docstring and comment of a module."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                for k, line in enumerate(body[0].value.value.splitlines()):
                    yield body[0].lineno + k, line
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            yield tok.start[0], tok.string


def markdown_prose(text: str):
    """``(line, text)`` of a document outside its generated blocks and outside :data:`POINT_SECTIONS`."""
    spans = docs.generated_spans(text)
    offset, section_exempt = 0, False
    for no, line in enumerate(text.splitlines(keepends=True), 1):
        if line.startswith("## "):
            section_exempt = line.strip().startswith(POINT_SECTIONS)
        inside = any(lo <= offset < hi for lo, hi in spans)
        offset += len(line)
        if not inside and not section_exempt:
            yield no, line


def test_formats_in_prose_are_named_not_typed():
    found = []
    for rel in tracked(".py"):
        if rel in NOTATION_FILES or rel == "tests/tools/test_docs.py":
            continue
        for no, line in python_prose((ROOT / rel).read_text(encoding="utf-8")):
            found += [f"{rel}:{no}: {m.group(0)}" for m in LITERAL_FMT.finditer(line)]
    for rel in hand_written():
        for no, line in markdown_prose((ROOT / rel).read_text(encoding="utf-8")):
            found += [f"{rel}:{no}: {m.group(0)}" for m in LITERAL_FMT.finditer(line)]
    assert not found, f"formats typed in prose drift from the presets; {HOW}:\n" + "\n".join(found)


# -- measured figures in prose -----------------------------------------------------------------------------------
#: A number with the unit of a measurement: a clock rate, a PSNR, a time, a rate, a load, a resource count.
MEASURED = re.compile(r"(?i)(?<![\w.])\d[\d,.]*\s?(?:MHz|dB|ns|ms|µs|(?:k|M)?\s?(?:vectors|pixels|fragments)"
                      r"\s?(?:/\s?s|per\s(?:CPU\s)?second)|s\sof\b|seconds|minutes|min\b|hours|LUT4|DP16KD|"
                      r"MULT18X18D)|load average\s\d")
#: A specification, not a measurement: a clock target, or a tool's version (``Python 3.11``).
TARGET = re.compile(r"(?i)target[s]?\s(?:of\s)?\d+\sMHz|\d+\sMHz\starget|Python\s\d+\.\d+")
#: Significant digits a prose number needs before it is compared with the records (fewer match by chance).
SIGNIFICANT = 3


def record_values() -> set[float]:
    """Every non-integer number held by a committed record (``docs/records``, ``docs/fpga``, ``docs/exhaustive``)."""
    values: set[float] = set()

    def walk(x):
        if isinstance(x, float) and math.isfinite(x) and x != int(x):
            values.add(x)
        elif isinstance(x, dict):
            for v in x.values():
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)
        elif isinstance(x, str):
            for m in re.finditer(r"(?<![\w.])\d+\.\d+(?![\w.])", x):
                walk(float(m.group(0)))

    for folder in ("docs/records", "docs/fpga", "docs/exhaustive"):
        for path in sorted((ROOT / folder).glob("*.json")):
            walk(json.loads(path.read_text(encoding="utf-8")))
    return values


def recorded_figures(line: str, values: set[float]) -> list[str]:
    """Decimal numbers of ``line`` with at least :data:`SIGNIFICANT` digits that a record holds (rounded alike)."""
    hits = []
    for m in re.finditer(r"(?<![\w.])\d+\.\d+(?![\w.]|\.\d)", line):
        text = m.group(0)
        digits = len(text.replace(".", "").lstrip("0"))
        decimals = len(text.split(".")[1])
        if digits >= SIGNIFICANT and any(round(v, decimals) == float(text) for v in values):
            hits.append(text)
    return hits


def measured_in_prose(text: str, values: set[float]) -> list[tuple[int, str]]:
    """``(line, figure)`` of the measured figures typed in a document's prose (outside generated blocks)."""
    found = []
    for no, line in markdown_prose(text):
        clean = TARGET.sub("", line)
        found += [(no, m.group(0)) for m in MEASURED.finditer(clean)]
        found += [(no, hit) for hit in recorded_figures(clean, values)]
    return found


def test_no_measured_figure_is_typed_in_prose():
    values = record_values()
    found = []
    for rel in hand_written():
        found += [f"{rel}:{no}: {fig}" for no, fig in measured_in_prose((ROOT / rel).read_text(encoding="utf-8"),
                                                                        values)]
    assert not found, ("measured figures typed in prose drift from their measurement; generate the table from the "
                       f"command's record (`--record`, `bumpmap record`; then `{docs.COMMAND}`):\n"
                       + "\n".join(found))


def test_the_figure_check_can_fail():
    values = {61.6812, 0.8691587, 3.1123}
    text = ("Fmax 180 MHz here; a clock target of 100 MHz is fine.\nit took 23.6 s of CPU\nload average 1.4\n"
            "worst 0.869 ulp, and 61.68 in passing; 0.5 ulp is a bound\nwith Python 3.11 (a version), but 3.11 ns\n"
            "<!-- BEGIN GENERATED unit-formats: bumpmap docs -->\n61.7 dB\n<!-- END GENERATED unit-formats -->\n")
    assert [f for _, f in measured_in_prose(text, values)] == ["180 MHz", "23.6 s of", "load average 1", "0.869",
                                                                 "61.68", "3.11 ns", "3.11"]


def test_the_prose_checks_can_fail():
    src = '"""Input ``w`` in ``s8.16``."""\n# N in s2.16\nx = "s1.9"  # not prose: a value\n'
    hits = [m.group(0) for _, line in python_prose(src) for m in LITERAL_FMT.finditer(line)]
    assert sorted(hits) == ["s2.16", "s8.16"]
    md = ("a u1.16\n<!-- BEGIN GENERATED unit-formats: bumpmap docs -->\ns2.16\n"
          "<!-- END GENERATED unit-formats -->\n## Speed against error\ns4.12\n## Next\nu8.0\n")
    hits = [m.group(0) for _, line in markdown_prose(md) for m in LITERAL_FMT.finditer(line)]
    assert hits == ["u1.16", "u8.0"]
    assert any(p.search("see " + "DESIGN" + ".md") for p, _ in OUTSIDE)
    assert any(p.search("(" + "issu" + "e 7, item 1)") for p, _ in OUTSIDE)
    assert not any(p.search("see docs/design.md") for p, _ in OUTSIDE)
    assert not any(p.search("see [Design](design.md#verification)") for p, _ in OUTSIDE)


def test_design_documents_the_cube_table_the_oracle_uses():
    from fxmodel.units import exact
    text = (ROOT / "docs/design.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| ([+−-][xyz]) \| (\d) \| ([+−-][xyz]) \| ([+−-][xyz]) \|$", text, re.M)
    assert len(rows) == 6, "docs/design.md: the face table (six rows) was not found"

    def signed_axis(cell):
        return "xyz".index(cell[1]), (1 if cell[0] == "+" else -1)

    for major, face, sc, tc in rows:
        assert 2 * "xyz".index(major[1]) + (major[0] != "+") == int(face)
        assert exact.CUBE_TABLE[int(face)] == (signed_axis(sc), signed_axis(tc)), f"face {face}"


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _base(rel: str) -> Path:
    """The folder a document's relative links start from: a generated page's are those of the page including it."""
    return ROOT / "docs" if rel.startswith(GENERATED_DIR) else (ROOT / rel).parent


def test_links_within_the_documents_resolve():
    broken = []
    for rel in tracked(".md"):
        text = (ROOT / rel).read_text(encoding="utf-8")
        anchors = {_slug(h) for h in re.findall(r"^#+ (.+)$", text, re.M)}
        for m in re.finditer(r"\]\(#([^)]+)\)", text):
            if m.group(1) not in anchors:
                broken.append(f"{rel}: #{m.group(1)}")
        for m in re.finditer(r"\]\((?!https?:|#)([^)#]+)", text):
            if not _base(rel).joinpath(m.group(1)).exists():
                broken.append(f"{rel}: {m.group(1)}")
    assert not broken, "links to missing headings or files:\n" + "\n".join(broken)


def test_a_missing_board_records_hint_makes_that_record():
    """The command a missing board record's page names (``tools.docs_board.RECORD_OPTIONS``) parses to the same frame
    store, maps in SDRAM, uploads and size as the command that made the committed record."""
    import shlex

    from tools.docs_board import RECORD_OPTIONS, _record_command
    from tools.main import build_parser
    ap = build_parser(["bitstream", "board-sim"])
    for name in RECORD_OPTIONS:
        tool, folder = ("bitstream", "docs/board") if name.startswith("bitstream") else ("board-sim", "docs/records")
        made = json.loads((ROOT / folder / f"{name}.json").read_text(encoding="utf-8"))["command"]
        hint, rec = (ap.parse_args(shlex.split(c)[1:]) for c in (_record_command(tool, name, folder), made))
        keys = ("frame", "size", "textures") + (("uploads",) if tool == "board-sim" else ())
        assert [getattr(hint, k) for k in keys] == [getattr(rec, k) for k in keys], name


def test_missed_endpoints_are_tabled_and_none_is_said_in_a_sentence():
    from tools.docs_records import misses_tables
    base = {"clock": "clk", "period_ns": 10.0}
    some = misses_tables({**base, "endpoints": 2, "by_unit": {"persp.recip": 2}, "by_kind": {"register": 2},
                          "worst": [{"ns": 11.4, "unit": "persp.recip", "register": "s7_pg", "pin": "A"}]})
    assert some.startswith("2 endpoints of `clk`") and "| `persp.recip` | 2 |" in some and "| 11.4 |" in some
    none = misses_tables({**base, "endpoints": 0, "by_unit": {}, "by_kind": {}, "worst": []})
    assert none.startswith("No endpoint of `clk` arrives later") and "|" not in none
