"""Scene files (host.scene): parsing, one clear error per malformed file, mesh generators, shipped scenes."""

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fxmodel.core.paths import SCENES
from host.meshes import quad_mesh, sphere_mesh
from host.scene import SCHEMA_EXAMPLE, SceneError, load_scene, parse_scene, scene_at

SHIPPED = ["tin-plane", "berlin-wall", "sphere"]

BASE = """\
ambient = [0.1, 0.1, 0.1]

[image]
width = 32
height = 24

[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 45.0
near = 0.1
far = 10.0

[[lights]]
direction = [0.0, 0.0, 1.0]
color = [1.0, 1.0, 1.0]

[[materials]]
name = "plain"
color = [0.5, 0.5, 0.5]

[[materials]]
name = "bumpy"
color = [0.5, 0.5, 0.5]

[materials.bump]
procedural = "mexican-hat"
repeat = [2, 2]

[[meshes]]
kind = "quad"
material = "bumpy"
origin = [-1.0, 1.0, 0.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, -2.0, 0.0]

[[meshes]]
kind = "triangles"
material = "plain"
positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
"""


def write(tmp_path, text, name="x.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def error_of(tmp_path, text):
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    return path, str(info.value)


def test_base_scene_parses(tmp_path):
    scene = load_scene(write(tmp_path, BASE))
    assert (scene.width, scene.height) == (32, 24)
    assert [m.name for m in scene.materials] == ["plain", "bumpy"]
    assert scene.meshes[0].material == 1 and scene.meshes[1].material == 0
    assert scene.materials[1].bump.repeat == (2.0, 2.0)
    assert scene.materials[1].bump.kwargs == {"size": (40, 40), "sigma": 5.0}      # defaults filled in
    tris = scene.triangles()
    assert tris.positions.shape == (3, 3, 3) and list(tris.material) == [1, 1, 0]


@pytest.mark.parametrize("old, new, key, message", [
    ('repeat = [2, 2]', 'repeat = "a"', "materials[1].bump.repeat", 'expected 2 numbers, got "a"'),
    ('repeat = [2, 2]', 'repeat = ["a", 1]', "materials[1].bump.repeat", "expected 2 numbers"),
    ('repeat = [2, 2]', 'repeat = [2, 0]', "materials[1].bump.repeat", "must be > 0"),
    ('repeat = [2, 2]', 'repeat = [2, 2]\nstrenght = 1', "materials[1].bump.strenght", "unknown key"),
    ('procedural = "mexican-hat"', 'procedural = "sombrero"', "materials[1].bump.procedural",
     "expected one of"),
    ('repeat = [2, 2]', 'repeat = [2, 2]\ntext = "x"', "materials[1].bump.text", "unknown key for procedural"),
    ('procedural = "mexican-hat"', 'procedural = "mexican-hat"\nfile = "h.png"', "materials[1].bump",
     "exactly one of"),
    ("fov = 45.0", "fov = 180.0", "camera.fov", "must be < 180"),
    ("fov = 45.0", 'fov = "wide"', "camera.fov", 'expected a number, got "wide"'),
    ("far = 10.0", "far = 0.05", "camera.far", "greater than camera.near"),
    ("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 2.0]", "camera.up", "parallel"),
    ("target = [0.0, 0.0, 0.0]", "target = [0.0, 0.0, 3.0]", "camera.target", "must differ"),
    ("width = 32", "width = 0", "image.width", "1 .. 8192"),
    ("width = 32", "width = 32.5", "image.width", "expected an integer"),
    ("height = 24\n", "", "image.height", "missing"),
    ("direction = [0.0, 0.0, 1.0]", "direction = [0.0, 0.0, 0.0]", "lights[0].direction", "zero vector"),
    ("color = [1.0, 1.0, 1.0]", "color = [1.0, -1.0, 1.0]", "lights[0].color", ">= 0"),
    ('name = "bumpy"', 'name = "plain"', "materials[1].name", "already the name of materials[0]"),
    ('name = "plain"\ncolor = [0.5, 0.5, 0.5]', 'name = "plain"\ncolor = [0.5, 0.5, 1.5]', "materials[0].color",
     "<= 1"),
    ('name = "plain"\ncolor = [0.5, 0.5, 0.5]', 'name = "plain"\ncolor = { rgb = [0, 0, 0], procedural = "checker" }',
     "materials[0].color", "exactly one of"),
    ('material = "bumpy"', 'material = "bumpie"', "meshes[0].material", 'no material is named "bumpie"'),
    ('material = "bumpy"', "material = 2", "meshes[0].material", "0 .. 1"),
    ('kind = "quad"', 'kind = "cube"', "meshes[0].kind", "expected one of"),
    ("edge_v = [0.0, -2.0, 0.0]", "edge_v = [4.0, 0.0, 0.0]", "meshes[0].edge_v", "parallel"),
    ("uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]", "uvs = [[0.0, 0.0], [1.0, 0.0]]", "meshes[1].uvs",
     "expected 3 [u, v] pairs"),
    ("positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]",
     "positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]", "meshes[1].positions", "zero area"),
    ("positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]",
     "positions = [[0.0, 0.0, 0.0], [1.0, 0.0], [0.0, 1.0, 0.0]]", "meshes[1].positions[1]",
     "expected 3 numbers"),
    ("uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]",
     "uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]\nindices = [[0, 1, 3]]", "meshes[1].indices[0]", "<= 2"),
    ("uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]",
     "uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]\nnormals = [[0, 0, 1], [0, 0, 0], [0, 0, 1]]",
     "meshes[1].normals[1]", "zero-length normal"),
    ("ambient = [0.1, 0.1, 0.1]", "ambient = [0.1, 0.1, 0.1]\nlihgts = 1", "lihgts", "unknown key"),
])
def test_malformed_file_names_file_and_key(tmp_path, old, new, key, message):
    assert old in BASE
    path, text = error_of(tmp_path, BASE.replace(old, new, 1))
    assert text.startswith(f"{path}: {key}: "), text
    assert message in text, text


def test_error_is_a_value_error_and_one_line(tmp_path):
    path, text = error_of(tmp_path, BASE.replace("fov = 45.0", "fov = -1"))
    assert issubclass(SceneError, ValueError) and "\n" not in text


def test_toml_syntax_error_names_file(tmp_path):
    path, text = error_of(tmp_path, BASE.replace("width = 32", "width = = 32"))
    assert text.startswith(f"{path}: TOML syntax error")
    assert "line" in text


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match=re.escape(str(tmp_path / "nope.toml"))):
        load_scene(tmp_path / "nope.toml")


