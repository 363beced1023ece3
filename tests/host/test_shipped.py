"""The preset of each shipped scene (``host.shipped``)."""

from fxmodel.core.paths import SCENES
from host.render import prepare
from host.shipped import SCENE_PRESETS, scene_preset


def test_every_shipped_scene_is_drawn_by_its_preset():
    assert scene_preset(SCENES / "grazing-floor.toml") == "grazing-floor-wide" == scene_preset("grazing-floor")
    assert scene_preset("tin-plane") == "default"
    for name in SCENE_PRESETS:
        assert (SCENES / f"{name}.toml").is_file()
        frame = prepare(SCENES / f"{name}.toml", size=48, preset=scene_preset(name))      # refused: ClampError
        assert len(frame.codes) > 100
