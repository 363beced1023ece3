"""The shape of the house (docs, "Layout"): no source file over 600 lines, no function over 100, ``ruff`` clean,
one command line (``bumpmap``) whose every command builds its parser, and a README that is a guide. The detectors
are also run on small broken examples, so a check that can never fail would show."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys

import pytest

from fxmodel.core.paths import ROOT
from tools.main import COMMANDS, build_parser

#: The packages whose sources are held to the limits.
PACKAGES = ("fxmodel", "host", "rtl", "board", "cosim", "tools", "formal")
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 100
MAX_README_LINES = 200


def sources():
    for pkg in PACKAGES:
        yield from sorted((ROOT / pkg).rglob("*.py")) if (ROOT / pkg).is_dir() else ()


def long_functions(source: str, limit: int) -> list[tuple[str, int]]:
    """``(qualified name, lines)`` of every function or method of ``source`` longer than ``limit`` lines (its
    decorators and docstring included)."""
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                    n = child.end_lineno - first + 1
                    if n > limit:
                        out.append((name, n))
                visit(child, name + ".")
            else:
                visit(child, prefix)
    visit(ast.parse(source), "")
    return out


def test_long_function_detector():
    src = "def short():\n    pass\n\nclass C:\n    @staticmethod\n    def f():\n" + "\n".join(
        f"        x{i} = {i}" for i in range(6)) + "\n"
    assert long_functions(src, 5) == [("C.f", 8)]
    assert long_functions(src, 8) == []


def test_no_source_file_over_the_limit():
    big = [f"{p.relative_to(ROOT)}: {n}" for p in sources()
           if (n := len(p.read_text().splitlines())) > MAX_FILE_LINES]
    assert not big, f"source files over {MAX_FILE_LINES} lines (split them along their jobs): {big}"


def test_no_function_over_the_limit():
    long = [f"{p.relative_to(ROOT)}: {name} ({n} lines)" for p in sources()
            for name, n in long_functions(p.read_text(), MAX_FUNCTION_LINES)]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines (split them into named steps): {long}"


@pytest.mark.skipif(shutil.which("ruff") is None and not (ROOT / ".venv" / "bin" / "ruff").exists(),
                    reason="ruff is not installed (the dev extra)")
def test_ruff_is_clean():
    run = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "."], cwd=ROOT,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_command_builds_its_parser(name):
    ap = build_parser([name])
    sub = ap._subparsers._group_actions[0].choices[name]
    assert sub.description and sub.format_help().startswith(f"usage: bumpmap {name}")


def test_an_unknown_command_is_refused_with_exit_2(capsys):
    from tools.main import main
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err


def test_the_readme_is_a_guide():
    n = len((ROOT / "README.md").read_text().splitlines())
    assert n <= MAX_README_LINES, f"README.md has {n} lines: a guide of at most {MAX_README_LINES}; tables go to docs/"