def test_png_paths_resolve_against_the_scene_folder(tmp_path, monkeypatch):
    sub = tmp_path / "scn"
    (sub / "maps").mkdir(parents=True)
    heights = (np.arange(12 * 8).reshape(8, 12) * 2).astype(np.uint8)
    Image.fromarray(heights, "L").save(sub / "maps" / "h.png")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(sub / "maps" / "c.png")
    text = BASE.replace('procedural = "mexican-hat"', 'file = "maps/h.png"').replace(
        'name = "plain"\ncolor = [0.5, 0.5, 0.5]', 'name = "plain"\ncolor = { file = "maps/c.png" }')
    path = write(sub, text)
    monkeypatch.chdir(tmp_path)                     # the working directory must not matter
    scene = load_scene(Path("scn") / "x.toml")
    assert scene.materials[1].bump.path == (sub / "maps" / "h.png").resolve()
    assert scene.materials[0].color.path == (sub / "maps" / "c.png").resolve()
    from host.bumpmap import height_field
    assert np.array_equal(height_field(scene.materials[1].bump), heights / 255.0)
    # missing and non-PNG files: one error naming the key
    (sub / "maps" / "j.jpg").write_bytes(b"")
    Image.fromarray(heights, "L").save(sub / "maps" / "j.jpg", format="JPEG")
    for name, msg in (("maps/none.png", "not found"), ("maps/j.jpg", "expected a PNG")):
        path.write_text(text.replace("maps/h.png", name))
        with pytest.raises(SceneError) as info:
            load_scene(path)
        assert str(info.value).startswith(f"{path}: materials[1].bump.file: ") and msg in str(info.value)


def test_schema_example_is_a_valid_scene():
    scene = parse_scene(SCHEMA_EXAMPLE, source="example")
    assert [m.kind for m in scene.meshes] == ["quad", "sphere", "triangles"]
    assert scene.materials[1].color.procedural == "graffiti"
    assert scene.materials[1].bump.procedural == "chiselled-text"
    assert abs(np.linalg.norm(scene.lights[0].direction) - 1.0) < 1e-15


def test_parsed_scene_is_frozen(tmp_path):
    scene = load_scene(write(tmp_path, BASE))
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.width = 5
    with pytest.raises(ValueError):
        scene.meshes[0].positions[0, 0, 0] = 1.0


def test_size_override(tmp_path):
    path = write(tmp_path, BASE)
    assert (load_scene(path, size=(64, 64)).width, load_scene(path, size=(64, 64)).height) == (64, 64)
    s = load_scene(path, size=64)
    assert (s.width, s.height) == (64, 48)                          # keeps the aspect ratio
    with pytest.raises(ValueError):
        s.with_size(0)


