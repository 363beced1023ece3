"""Reference (c), the true image (``host.truth``), and its error measures (``host.metrics``)."""

import json
import math

import numpy as np
import pytest

from fxmodel.core.paths import ROOT
from host.bumpmap import scene_maps
from host.frontend import rasterize
from host.metrics import compare, psnr_db, rmse
from host.render import prepare, render
from host.scene import load_scene
from host.truth import against_truth, bump_float, material_lighting, radiance, true_image

TIN = ROOT / "scenes" / "tin-plane.toml"

SQUARE = """
name = "square"
ambient = [0.2, 0.3, 0.4]
[image]
width = 16
height = 16
background = [0.0, 0.0, 0.0]
[camera]
position = [0.0, 0.0, 1.0]
target = [0.0, 0.0, 0.0]
fov = 90.0
near = 0.1
far = 10.0
[[lights]]
direction = [0.0, 0.0, 1.0]
color = [0.5, 0.25, 0.125]
[[materials]]
name = "flat"
color = [0.5, 0.5, 0.5]
specular = [0.0, 0.0, 0.0]
[[meshes]]
kind = "quad"
material = "flat"
origin = [{x}, {y}, 0.0]
edge_u = [{w}, 0.0, 0.0]
edge_v = [0.0, -{w}, 0.0]
"""


def square(tmp_path, half: float):
    """A square ``[-half, half]^2`` facing the camera: at distance 1 with a 90 degree view, 1/8 unit a pixel."""
    path = tmp_path / "square.toml"
    path.write_text(SQUARE.format(x=-half, y=half, w=2 * half))
    return load_scene(path)


def test_flat_constant_plane_is_its_constant(tmp_path):
    scene = square(tmp_path, 1.5)                         # beyond the view: every pixel fully covered
    truth = true_image(scene, 4)
    expected = 128 * (np.array([0.2, 0.3, 0.4]) + np.array([0.5, 0.25, 0.125]))     # texture byte x D, S = 0
    assert truth.full.all() and not truth.edge.any()
    np.testing.assert_allclose(truth.mean, np.broadcast_to(expected, truth.mean.shape), rtol=0, atol=1e-9)
    assert (truth.image == np.floor(expected + 0.5).astype(np.uint8)).all()


def test_edge_and_full_split_of_an_axis_aligned_square(tmp_path):
    # edges half-way through pixels 3 and 12: 8 x 8 full pixels, a ring of 36 edge pixels, half (corners a
    # quarter) of their samples covered
    scene = square(tmp_path, 0.5625)
    truth = true_image(scene, 8, "grid")
    assert truth.full.sum() == 64 and truth.edge.sum() == 36
    assert truth.full[4:12, 4:12].all()
    cov = truth.coverage
    assert (cov[3, 4:12] == 32).all() and (cov[12, 4:12] == 32).all() and (cov[4:12, 3] == 32).all()
    assert cov[3, 3] == cov[3, 12] == cov[12, 3] == cov[12, 12] == 16
    assert cov.sum() == 64 * 64 + 32 * 32 + 4 * 16
    # on pixel boundaries: no edge pixel at all
    exact = true_image(square(tmp_path, 0.5), 8, "grid")
    assert exact.full.sum() == 64 and exact.edge.sum() == 0
    exact = true_image(square(tmp_path, 0.5), 8)                       # jittered: samples stay in their pixel
    assert exact.full.sum() == 64 and exact.edge.sum() == 0


def test_psnr_and_rmse_of_integer_cases():
    a = np.zeros((2, 2, 3), np.uint8)
    b = a.copy()
    b[0, 0] = 3                                             # 3 of 12 channels differ by 3: MSE 9 / 4
    assert rmse(b, a) == 1.5
    assert psnr_db(b, a) == pytest.approx(20 * math.log10(255 / 1.5), abs=1e-12)
    b[1, 1, 0] = 255                                        # MSE (27 + 255^2) / 12
    assert rmse(b, a) == pytest.approx(math.sqrt((27 + 255 ** 2) / 12), abs=1e-12)
    m = compare(b, a, flip=False)
    assert m["max_lsb"] == 255 and m["pixels"] == 4 and m["psnr_db"] == pytest.approx(
        10 * math.log10(255 ** 2 * 12 / (27 + 255 ** 2)), abs=0.005)
    mask = np.array([[False, True], [True, False]])         # the two equal pixels
    same = compare(b, a, mask)
    assert same["psnr_db"] is None and same["rmse"] == 0 and same["max_lsb"] == 0
    assert same["flip_mean"] > 0                            # FLIP is spatial: neighbours of a difference see it
    json.dumps(same, allow_nan=False)                       # strict JSON: no Infinity
    assert compare(b, b)["flip_mean"] == 0
    empty = compare(b, a, np.zeros((2, 2), bool))
    assert empty["pixels"] == 0 and empty["psnr_db"] is None and empty["flip_mean"] is None


