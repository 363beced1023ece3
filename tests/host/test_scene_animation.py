"""A scene's animation (``host/scene_animation.py``): the ``[animation]`` table parsed and validated (limits, clear
errors naming the key), each frame's camera on the piecewise-linear path and its lights turned about +y by the
exact rotation, and the host tool sending the frames in turn."""

from __future__ import annotations

import numpy as np
import pytest

from host.scene import SCHEMA_EXAMPLE, SceneError, parse_scene
from host.scene_animation import MAX_FRAMES, MAX_KEYS, frames

BASE = """
[image]
width = 8
height = 8
[camera]
position = [0.0, 1.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 45.0
[[lights]]
direction = [1.0, 0.0, 0.0]
color = [1.0, 1.0, 1.0]
[[materials]]
name = "m"
[[meshes]]
kind = "quad"
material = "m"
origin = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
"""


def _scene(anim: str):
    return parse_scene(BASE + "[animation]\n" + anim, source="anim")


def test_frames_follow_the_path_and_turn_the_lights_exactly():
    s = _scene("frames = 5\ncamera_path = [[0.0, 1.0, 4.0], [2.0, 1.0, 4.0], [2.0, 3.0, 4.0]]\nlight_turn = 90.0")
    fr = frames(s)
    assert len(fr) == 5
    pos = np.array([f.camera.position for f in fr])
    # keys at t = 0, 1/2, 1; frames at t = k/4: halfway along each segment between the keys
    assert np.allclose(pos, [[0, 1, 4], [1, 1, 4], [2, 1, 4], [2, 2, 4], [2, 3, 4]])
    for k, f in enumerate(fr):
        a = np.radians(90.0 * k / 4)
        assert np.allclose(f.lights[0].direction, [np.cos(a), 0.0, -np.sin(a)])
        assert f.camera.target == s.camera.target and f.materials == s.materials
    still = parse_scene(BASE, source="still")
    assert frames(still)[0] is still and len(frames(still)) == 1


def test_the_camera_path_defaults_to_the_camera():
    fr = frames(_scene("frames = 3\nlight_turn = -30.0"))
    assert all(f.camera.position == (0.0, 1.0, 4.0) for f in fr)


@pytest.mark.parametrize("anim, key", [
    (f"frames = {MAX_FRAMES + 1}", "animation.frames"),
    ("frames = 1", "animation.frames"),
    ("frames = 2.5", "animation.frames"),
    ("camera_path = [[0.0, 1.0, 4.0]]", "animation.frames"),                     # frames is required
    ("frames = 3\nlight_turn = 361.0", "animation.light_turn"),
    ("frames = 3\nlight_turn = nan", "animation.light_turn"),
    ("frames = 3\nspeed = 2", "speed"),
    ("frames = 3\ncamera_path = []", "animation.camera_path"),
    ("frames = 3\ncamera_path = " + str([[0.0, 1.0, 4.0 + k] for k in range(MAX_KEYS + 1)]), "animation.camera_path"),
    ("frames = 3\ncamera_path = [[0.0, 1.0, 4.0], [0.0, 0.0, 0.0]]", "reaches camera.target"),
    ("frames = 3\ncamera_path = [[0.0, 1.0, 4.0], [0.0, 5.0, 0.0]]", "parallel to camera.up"),
    ("frames = 3\ncamera_path = [[0.0, 1.0, 1e9]]", "animation.camera_path"),
])
def test_bad_animations_are_refused_naming_the_key(anim, key):
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        _scene(anim)


def test_the_schema_example_animates():
    s = parse_scene(SCHEMA_EXAMPLE, source="example")
    assert s.animation is not None and len(frames(s)) == s.animation.frames


def test_send_sends_the_frames_in_turn(tmp_path):
    import argparse

    from host.protocol import Cmd, parse, record_bytes
    from host.scene import load_scene, scene_path
    from tools import send

    ap = argparse.ArgumentParser()
    send.add_arguments(ap)
    out = tmp_path / "anim.bin"
    args = ap.parse_args(["--scene", "tin-plane", "--size", "24", "--animate", "--frame", "chip", "--dry-run",
                          str(out)])
    assert send.run(args) == 0
    from host.render import from_triangles, prepare
    scene = load_scene(scene_path("tin-plane"))
    tf = from_triangles(prepare(scene, size=24, preset=args.preset))      # send's preset (the board's by default)
    parsed = parse(out.read_bytes(), record_bytes(tf.params.raster.record))
    cmds = [c for c, _ in parsed.commands]
    n = scene.animation.frames
    assert parsed.error == 0 and cmds.count(Cmd.FRAME_START) == n and cmds.count(Cmd.SWAP) == n
    assert cmds.count(Cmd.TRIANGLE) == n * len(tf.records)
    # the maps once; the cubes again with every frame when the lights turn
    starts = [i for i, c in enumerate(cmds) if c == Cmd.FRAME_START]
    assert Cmd.TEXTURE not in cmds[starts[0]:] and all(Cmd.CUBE in cmds[a:b] for a, b in
                                                       zip([s + 1 for s in starts], starts[1:]))