@pytest.mark.parametrize("size, dims", [(64, (64, 48)), ((64, 64), (64, 64)), ((40, 10), (40, 10)), (None, (32, 24))])
def test_scene_at_size_means_the_same_for_a_path_and_a_loaded_scene(tmp_path, size, dims):
    """``scene_at`` (what ``prepare`` draws) sizes a loaded scene as ``load_scene`` sizes its file: an int is a
    width keeping the aspect ratio (32 x 24 here), not a square."""
    path = write(tmp_path, BASE)
    by_path, loaded = scene_at(path, size), scene_at(load_scene(path), size)
    assert (by_path.width, by_path.height) == (loaded.width, loaded.height) == dims


def test_quad_mesh_winding_and_uv():
    o, eu, ev = np.array([1.0, 2.0, 3.0]), np.array([2.0, 0.0, 0.5]), np.array([0.0, -1.5, 0.0])
    P, N, UV = quad_mesh(o, eu, ev, ((0.0, 0.0), (3.0, 2.0)), (3, 2))
    assert P.shape == (12, 3, 3)
    n = np.cross(ev, eu) / np.linalg.norm(np.cross(ev, eu))
    face = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    assert np.all(face @ n > 0)                                           # counter-clockwise about the front
    assert np.allclose(N, n)
    # every vertex satisfies P = o + (u / 3) eu + (v / 2) ev: the uv mapping is the stated one
    assert np.allclose(P, o + UV[..., :1] / 3.0 * eu + UV[..., 1:] / 2.0 * ev)
    assert np.isclose(np.linalg.norm(face, axis=1).sum() / 2, np.linalg.norm(np.cross(eu, ev)))  # they tile it


def test_sphere_mesh():
    c = np.array([0.5, -1.0, 2.0])
    P, N, UV = sphere_mesh(c, 2.0, segments=9, rings=5)
    assert P.shape == (2 * 9 * 4, 3, 3)
    assert np.allclose(np.linalg.norm(N, axis=-1), 1.0, atol=1e-15)
    assert np.allclose(P, c + 2.0 * N)
    face = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    assert np.all(np.einsum("ti,ti->t", face, P.mean(axis=1) - c) > 0)   # counter-clockwise from outside
    assert UV[..., 0].min() == 0.0 and UV[..., 0].max() == 1.0 and UV[..., 1].min() == 0.0 and UV[..., 1].max() == 1.0
    # u = 0 is +z, u increases toward +x; v = 0 is the +y pole
    eq = np.isclose(UV[..., 1], 0.4)
    u, n = UV[..., 0][eq], N[eq]
    assert np.allclose(n[:, 0], np.sin(2 * np.pi * u) * np.sin(0.4 * np.pi))
    assert np.allclose(n[:, 2], np.cos(2 * np.pi * u) * np.sin(0.4 * np.pi))
    assert np.all(N[UV[..., 1] == 0.0] == [0.0, 1.0, 0.0]) and np.all(N[UV[..., 1] == 1.0] == [0.0, -1.0, 0.0])


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scenes_load(name):
    scene = load_scene(SCENES / f"{name}.toml")
    assert scene.name == name
    assert 64 <= scene.width <= 512 and 64 <= scene.height <= 512
    small = load_scene(SCENES / f"{name}.toml", size=(64, 64))
    assert (small.width, small.height) == (64, 64)
    assert all(m.bump is not None for m in scene.materials[:1])


def test_docs_quote_the_schema_example():
    assert SCHEMA_EXAMPLE in (SCENES.parent / "docs" / "generated" / "scene-schema.md").read_text()


@pytest.mark.parametrize("mesh", [
    lambda: sphere_mesh([0.1, 0.2, 0.3], 1.3, segments=7, rings=5),
    lambda: quad_mesh([0.1, 0.2, 0.3], [0.7, 0.1, 0.0], [0.0, 0.3, 0.9], divisions=(7, 3))])
def test_generated_meshes_share_edges_bit_for_bit(mesh):
    """Every interior edge is used by exactly two triangles, once in each direction, with bit-identical end
    points: no cracks for the rasterizer, consistent winding (a closed sphere has no boundary at all)."""
    P = mesh()[0]
    directed = {}
    for tri in P:
        for k in range(3):
            e = (tuple(tri[k]), tuple(tri[(k + 1) % 3]))
            directed[e] = directed.get(e, 0) + 1
    assert max(directed.values()) == 1                                         # consistent orientation
    boundary = [e for e in directed if (e[1], e[0]) not in directed]
    if len(P) == 2 * 7 * 4:                                                    # the sphere: closed
        assert boundary == []
    else:                                                                      # the quad: its outline only
        assert len(boundary) == 2 * (7 + 3)


