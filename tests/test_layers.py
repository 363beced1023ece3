"""The layers of the code base point down (docs, "Layout"): the golden model (``fxmodel.core`` < ``fxmodel.units``
< ``fxmodel.pipeline``) < ``host`` < ``rtl`` < ``cosim`` < ``tools``.

Four checks: the import-linter ``layers`` contract in ``pyproject.toml`` (``[tool.importlinter]``), that every
module of the four packages is in one of its layers (a new module must be placed), that no module imports
another module's private (``_``) name, and that there are no import cycles (function-level imports included).
Nothing is exempt (the contract has no ``ignore_imports``): the one entry point, ``bumpmap``, is in ``tools``. The
detectors are also run on small broken examples, so a check that can never fail
would show.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import grimp
import pytest

from fxmodel.core.paths import ROOT

PACKAGES = ("fxmodel", "host", "rtl", "board", "cosim", "formal", "tools")
#: Modules in no layer: the golden model's (empty) package ``__init__`` files.
UNLAYERED = {"fxmodel", "fxmodel.core", "fxmodel.units", "fxmodel.pipeline"}


def _config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]


def _modules() -> dict[str, Path]:
    """Every module of the four packages: dotted name -> file."""
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _lint_imports(config: Path) -> subprocess.CompletedProcess:
    code = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", code, "--config", str(config), "--no-cache", "--no-logo"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)


def test_layers_contract_is_kept():
    run = _lint_imports(ROOT / "pyproject.toml")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "0 broken" in run.stdout


def test_layers_contract_catches_an_upward_import(tmp_path):
    """The same checker on a contract that ``fxmodel.core.rounding`` (which imports ``fxmodel.core.fixed``) breaks."""
    bad = tmp_path / "bad.toml"
    bad.write_text('[tool.importlinter]\nroot_packages = ["fxmodel"]\n\n[[tool.importlinter.contracts]]\n'
                   'name = "upside down"\ntype = "layers"\nlayers = ["fxmodel.core.fixed", "fxmodel.core.rounding"]\n')
    run = _lint_imports(bad)
    assert run.returncode == 1 and "BROKEN" in run.stdout, run.stdout + run.stderr


def test_nothing_is_exempt():
    (contract,) = _config()["contracts"]
    assert not contract.get("ignore_imports"), contract["ignore_imports"]


def _layer_modules() -> list[str]:
    (contract,) = _config()["contracts"]
    out = []
    for layer in contract["layers"]:
        for name in layer.replace("|", ":").split(":"):
            out.append(name.strip().strip("()"))
    return out


def test_every_module_is_in_a_layer():
    layers = _layer_modules()
    missing = [m for m in _modules() if m not in UNLAYERED
               and not any(m == name or m.startswith(name + ".") for name in layers)]
    assert not missing, (f"modules in no layer of [tool.importlinter] in pyproject.toml: {missing}; add each to "
                         f"the layer it belongs to (README, Layout)")


def private_imports(module: str, source: str, is_package: bool = False, project: tuple[str, ...] = PACKAGES
                    ) -> list[str]:
    """``from M import _name`` (and ``M._name`` on a module imported as a name) of another project module ``M``
    in the source of ``module`` (a package's ``__init__`` if ``is_package``): ``"line: M._name"`` each."""
    tree = ast.parse(source)
    package = module.split(".") if is_package else module.split(".")[:-1]
    aliases = {}                                     # local name -> project module it names
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package[:len(package) - node.level + 1]
                base = ".".join(parent + ([base] if base else []))
            if base.split(".")[0] not in project:
                continue
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__") and base != module:
                    out.append(f"{node.lineno}: {base}.{a.name}")
                aliases[a.asname or a.name] = f"{base}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in project:
                    aliases[a.asname or a.name.split(".")[0]] = a.asname and a.name or a.name.split(".")[0]
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and node.attr.startswith("_") and not node.attr.startswith("__")):
            out.append(f"{node.lineno}: {aliases[node.value.id]}.{node.attr}")
    return out


def test_private_import_detector():
    src = "from .cube import _divide, CubeParams\nfrom rtl import reflect\nx = reflect._DIGIT\nfrom . import _ok\n"
    assert private_imports("tools.fit", "from fxmodel.units.cube import _divide\n") == ["1: fxmodel.units.cube._divide"]
    assert private_imports("fxmodel.units.fit", src) == ["1: fxmodel.units.cube._divide", "4: fxmodel.units._ok",
                                                         "3: rtl.reflect._DIGIT"]
    assert private_imports("fxmodel.units.fit", "from numpy import _x\nimport os\nos._exit\n") == []
    assert private_imports("rtl", "from .unit import _x\n", is_package=True) == ["1: rtl.unit._x"]


def test_no_private_names_imported_across_modules():
    found = [f"{path.relative_to(ROOT)}:{hit}" for name, path in _modules().items()
             for hit in private_imports(name, path.read_text(), path.name == "__init__.py")]
    assert not found, f"imports of another module's private name (make it public and documented): {found}"


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of a graph ``module -> imported modules``: its strongly connected components of more
    than one module, and modules that import themselves (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, it = work[-1]
            for nxt in it:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(edges.get(nxt, ())))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        m = stack.pop()
                        on_stack.discard(m)
                        comp.append(m)
                        if m == node:
                            break
                    if len(comp) > 1 or node in edges.get(node, ()):
                        out.append(sorted(comp))
    return out


def test_cycle_detector():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"a"}}) == [["a"]]
    assert cycles({"a": {"b"}, "b": set(), "c": {"a", "b"}}) == []


def test_no_import_cycles():
    graph = grimp.build_graph(*PACKAGES, cache_dir=None)
    edges = {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    assert set(_modules()) <= set(edges), "grimp did not see every module"
    found = cycles(edges)
    assert not found, f"import cycles (module-level and function-level imports): {found}"


@pytest.mark.parametrize("package", ["fxmodel"])
def test_model_never_imports_the_hdl_tools(package):
    """``fxmodel`` stays free of amaranth and cocotb (the entry point ``fxmodel.__main__`` aside)."""
    graph = grimp.build_graph(package, include_external_packages=True, cache_dir=None)
    bad = [(m, ext) for m in graph.modules if m.startswith(package + ".") and m != f"{package}.__main__"
           for ext in graph.find_modules_directly_imported_by(m) if ext.split(".")[0] in ("amaranth", "cocotb")]
    assert not bad, bad
