"""Reference pages of the documentation generated from the code: the commands, the layers, the parameter objects.

Three things drift when typed by hand, so the documents do not type them:

* the **command reference** (:func:`commands`) is rendered from the argparse parsers themselves
  (:func:`parsers`: every entry point, its options, defaults and choices);
* the **layout** (:func:`layout`) is rendered from the import-linter contract in ``pyproject.toml`` (the one
  description of the layers that ``make test`` enforces), each module with the first line of its docstring;
* the **parameter objects** (:func:`parameters`) are ``mkdocstrings`` directives naming the classes where they
  live now (taken from the unit registry and the classes' ``__module__``), so a moved class moves its page.
"""

from __future__ import annotations

import argparse
import ast
import os
import re
import tomllib
from pathlib import Path

from fxmodel.core.paths import ROOT

__all__ = ["UNIT_ORDER", "parsers", "commands", "contract_layers", "layout", "module_summary",
           "parameters"]

#: Units in the order of the pixel's path; registered units not listed here follow in name order.
UNIT_ORDER = ("recip", "divide", "persp", "lod", "sampler", "bump", "reflect", "cube", "shade", "pipeline")

def parsers() -> dict[str, argparse.ArgumentParser]:
    """``{command: parser}``: the console script's one parser (:func:`tools.main.build_parser`, one subparser per
    command)."""
    from tools.main import build_parser
    return {"bumpmap": build_parser()}


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _usage(parser: argparse.ArgumentParser, prog: str) -> str:
    """``parser``'s usage line for ``prog``, wrapped at a fixed width (not the terminal's)."""
    saved_prog, saved_cols = parser.prog, os.environ.get("COLUMNS")
    parser.prog, os.environ["COLUMNS"] = prog, "110"
    try:
        return parser.format_usage().removeprefix("usage: ").strip()
    finally:
        parser.prog = saved_prog
        if saved_cols is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = saved_cols


def _help(action: argparse.Action) -> str:
    text = (action.help or "").replace("%(default)s", str(action.default)).replace("%(prog)s", "")
    if action.choices and not isinstance(action, argparse._SubParsersAction):
        text += f" (choices: {', '.join(map(str, action.choices))})"
    if action.default not in (None, False, argparse.SUPPRESS) and "%(default)" not in (action.help or "") \
            and action.option_strings and not isinstance(action, (argparse._HelpAction, argparse._StoreTrueAction)):
        text += f" (default: {action.default})"
    return text.replace(f"{ROOT}/", "")          # defaults under the checkout, relative to it


def _arguments_table(parser: argparse.ArgumentParser) -> list[str]:
    rows = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)) or action.help == argparse.SUPPRESS:
            continue
        name = ", ".join(action.option_strings) if action.option_strings else action.metavar or action.dest
        if action.option_strings and action.nargs != 0:
            name += " " + (action.metavar if isinstance(action.metavar, str) else action.dest.upper())
        rows.append(f"| `{_cell(name)}` | {_cell(_help(action))} |")
    return ["| argument | meaning |", "|---|---|", *rows, ""] if rows else []


