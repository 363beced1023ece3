"""``tools.record``: what a record says about the command that made it."""

from __future__ import annotations

from tools.record import command_line


def test_command_line_writes_paths_inside_the_working_folder_relative(tmp_path, monkeypatch):
    """An absolute path inside the working folder is written relative to it (a record names no one machine's
    folders); one outside it, and every other argument, as typed and quoted."""
    monkeypatch.chdir(tmp_path)
    inside = tmp_path / "docs" / "formal" / "proofs.json"
    line = command_line("bumpmap formal", ["--record", str(inside), "--out", "/elsewhere/build", "a b"])
    assert line == "bumpmap formal --record docs/formal/proofs.json --out /elsewhere/build 'a b'"
