"""A fuzzer of ``bumpmap``'s untrusted inputs: malformed and extreme scene and preset files.

Hypothesis builds a scene file from a small valid one and breaks it: values replaced by wrong types, extreme and
non-finite numbers, hostile strings and paths (``../x``, ``/abs``, ``a/b``), keys deleted and unknown keys
added, huge declared sizes, a byte-order mark, a cut-off file, bytes that are not UTF-8; likewise a preset file
from the default preset's. Each file is run, in a sandbox (cwd and ``$BUMPMAP_BUILD`` inside a fresh temporary
folder), through ``bumpmap render``, the model side of ``bumpmap sim`` (``--model-only``) and ``bumpmap fit``
(short: ``--size 8 --passes 1``; on the files ``render`` refuses, and in the thorough profiles also on one in 10
or 40 of the others, since a search takes tens of seconds).

Property, for every command: the exit code is 0, 1 or 2; no exception escapes (no traceback) and no warning is
raised (numpy's ``invalid value`` on NaN normals, ...); an error (exit 2) is one message: one line starting
``error:`` or ``bumpmap ...: error:`` (a refusal naming several inputs continues on indented lines); and no file
is created, changed or deleted outside the run's own output (``out/``), build (``build/``) and preset
(``fitted/``) folders. ``render`` and ``fit`` agree on refusing a malformed scene.

The slow test (``-m slow``, ``make exhaustive``) runs many more files; so does
``HYPOTHESIS_PROFILE=thorough`` for the quick test. The counts of files run
and of what they found are printed at the end of the run (``pytest -s``).
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
import os
import tempfile
import tomllib
import warnings
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tools.main import main as bumpmap

THOROUGH = os.environ.get("HYPOTHESIS_PROFILE") == "thorough"

#: The valid scene the fuzzer breaks: small (24 x 16), every kind of mesh, a bump map and a color texture.
BASE_SCENE = {
    "name": "fuzz", "ambient": [0.05, 0.05, 0.05],
    "image": {"width": 24, "height": 16, "background": [0.0, 0.0, 0.1]},
    "camera": {"position": [0.0, 1.5, 3.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0], "fov": 45.0,
               "near": 0.1, "far": 100.0},
    "lights": [{"direction": [0.0, 1.0, 1.0], "color": [0.7, 0.7, 0.7]}],
    "materials": [{"name": "m", "color": {"procedural": "checker", "size": [8, 8], "checks": [2, 2]},
                   "specular": [1.0, 1.0, 1.0], "shininess": 20.0,
                   "bump": {"procedural": "mexican-hat", "size": [8, 8], "sigma": 1.5, "repeat": [2, 2],
                            "strength": 1.0}}],
    "meshes": [{"kind": "quad", "material": "m", "origin": [-1.0, 0.0, -1.0], "edge_u": [2.0, 0.0, 0.0],
                "edge_v": [0.0, 0.0, 2.0], "divisions": [1, 1]},
               {"kind": "sphere", "material": 0, "center": [0.0, 0.3, 0.0], "radius": 0.3, "segments": 6,
                "rings": 4},
               {"kind": "triangles", "material": "m", "positions": [[-1.0, 0.1, 0.5], [1.0, 0.1, 0.5],
                                                                   [0.0, 0.8, 0.5]],
                "uvs": [[0.0, 1.0], [1.0, 1.0], [0.5, 0.0]]}],
}

#: Hostile strings: paths that climb out, absolute paths, separators, empty, long, control characters.
HOSTILE_STRINGS = ["../x", "../../escape", "/abs/olute", "/etc/passwd", "a/b", "Fig 9/a", "..", ".", "", "a\\b",
                   "x" * 300, "nul\x00byte", "\u202e", "graffiti", "mexican-hat", "file.png", "../x.png"]
#: Extreme numbers (the schema's edges and far beyond), non-finite ones, huge declared sizes.
EXTREME_NUMBERS = [1e308, -1e308, 1e160, -1e160, 5e-324, 1e-300, 0, 0.0, -0.0, 2**63 - 1, -2**63, 10**30,
                   math.inf, -math.inf, math.nan, 8192, 8193, 4096, 4097, 1024, 1025, 10**9, 1, 2, 3, -1, 0.5]

values = st.one_of(
    st.sampled_from(EXTREME_NUMBERS), st.sampled_from(HOSTILE_STRINGS),
    st.sampled_from([True, False, [], {}, [0, 0, 0], [1e308] * 3, [1e160, 0.0, 0.0], [-1.0] * 3, [[1, 2]],
                     {"x": 1}, [1, "a", 2.0]]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(), st.text(max_size=12),
    st.lists(st.floats(-1e6, 1e6), max_size=4))


def _paths(doc, prefix=()):
    """Every key path of a parsed TOML document (tables and arrays walked)."""
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from _paths(v, prefix + (k,))


def _parent(doc, path):
    for k in path[:-1]:
        doc = doc[k]
    return doc


def mutate(data, doc: dict, count: int) -> list:
    """Apply up to ``count`` mutations to ``doc`` in place; returns what was done (for the failure report)."""
    done = []
    for _ in range(count):
        paths = list(_paths(doc))
        if not paths:
            break
        path = data.draw(st.sampled_from(paths))
        parent, key = _parent(doc, path), path[-1]
        how = data.draw(st.sampled_from(["set", "set", "set", "delete", "unknown"]))
        if how == "set":                # a copy: a drawn list is a shared constant, and a later mutation of it
            parent[key] = copy.deepcopy(data.draw(values))      # would change every example (or nest it in itself)
        elif how == "delete":
            if isinstance(parent, list):
                parent.pop(key)
            else:
                del parent[key]
        elif isinstance(parent, dict):
            parent[data.draw(st.sampled_from(["colour", "nmae", "extra", "../x"]))] = copy.deepcopy(data.draw(values))
        done.append((how, path))
    return done


def encode(data, doc: dict) -> bytes:
    """TOML bytes of ``doc``, sometimes with a byte-order mark, cut short, or with a byte that is not UTF-8."""
    import tomli_w
    try:
        text = tomli_w.dumps(doc).encode()
    except (TypeError, ValueError):             # a value TOML cannot hold (e.g. a mixed nested list)
        text = b"name = 1\n[image\n"
    how = data.draw(st.sampled_from(["plain"] * 6 + ["bom", "cut", "not-utf8"]))
    if how == "bom":
        return b"\xef\xbb\xbf" + text
    if how == "cut":
        return text[:data.draw(st.integers(0, len(text)))]
    if how == "not-utf8":
        i = data.draw(st.integers(0, len(text)))
        return text[:i] + b"\xff\xfe" + text[i:]
    return text


def base_preset() -> dict:
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS, dump_preset
    return tomllib.loads(dump_preset(BUILTIN_PRESET_UNITS["default"]))


def listing(root: Path) -> dict:
    return {p.relative_to(root).as_posix(): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in root.rglob("*") if p.is_file() or p.is_symlink()}


#: What the fuzz run found: files run, exit codes per command, first words of the refusals.
FOUND: Counter = Counter()
#: Folders (relative to the sandbox) a run may change: its output, the build folder and fit's preset folder.
OWN = ("out/", "build/", "fitted/")


def run(argv: list[str]) -> tuple[int, str]:
    """``bumpmap argv`` in this process: ``(exit code, stderr)``; any exception or warning fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("error")                  # a warning (NaN normals, overflow) is a finding
        try:
            rc = bumpmap(argv)
        except SystemExit as exc:                       # argparse's refusals
            rc = exc.code
    return rc, err.getvalue()


