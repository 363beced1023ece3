"""Paths as reports print them (``fxmodel.core.paths.shown_path``): inside the repository relative to its root, so a
record or the README's transcript of one names no one machine's folders; outside it, as given."""

from __future__ import annotations

from pathlib import Path

from fxmodel.core.paths import ROOT, shown_path


def test_paths_inside_the_repository_are_shown_from_its_root():
    assert shown_path(ROOT / "build" / "sim" / "run") == str(Path("build", "sim", "run"))
    assert not Path(shown_path(ROOT / "docs")).is_absolute()
    assert shown_path("/tmp/elsewhere") == "/tmp/elsewhere"
    assert shown_path("build/x") == "build/x"
