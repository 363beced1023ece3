"""Atomic outputs (:mod:`host.atomic`, :func:`fxmodel.core.paths.atomic_writer`): a run interrupted at any moment
leaves each output either the previous complete file or the new complete file (before, 7 of 7 renders
interrupted while writing left truncated PNGs).

Three levels: the writer itself; a render whose writes are interrupted in-process at every write, every fsync
and every rename in turn (deterministic); and ``bumpmap render`` killed with SIGKILL or SIGINT at random moments
in a subprocess.
"""

from __future__ import annotations

import io
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from PIL import Image

import fxmodel.core.paths as paths
from fxmodel.core.paths import ROOT, atomic_writer
from host.atomic import (
    atomic_json,
    atomic_write_text,
    check_output_dir,
    check_output_file,
)
from host.render import prepare, render

TIN = ROOT / "scenes" / "tin-plane.toml"


def test_writer_replaces_whole_or_not_at_all(tmp_path):
    path = tmp_path / "a.txt"
    atomic_write_text(path, "old")
    with pytest.raises(RuntimeError):
        with atomic_writer(path, "w") as fh:
            fh.write("new, half")
            raise RuntimeError("interrupted")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.txt"]   # no temp left
    atomic_write_text(path, "new")
    assert path.read_text() == "new"


def test_writer_names_the_target_in_its_errors(tmp_path):
    with pytest.raises(IsADirectoryError):
        atomic_write_text(tmp_path, "x")
    with pytest.raises(OSError) as exc:
        with atomic_writer(tmp_path / "missing" / "x.txt") as fh:
            fh.write(b"x")
    assert exc.value.filename == str(tmp_path / "missing" / "x.txt")


def test_json_is_strict(tmp_path):
    with pytest.raises(ValueError):
        atomic_json(tmp_path / "r.json", {"psnr": float("inf")})
    assert not (tmp_path / "r.json").exists()
    atomic_json(tmp_path / "r.json", {"psnr": None})
    assert json.loads((tmp_path / "r.json").read_text()) == {"psnr": None}