def check(argv, rc, err) -> None:
    assert rc in (0, 1, 2), (argv, rc, err)
    assert "Traceback" not in err, (argv, err)
    heads = [line for line in err.splitlines() if line and not line[0].isspace()]
    if rc == 2:
        assert len(heads) == 1 and ("error:" in heads[0]), (argv, err)
    for line in heads:
        assert line.startswith(("error:", "warning:", "bumpmap")), (argv, err)


@contextlib.contextmanager
def sandbox():
    """A fresh folder as cwd, with ``$BUMPMAP_BUILD`` and ``$FXMODEL_PRESETS`` inside it."""
    old_cwd, old_env = os.getcwd(), {k: os.environ.get(k) for k in ("BUMPMAP_BUILD", "FXMODEL_PRESETS")}
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        root = Path(tmp)
        (root / "work").mkdir()
        os.chdir(root / "work")
        os.environ["BUMPMAP_BUILD"] = str(root / "work" / "build")
        os.environ["FXMODEL_PRESETS"] = str(root / "work" / "presets")
        try:
            yield root
        finally:
            os.chdir(old_cwd)
            for k, v in old_env.items():
                os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v)


@settings(max_examples=300 if THOROUGH else 150, deadline=None, derandomize=not THOROUGH,
          suppress_health_check=list(HealthCheck))
