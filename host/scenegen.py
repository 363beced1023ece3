r"""Random valid scenes, for the scene-level properties of the pipeline (paper sections 3.2-5).

:func:`random_scene` draws one scene file (TOML text, parsed by :func:`host.scene.parse_scene`) from a numpy
random generator: the tests turn a hypothesis-drawn seed into a scene (``tests/host/test_scenegen.py``), and
``bumpmap scenes-stress`` renders a numbered series of them and records the figures the docs quote.

What a scene may hold (each choice independent):

- **camera**: looking at a point near the origin from elevation 1 to 90 degrees over the ``y = 0`` plane (grazing
  to head-on), any azimuth, at a distance from 0.8 to 40 (close and far viewers), vertical field of view 20 to
  90 degrees, ``near`` from 0.005 to 0.5 and ``far`` 10 to 10**5 times ``near`` (near and far planes far apart)
  but at least twice the distance plus 4;
- **meshes** (one to three, overlapping at will, each possibly two-sided): quads (a floor in ``y = 0`` up to 100
  units wide, or an arbitrary parallelogram, 1 to 3 divisions, arbitrary ``uv`` ranges), UV spheres (3 to 16
  segments, 2 to 8 rings) and explicit triangles (one to four) with arbitrary vertex normals, including normals
  nearly opposite each other;
- **lights**: one to four, each along a cube axis, edge or corner (exactly) or in a random direction;
- **material** (one: the pipeline holds one material's maps): constant, checker or graffiti color repeated 1 to 64
  times; a Mexican-hat bump map of any size from 3 to 48 texels a side (odd sizes included), strength up to 8,
  repeated 1 to 64 times, or none.
"""

from __future__ import annotations

import numpy as np

__all__ = ["random_scene", "LIGHT_KINDS"]

#: Light direction kinds: along a cube axis, edge, corner, or random.
LIGHT_KINDS = ("axis", "edge", "corner", "random")


def _vec(v) -> str:
    return "[" + ", ".join(f"{float(x):.6g}" for x in v) + "]"


def _light_direction(rng, kind: str) -> np.ndarray:
    if kind == "random":
        d = rng.normal(size=3)
        return d / max(np.linalg.norm(d), 1e-9)
    n = {"axis": 1, "edge": 2, "corner": 3}[kind]
    d = np.zeros(3)
    axes = rng.choice(3, size=n, replace=False)
    d[axes] = rng.choice([-1.0, 1.0], size=n)
    return d


def _unit(rng) -> np.ndarray:
    d = rng.normal(size=3)
    return d / max(np.linalg.norm(d), 1e-9)