def test_output_checks(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(NotADirectoryError):
        check_output_dir(tmp_path / "f")
    with pytest.raises(IsADirectoryError):
        check_output_file(tmp_path)
    assert check_output_file(tmp_path / "new" / "x.png") == tmp_path / "new" / "x.png"
    assert (tmp_path / "new").is_dir()


def test_writer_and_checks_refuse_a_path_that_is_not_a_regular_file(tmp_path):
    """A FIFO (or a device: ``/dev/null`` as an output, run as root, became a regular file) is not renamed over."""
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(OSError, match="not a regular file"):
        atomic_write_text(fifo, "x")
    with pytest.raises(OSError, match="not a regular file"):
        check_output_file(fifo)
    assert [p.name for p in tmp_path.iterdir()] == ["fifo"] and os.path.exists(fifo) and not fifo.is_file()


def test_output_check_refuses_an_input(tmp_path):
    (tmp_path / "in.toml").write_text("x")
    os.link(tmp_path / "in.toml", tmp_path / "hard.toml")
    for out in (tmp_path / "in.toml", tmp_path / "sub" / ".." / "in.toml", tmp_path / "hard.toml"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        with pytest.raises(OSError, match="is the input"):
            check_output_file(out, inputs=[None, tmp_path / "in.toml"])
    assert check_output_file(tmp_path / "new.png", inputs=[tmp_path / "in.toml", tmp_path / "missing"])


def _outputs(folder: Path) -> dict:
    """Every visible file of ``folder``: name -> bytes (temporary files are hidden: ``.name.*.tmp``)."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")}


def _check_old_or_new(folder: Path, old: dict, new: dict) -> None:
    """Each output is the old complete file or the new complete file, and decodes."""
    for name, data in _outputs(folder).items():
        assert data == old.get(name) or data == new.get(name), f"{name}: neither the old nor the new file"
        if name.endswith(".png"):
            Image.open(io.BytesIO(data)).load()
        elif name.endswith(".json"):
            json.loads(data)


@pytest.fixture(scope="module")
def frames():
    return prepare(TIN, size=24, cube_size=8), prepare(TIN, size=32, cube_size=8)


@pytest.mark.parametrize("where", ["write", "fsync", "replace"])
def test_render_interrupted_at_every_step_of_every_write(tmp_path_factory, monkeypatch, frames, where):
    """Render into a folder holding an older frame's images, with a KeyboardInterrupt raised at the k-th write
    (half of the data written), fsync or rename, for every k: each file is the old one or the new one."""
    old_frame, new_frame = frames
    tmp_path, ref = tmp_path_factory.mktemp("out"), tmp_path_factory.mktemp("ref")
    render(old_frame, tmp_path)
    old = _outputs(tmp_path)
    render(new_frame, ref)
    new = _outputs(ref)
    assert set(old) == set(new) and all(old[n] != new[n] for n in old)
    real_fdopen, real_fsync, real_replace = paths.os.fdopen, paths.os.fsync, paths.os.replace
    interrupted = 0
    for k in range(len(new) + 1):
        calls = [0]

        def trip(calls=calls, k=k):
            calls[0] += 1
            if calls[0] == k + 1:
                raise KeyboardInterrupt

        class HalfFile(io.FileIO):
            def write(self, data, calls=calls, k=k, trip=trip):
                if calls[0] + 1 == k + 1:
                    super().write(bytes(data)[:len(data) // 2])
                trip()
                return super().write(data)

        if where == "write":
            monkeypatch.setattr(paths.os, "fdopen", lambda fd, mode, **kw: HalfFile(fd, "w"))
        elif where == "fsync":
            monkeypatch.setattr(paths.os, "fsync", lambda fd: (trip(), real_fsync(fd)))
        else:
            monkeypatch.setattr(paths.os, "replace", lambda a, b: (trip(), real_replace(a, b)))
        try:
            render(new_frame, tmp_path)
        except KeyboardInterrupt:
            interrupted += 1
        finally:
            monkeypatch.setattr(paths.os, "fdopen", real_fdopen)
            monkeypatch.setattr(paths.os, "fsync", real_fsync)
            monkeypatch.setattr(paths.os, "replace", real_replace)
        _check_old_or_new(tmp_path, old, new)
        assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]      # cleaned up on the way out
        render(old_frame, tmp_path)                         # back to the old frame for the next k
    assert interrupted == len(new)                          # every write was interrupted once


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_render_killed_at_random_moments(tmp_path, sig):
    """``bumpmap render --refs`` killed (SIGKILL) or interrupted (SIGINT) at random moments while it renders and
    writes: every image in the folder is the old complete one or the new complete one."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "BUMPMAP_BUILD": str(tmp_path / "build")}
    out = tmp_path / "out"

    def bumpmap_render(folder, size):
        return [sys.executable, "-m", "tools", "render", str(TIN), str(folder / "model.png"), "--refs",
                str(folder), "--size", str(size), "--cube-size", "8"]

    t0 = time.perf_counter()
    subprocess.run(bumpmap_render(tmp_path / "new", 160), env=env, check=True, capture_output=True, timeout=300)
    full = time.perf_counter() - t0
    new = _outputs(tmp_path / "new")
    rng = random.Random(23)
    for _ in range(4):
        subprocess.run(bumpmap_render(out, 96), env=env, check=True, capture_output=True, timeout=300)
        old = _outputs(out)
        proc = subprocess.Popen(bumpmap_render(out, 160), env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True)
        time.sleep(rng.uniform(0.5, 0.95) * full)            # late in the run: while the images are written
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=300)
        if "init_import_site" not in err:       # not while the interpreter itself starts, before bumpmap runs
            assert "Traceback" not in err
            # 130: Ctrl-C caught ('interrupted'); -2: it came while the interpreter was exiting; -9: SIGKILL
            assert proc.returncode in (0, 130, -sig), (proc.returncode, err)
        _check_old_or_new(out, old, new)
    assert set(_outputs(out)) >= {"model.png", "float.png", "ideal.png", "diff.png"}