def test_eight_by_eight_is_close_to_sixteen_by_sixteen():
    scene = load_scene(TIN, size=40)
    t8, t16 = true_image(scene, 8), true_image(scene, 16)
    frame = prepare(scene)
    model = frame.image(render(frame, references=False)["_model_bytes"])
    full = t8.full & t16.full
    p8, p16 = compare(model, t8.image, full), compare(model, t16.image, full)
    assert abs(p8["psnr_db"] - p16["psnr_db"]) < 0.5
    assert abs(p8["flip_mean"] - p16["flip_mean"]) < 0.005
    assert compare(t8.image, t16.image, full, flip=False)["max_lsb"] <= 8


def test_against_truth_reports_full_and_edge_and_excludes_pixels(tmp_path):
    scene = square(tmp_path, 0.5625)
    truth = true_image(scene, 4)
    rep, t = against_truth(scene, {"same": truth.image}, 4, flip=False)      # (c) is reproducible
    assert np.array_equal(t.image, truth.image)
    assert rep["full_pixels"] == 64 and rep["edge_pixels"] == 36
    assert rep["same"]["full"]["psnr_db"] is None and rep["same"]["edge"]["max_lsb"] == 0
    rep, _ = against_truth(scene, {"same": truth.image}, 4, exclude=([4, 3], [4, 3]), flip=False)
    assert rep["full_pixels"] == 63 and rep["edge_pixels"] == 35



def test_excluded_pixels_do_not_leak_into_the_flip_of_their_neighbours(tmp_path):
    # A frame drawn from triangles shows another surface than (c) at its depth disagreements (z-fighting of
    # coplanar meshes: stripes over half the frame); those pixels are excluded. FLIP is spatial, so their
    # differences must not count in the kept pixels around them: a frame equal to (c) on every kept pixel has
    # FLIP 0 there (before the fix, 0.5 on a z-fighting scene whose kept pixels were within 6 LSB of (c)).
    scene = square(tmp_path, 1.5)                                           # every pixel fully covered
    truth = true_image(scene, 4)
    other = truth.image.copy()
    other[::2] = 255 - other[::2]                                           # every other row another surface
    ys, xs = np.nonzero(np.broadcast_to((np.arange(16) % 2 == 0)[:, None], (16, 16)))
    rep, _ = against_truth(scene, {"model": other}, 4, exclude=(xs, ys))
    assert rep["full_pixels"] == 128
    assert rep["model"]["full"]["max_lsb"] == 0 and rep["model"]["full"]["flip_mean"] == 0

def test_grid_samples_are_the_frame_rasterized_at_k_times_the_resolution():
    n, k = 96, 4
    scene = load_scene(TIN, size=n)
    truth = true_image(scene, k, "grid")
    fine = scene.with_size(n * k)
    maps = scene_maps(fine)
    f = rasterize(fine, maps)
    rad = radiance({"U": f.s, "s": f.s, "t": f.t, "sc": f.sc, "tc": f.tc, "N": f.N, "E": f.E, "A": f.A},
                   bump=bump_float(maps[0]), texture=maps[0].color,
                   lighting=material_lighting(fine, fine.materials[0]))
    pix = (f.y // k) * n + f.x // k
    cov = np.bincount(pix, minlength=n * n).reshape(n, n)
    mean = np.stack([np.bincount(pix, rad[:, c], minlength=n * n) for c in range(3)], -1).reshape(n, n, 3)
    assert np.array_equal(cov, truth.coverage)
    # the same samples up to vertex snapping (1/256 of a pixel here, of a sample there)
    d = np.abs(mean[truth.full] / (k * k) - truth.mean[truth.full])
    assert truth.full.sum() > 7000 and np.percentile(d, 99) < 0.05 and d.max() < 0.5


def test_summary_of_a_frame_without_fully_covered_pixels_says_nothing_was_compared(tmp_path):
    # A 1 x 200 frame of a sliver, or a 1 x 1 frame whose pixel an edge crosses: no pixel is fully covered, the
    # figures are all None, and the summary said "identical (exact)" for a comparison that never happened.
    from host.images import truth_rows
    scene = square(tmp_path, 0.0625 + 0.03125)                              # 1.5 pixels: edge pixels only
    truth = true_image(scene, 4)
    rep, _ = against_truth(scene, {"model": truth.image, "float": truth.image}, 4, flip=False)
    assert rep["full_pixels"] == 0 and rep["edge_pixels"] > 0 and rep["model"]["full"]["psnr_db"] is None
    rows = dict(truth_rows({"vs_truth": rep}))
    assert "identical" not in rows["model vs truth (c)"] and "not compared" in rows["model vs truth (c)"]
    assert "not compared" in rows["float (a) vs truth (c)"]