def test_triangle_budget_is_checked_before_each_generator_runs(tmp_path, monkeypatch):
    """The scene-wide triangle budget holds before a mesh is built: many meshes, each within the budget alone,
    are refused at the first one beyond it, not after all of them were generated (6 meshes of 2^20 triangles
    took 4 s and 1.4 GB before their sum was checked; a file of 100 lines, 60 of them, exhausts the memory). Here
    the budget is 100 triangles."""
    import host.scene as scene_module
    built = []
    real = scene_module.quad_mesh
    monkeypatch.setattr(scene_module, "MAX_TRIANGLES", 100)
    monkeypatch.setattr(scene_module, "quad_mesh", lambda *a, **k: built.append(1) or real(*a, **k))
    quad = ('\n[[meshes]]\nkind = "quad"\nmaterial = "plain"\norigin = [0.0, 0.0, 0.0]\n'
            'edge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, -1.0, 0.0]\ndivisions = [7, 7]\n')        # 98 triangles
    head = BASE.split("[[meshes]]")[0]
    assert len(load_scene(write(tmp_path, head + quad)).triangles().positions) == 98
    built.clear()
    path, text = error_of(tmp_path, head + quad * 5)
    assert text.startswith(f"{path}: meshes[1].divisions: makes 98 triangles after the 98 of the meshes before "
                           "it, more than the 100 a scene may hold"), text
    assert len(built) == 1
    path, text = error_of(tmp_path, head + quad + quad.replace("kind = \"quad\"", "kind = \"sphere\"")
                          .replace("origin = [0.0, 0.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, -1.0, 0.0]\n"
                                   "divisions = [7, 7]", "center = [0.0, 0.0, 0.0]\nradius = 1.0\nsegments = 3\n"
                                   "rings = 2"))                  # 6 triangles: 104 in all
    assert "meshes[1].segments: makes 6 triangles after the 98" in text, text


@pytest.mark.parametrize("where", ["color", "bump"])
def test_png_maps_hold_the_map_edge_limit(tmp_path, where):
    """A PNG map is held to the map edge limit (4096 texels) like a procedural one, from its header, before it
    is decoded: a 35 kB PNG of 5000 x 5000 took 48 s and 2.4 GB to draw a 16 x 16 frame, and a larger one
    exhausts the memory."""
    Image.new("L", (4097, 1)).save(tmp_path / "wide.png")
    Image.new("L", (4096, 2)).save(tmp_path / "ok.png")
    table = ('[materials.bump]\nfile = "{}"\n' if where == "bump" else '[materials.color]\nfile = "{}"\n')
    text = BASE.replace('[[materials]]\nname = "bumpy"\ncolor = [0.5, 0.5, 0.5]\n',
                        '[[materials]]\nname = "bumpy"\n' + ("color = [0.5, 0.5, 0.5]\n" if where == "bump" else ""))
    text = text.replace('[materials.bump]\nprocedural = "mexican-hat"\nrepeat = [2, 2]\n',
                        table.format("ok.png"))
    load_scene(write(tmp_path, text))
    path, err = error_of(tmp_path, text.replace("ok.png", "wide.png"))
    assert err == (f'{path}: materials[1].{where}.file: "wide.png" is 4097 x 1 pixels, more than the 4096 texels '
                   "a map edge may have"), err


def test_a_deeply_nested_bad_value_is_shown_short(tmp_path):
    """The message shows a bad value nested deeper than json.dumps recurses (where tomllib still reads it) in a
    few characters, not a ``RecursionError``."""
    from host.scene_reader import show_value
    deep = []
    for _ in range(5000):
        deep = [deep]
    assert len(show_value(deep)) <= 60
    path, text = error_of(tmp_path, BASE.replace("repeat = [2, 2]", "repeat = " + "[" * 200 + "]" * 200))
    assert text.startswith(f"{path}: materials[1].bump.repeat: expected 2 numbers"), text


