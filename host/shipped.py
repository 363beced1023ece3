"""The preset each shipped scene (``scenes/*.toml``) is drawn with: ``default`` unless a scene needs wider
formats than the default preset holds. One table, so that every command and test drawing the shipped scenes
(``render`` and ``make sim`` take ``--preset`` / ``PRESET=`` instead) agrees.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["SCENE_PRESETS", "scene_preset"]

#: Scene name -> preset name, for the shipped scenes the default preset refuses.
SCENE_PRESETS = {
    # texture addresses at W down to 0.0008: U, V and W need 7 more fraction bits (presets/grazing-floor-wide.toml)
    "grazing-floor": "grazing-floor-wide",
}


def scene_preset(scene) -> str:
    """The preset of a shipped scene, given its name or path (``default`` for any other scene)."""
    return SCENE_PRESETS.get(Path(str(scene)).stem, "default")