@given(st.data())
def test_untrusted_scene_and_preset_files(data):
    """The quick profile (``make test``): fit only on the files render refuses."""
    fuzz(data, 10 if THOROUGH else 0)


@pytest.mark.slow
@settings(max_examples=1000, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_untrusted_scene_and_preset_files_thorough(data):
    """The slow profile (``-m slow``): many more files, fit also on one in 40 of the accepted ones."""
    fuzz(data, 40)


def fuzz(data, thorough: int) -> None:
    """One fuzzed scene (and maybe preset) file through render, sim's model side and fit (module docstring); fit
    also runs on one in ``thorough`` of the files render accepts (never with 0)."""
    doc = copy.deepcopy(BASE_SCENE)
    mutations = mutate(data, doc, data.draw(st.integers(0, 3)))
    stem = data.draw(st.sampled_from(["scene", "..x", "a b", "ü-x", "-x", "x.y"]))
    preset = data.draw(st.sampled_from([None, None, "fz", "../x", "/abs", "a/b"]))
    pdoc = base_preset() if preset == "fz" else None
    if pdoc is not None:
        mutations += mutate(data, pdoc, data.draw(st.integers(1, 2)))
    with sandbox() as root:
        work = root / "work"
        (work / "scenes").mkdir()
        (work / "scenes" / f"{stem}.toml").write_bytes(encode(data, doc))
        (root / "outside.txt").write_text("must stay")
        if pdoc is not None:
            (work / "presets").mkdir()
            (work / "presets" / "fz.toml").write_bytes(encode(data, pdoc))
        scene = f"scenes/{stem}.toml"
        small = ["--size", "16", "--cube-size", "8"]
        pre = ["--preset", preset] if preset else []
        before = listing(root)
        commands = {"render": ["render", scene, "out/frame.png", *small, *pre],
                    "sim": ["sim", "--scene", scene, "--model-only", *small, *pre],
                    "fit": ["fit", scene, "--size", "8", "--scene-size", "16", "--passes", "1", "--cube-size", "8",
                            "--quiet", "--out", "fitted"]}
        codes = {}
        for name, argv in commands.items():
            refused = codes.get("render") == 2 and not preset
            if name == "fit" and not refused and not (thorough and data.draw(st.integers(1, thorough)) == 1):
                continue                    # a search takes tens of seconds: refusals, and 1 in `thorough` others
            rc, err = run(argv)
            check((argv, mutations), rc, err)
            codes[name] = rc
            FOUND[f"{name} exit {rc}"] += 1
            if rc == 2:
                FOUND[f"{name} refused: {_what(err)}"] += 1
        if "fit" in codes and not preset:
            assert (codes["render"] == 2) == (codes["fit"] == 2), (codes, mutations)
        after = listing(root)
        changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
        stray = sorted(k for k in changed if not k.startswith(tuple("work/" + o for o in OWN)))
        assert not stray, (stray, mutations)
    FOUND["files run"] += 1


def _what(err: str) -> str:
    """The kind of a refusal, for the summary: the key path or the first words after the file name."""
    line = err.splitlines()[0]
    for marker in ("error: argument ", ".toml: ", "error: "):
        if marker in line:
            rest = line.split(marker, 1)[1]
            return rest.split(":")[0][:40]
    return line[:40]


@pytest.fixture(scope="module", autouse=True)
def summary():
    yield
    if FOUND:
        print("\nfuzz summary:", dict(sorted(FOUND.items())))