def _describe(parser: argparse.ArgumentParser, prog: str, level: int) -> list[str]:
    out = [f"{'#' * level} `{prog}`", "", "```text", _usage(parser, prog), "```", ""]
    if parser.description:
        out += [rst_to_markdown(parser.description.strip().split("\n\n")[0].replace("\n", " ")), ""]
    out += _arguments_table(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                if helps.get(name) and not sub.description:
                    sub.description = helps[name]
                out += _describe(sub, f"{prog} {name}", min(level + 1, 4))
    return out


def commands() -> str:
    """The command reference: every entry point's usage, description and arguments (from :func:`parsers`)."""
    out = []
    for command, parser in parsers().items():
        out += _describe(parser, command, 3)
    return "\n".join(out).rstrip() + "\n"


# -- layout: the import-linter contract --------------------------------------------------------------------------
def contract_layers(pyproject: Path = ROOT / "pyproject.toml") -> list[tuple[str, list[str]]]:
    """``[(label, modules)]`` of the first ``layers`` contract, bottom layer first. ``label`` is the comment line
    just above the layer in ``pyproject.toml`` up to its colon (``# host: scenes, ...`` gives ``host``), else the
    layer's first module."""
    text = pyproject.read_text(encoding="utf-8")
    config = tomllib.loads(text)["tool"]["importlinter"]
    contract = next(c for c in config["contracts"] if c.get("type") == "layers")
    labels, lines = {}, text.splitlines()
    for no, line in enumerate(lines):
        m = re.match(r'\s*"([^"]+)",?\s*$', line)
        if m and no and lines[no - 1].strip().startswith("#"):
            labels[m.group(1)] = lines[no - 1].strip().lstrip("#").strip().split(":")[0]
    containers = contract.get("containers") or [""]
    out = []
    for layer in reversed(contract["layers"]):
        names = [n.strip() for n in re.split(r"[:|]", layer.strip("()")) if n.strip()]
        modules = [f"{c}.{n}" if c else n for c in containers for n in names]
        out.append((labels.get(layer, names[0]), modules))
    return out


def _module_file(module: str) -> Path | None:
    base = ROOT.joinpath(*module.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def rst_to_markdown(text: str) -> str:
    """Inline reStructuredText of a docstring as Markdown: ````x```` and ``:func:`x``` become ```x```."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)
    return text.replace("``", "`")


def module_summary(path: Path) -> str:
    """The first sentence of a module's docstring, in Markdown (``""`` if it has none)."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    para = " ".join(doc.strip().split("\n\n")[0].split())
    m = re.match(r"(.*?[.!?])(\s|$)", para)
    return rst_to_markdown(m.group(1) if m else para)


def _expand(module: str) -> list[tuple[str, Path]]:
    """``module`` itself, or for a package every module in it (``__init__`` first, then by name, recursively)."""
    path = _module_file(module)
    if path is None:
        raise ValueError(f"pyproject.toml: layer module {module!r} has no source file")
    if path.name != "__init__.py":
        return [(module, path)]
    out = [(module, path)]
    for child in sorted(path.parent.iterdir()):
        if child.name.startswith((".", "_")) or child.name == "__pycache__":
            continue
        if child.suffix == ".py" or (child / "__init__.py").is_file():
            out += _expand(f"{module}.{child.stem if child.suffix == '.py' else child.name}")
    return out


def layout() -> str:
    """The layers of the import-linter contract as a table, top layer first: layer, module, what it holds."""
    rows = []
    for label, modules in reversed(contract_layers()):
        first = True
        for module in modules:
            for name, path in _expand(module):
                rows.append(f"| {label if first else ''} | `{name}` | {_cell(module_summary(path))} |")
                first = False
    return "\n".join(["| layer | module | what it holds |", "|---|---|---|", *rows]) + "\n"


# -- parameter objects -------------------------------------------------------------------------------------------
def _extra_classes() -> list[type]:
    """The parameter objects outside the unit registry, and the number format and unit contract they use."""
    from fxmodel.core.fixed import Fmt
    from fxmodel.core.unit import Port, Unit
    from fxmodel.pipeline.engine import EngineParams
    from fxmodel.units.raster import RasterParams
    from fxmodel.units.rop import RopParams
    from fxmodel.units.texcache import TexCacheParams
    return [EngineParams, RasterParams, RopParams, TexCacheParams, Unit, Port, Fmt]


def parameters() -> str:
    """``mkdocstrings`` directives of every registered unit's parameter object, then :func:`_extra_classes`."""
    from fxmodel.core.unit import unit_class, units

    names = [u for u in UNIT_ORDER if u in units()] + sorted(u for u in units() if u not in UNIT_ORDER)
    out = []
    for cls in [unit_class(n) for n in names] + _extra_classes():
        out += [f"::: {cls.__module__}.{cls.__qualname__}", ""]
    return "\n".join(out)