def random_scene(rng: np.random.Generator, *, size: int = 32, name: str = "random") -> str:
    """One random valid scene as TOML text (see the module docstring for what it may hold).

    Parameters
    ----------
    rng : numpy.random.Generator
    size : int
        Image width and height in pixels.
    name : str
        The scene's name.
    """
    lines = [f'name = "{name}"', f"ambient = {_vec(rng.uniform(0, 0.2, 3))}", "",
             "[image]", f"width = {size}", f"height = {size}", ""]
    # camera: grazing to head-on, close to far
    el = np.radians(rng.uniform(1.0, 90.0))
    az = rng.uniform(0, 2 * np.pi)
    dist = float(np.exp(rng.uniform(np.log(0.8), np.log(40.0))))
    target = rng.uniform(-0.5, 0.5, 3) * np.array([1, 0.2, 1])
    pos = target + dist * np.array([np.cos(el) * np.sin(az), np.sin(el), np.cos(el) * np.cos(az)])
    up = (0.0, 1.0, 0.0) if np.degrees(el) < 80 else (np.sin(az + np.pi), 0.0, np.cos(az + np.pi))
    near = float(np.exp(rng.uniform(np.log(0.005), np.log(0.5))))
    far = max(near * float(10 ** rng.uniform(1, 5)), 2 * dist + 4)        # the geometry in range
    lines += ["[camera]", f"position = {_vec(pos)}", f"target = {_vec(target)}", f"up = {_vec(up)}",
              f"fov = {rng.uniform(20, 90):.4g}", f"near = {near:.6g}", f"far = {far:.6g}", ""]
    for _ in range(int(rng.integers(1, 5))):
        kind = LIGHT_KINDS[int(rng.integers(len(LIGHT_KINDS)))]
        lines += ["[[lights]]", f"direction = {_vec(_light_direction(rng, kind))}    # {kind}",
                  f"color = {_vec(rng.uniform(0, 1, 3))}", ""]
    # the material
    lines += ["[[materials]]", 'name = "m"', f"specular = {_vec(rng.uniform(0, 1, 3))}",
              f"shininess = {float(np.exp(rng.uniform(0, np.log(128)))):.4g}", ""]
    color = rng.choice(["rgb", "checker", "graffiti"])
    crep = [int(rng.integers(1, 65)) if rng.random() < 0.5 else int(rng.integers(1, 5)) for _ in range(2)]
    if color == "rgb":
        lines[-1:] = [f"color = {_vec(rng.uniform(0, 1, 3))}", ""]
    elif color == "checker":
        lines += ["[materials.color]", 'procedural = "checker"',
                  f"size = {[int(rng.integers(2, 65)), int(rng.integers(2, 65))]}",
                  f"checks = {[int(rng.integers(1, 9)), int(rng.integers(1, 9))]}",
                  f"colors = [{_vec(rng.uniform(0, 1, 3))}, {_vec(rng.uniform(0, 1, 3))}]", f"repeat = {crep}", ""]
    else:
        lines += ["[materials.color]", 'procedural = "graffiti"',
                  f"size = {[int(rng.integers(16, 129)), int(rng.integers(8, 65))]}",
                  f"seed = {int(rng.integers(0, 1000))}", f"repeat = {crep}", ""]
    if rng.random() < 0.85:
        bsize = [int(rng.integers(3, 49)), int(rng.integers(3, 49))]
        brep = [int(rng.integers(1, 65)) if rng.random() < 0.5 else int(rng.integers(1, 9)) for _ in range(2)]
        lines += ["[materials.bump]", 'procedural = "mexican-hat"', f"size = {bsize}",
                  f"sigma = {rng.uniform(0.5, max(0.6, min(bsize) / 3)):.4g}", f"repeat = {brep}",
                  f"strength = {rng.uniform(0, 8):.4g}", ""]
    # meshes
    for _ in range(int(rng.integers(1, 4))):
        kind = rng.choice(["floor", "quad", "sphere", "triangles"])
        two = "true" if rng.random() < 0.4 else "false"
        uv0 = rng.uniform(-3, 3, 2)
        uv = f"[{_vec(uv0)}, {_vec(uv0 + rng.uniform(0.2, 3, 2))}]"
        if kind == "floor":
            w = float(np.exp(rng.uniform(np.log(1), np.log(100))))
            lines += ["[[meshes]]", 'kind = "quad"', 'material = "m"', f"origin = {_vec([-w / 2, 0, -w / 2])}",
                      f"edge_u = {_vec([w, 0, 0])}", f"edge_v = {_vec([0, 0, w])}", f"uv = {uv}",
                      f"divisions = {[int(rng.integers(1, 4)), int(rng.integers(1, 4))]}", f"two_sided = {two}", ""]
        elif kind == "quad":
            eu = _unit(rng) * rng.uniform(0.5, 6)
            ev = np.cross(_unit(rng), eu)
            ev = ev / max(np.linalg.norm(ev), 1e-9) * rng.uniform(0.5, 6) + 0.3 * eu
            lines += ["[[meshes]]", 'kind = "quad"', 'material = "m"',
                      f"origin = {_vec(rng.uniform(-2, 2, 3) - (eu + ev) / 2)}", f"edge_u = {_vec(eu)}",
                      f"edge_v = {_vec(ev)}", f"uv = {uv}",
                      f"divisions = {[int(rng.integers(1, 4)), int(rng.integers(1, 4))]}", f"two_sided = {two}", ""]
        elif kind == "sphere":
            lines += ["[[meshes]]", 'kind = "sphere"', 'material = "m"', f"center = {_vec(rng.uniform(-1.5, 1.5, 3))}",
                      f"radius = {rng.uniform(0.2, 2):.4g}", f"segments = {int(rng.integers(3, 17))}",
                      f"rings = {int(rng.integers(2, 9))}", f"two_sided = {two}", ""]
        else:
            n = int(rng.integers(1, 5))
            pos = rng.uniform(-2, 2, (3 * n, 3))
            uvs = rng.uniform(-3, 3, (3 * n, 2))
            normals = []
            for _t in range(n):
                base = _unit(rng)
                mode = rng.choice(["random", "opposite", "axis"])
                for _v in range(3):
                    if mode == "random":
                        normals.append(_unit(rng))
                    elif mode == "opposite":                       # nearly opposite vertex normals
                        sign = -1.0 if _v == 1 else 1.0
                        nn = sign * base + rng.normal(scale=0.05, size=3)
                        normals.append(nn / max(np.linalg.norm(nn), 1e-9))
                    else:
                        normals.append(_light_direction(rng, LIGHT_KINDS[int(rng.integers(3))]))
            lines += ["[[meshes]]", 'kind = "triangles"', 'material = "m"',
                      "positions = [" + ", ".join(_vec(p) for p in pos) + "]",
                      "uvs = [" + ", ".join(_vec(p) for p in uvs) + "]",
                      "normals = [" + ", ".join(_vec(p) for p in normals) + "]", f"two_sided = {two}", ""]
    return "\n".join(lines)