def test_resource_caps_lights_texels_text(tmp_path):
    """Caps that keep the host's work on one small file bounded (``host.scene_types``): 20,000 lights (a 2 MB
    file) took 45 s at the default cube, more at a larger one; the maps of every material are built (three
    hidden 2048^2 materials took 10 s, dozens of 4096^2 ones exhaust the memory); a chiselled text of 2 million
    characters ended in Pillow's 'too many characters in string', naming no file or key."""
    one = "[[lights]]\ndirection = [0.0, 0.0, 1.0]\ncolor = [1.0, 1.0, 1.0]\n\n"
    assert len(load_scene(write(tmp_path, BASE.replace(one, one * 32))).lights) == 32
    path, text = error_of(tmp_path, BASE.replace(one, one * 33))
    assert text == f"{path}: lights: 33 lights, more than the 32 a scene may have", text

    hat = '[materials.bump]\nprocedural = "mexican-hat"\nrepeat = [2, 2]\n'
    big = hat + "size = [4096, 4096]\nsigma = 5.0\n"
    plain = 'name = "plain"\ncolor = [0.5, 0.5, 0.5]\n'
    two = BASE.replace(hat, big).replace(plain, plain + big)        # two full-size bump maps, constant colors
    assert load_scene(write(tmp_path, two)).materials[1].bump.kwargs["size"] == (4096, 4096)
    path, text = error_of(tmp_path, two.replace(plain, 'name = "plain"\ncolor = { procedural = "checker" }\n'))
    assert text.startswith(f"{path}: materials[1]: its maps bring the scene's maps to 33,558,528 texels, more "
                           "than the 33,554,432"), text                    # + the checker's 64 x 64
    Image.new("RGB", (4096, 1)).save(tmp_path / "c.png")              # a PNG counts by its header's size
    path, text = error_of(tmp_path, two.replace(plain, 'name = "plain"\ncolor = { file = "c.png" }\n'))
    assert text.startswith(f"{path}: materials[1]: its maps bring the scene's maps to 33,558,528 texels"), text

    chisel = '[materials.bump]\nprocedural = "chiselled-text"\nsize = [64, 32]\ntext = "{}"\n'
    assert load_scene(write(tmp_path, BASE.replace(hat, chisel.format("x" * 4096)))).materials[1].bump
    path, text = error_of(tmp_path, BASE.replace(hat, chisel.format("x" * 2_000_000)))
    assert text == (f"{path}: materials[1].bump.text: 2,000,000 characters, more than the 4096 a chiselled text "
                    "may have"), text


def test_image_pixels_are_capped_in_the_file_and_in_an_override(tmp_path):
    """An 8192 x 8192 image (each edge within 8192) needed some 55 GB and an hour for a covered frame and was
    killed for memory with no message; width x height is capped at 2048 x 2048, an edge may still be 8192."""
    sized = BASE.replace("width = 32\nheight = 24", "width = {}\nheight = {}")
    assert load_scene(write(tmp_path, sized.format(8192, 512))).width == 8192
    scene = load_scene(write(tmp_path, sized.format(2048, 2048)))
    path, text = error_of(tmp_path, sized.format(8192, 8192))
    assert text == (f"{path}: image: 8192 x 8192 is 67,108,864 pixels, more than the 4,194,304 (2048 x 2048) an "
                    "image may have"), text
    assert scene.with_size(64).height == 64
    with pytest.raises(ValueError, match="at 4096 x 4096, 16,777,216 pixels, more than the 4,194,304"):
        scene.with_size(4096)
    with pytest.raises(ValueError, match="more than the 4,194,304"):
        load_scene(write(tmp_path, BASE), size=(8192, 8192))
    # a file declaring more is drawn at a size given that has fewer (its own declares the aspect ratio alone)
    big = write(tmp_path, sized.format(8192, 4096))
    assert (load_scene(big, size=512).width, load_scene(big, size=512).height) == (512, 256)
    assert load_scene(big, size=(100, 30)).height == 30
    with pytest.raises(ValueError, match="at 4096 x 2048, 8,388,608 pixels, more than the 4,194,304"):
        load_scene(big, size=4096)


def test_a_png_whose_pixels_do_not_decode_is_refused_by_key(tmp_path):
    """A PNG with good chunk checksums but a broken deflate stream passed the load-time check (``verify``) and
    stopped the render later with 'error: broken data stream when reading image file', naming no file or key."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    header = chunk(b"IHDR", struct.pack(">IIBBBBB", 8, 8, 8, 0, 0, 0, 0))
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n" + header + chunk(b"IDAT", b"\x78\x9c" + b"\xff" * 50)
                                       + chunk(b"IEND", b""))
    path, text = error_of(tmp_path, BASE.replace('procedural = "mexican-hat"\nrepeat = [2, 2]', 'file = "bad.png"'))
    assert text.startswith(f'{path}: materials[1].bump.file: cannot read "bad.png" as an image'), text
    assert "broken data stream" in text
