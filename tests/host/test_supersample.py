"""Scene samples at sub-pixel positions, by bands of rows (``host.supersample``), as reference (c) uses them."""

import numpy as np
import pytest

from fxmodel.core.paths import ROOT
from host.bumpmap import scene_maps
from host.scene import load_scene
from host.supersample import offsets, scene_samples
from host.truth import true_image

TIN = ROOT / "scenes" / "tin-plane.toml"


def test_offsets_grid_and_jittered_cells():
    g = offsets(4, "grid", 0, 0, 3)
    assert g.shape == (3, 16, 2) and sorted(set(g[0, :, 0].tolist())) == [32, 96, 160, 224]
    j = offsets(4, "jittered", 5, 7, 3)
    cell = np.stack(np.meshgrid(np.arange(4), np.arange(4)), -1).reshape(-1, 2) * 64
    assert ((j - cell[None] >= 0) & (j - cell[None] < 64)).all()          # one point in each cell
    assert np.array_equal(j, offsets(4, "jittered", 5, 7, 3)) and not np.array_equal(j, offsets(4, "jittered", 5, 8, 3))


def test_jittered_pattern_is_reproducible_and_bands_do_not_matter(tmp_path):
    scene = load_scene(TIN, size=24)
    a, b = true_image(scene, 4, seed=3), true_image(scene, 4, "jittered", seed=3)
    assert np.array_equal(a.mean, b.mean)
    assert not np.array_equal(a.mean, true_image(scene, 4, "jittered", seed=4).mean)
    assert not np.array_equal(a.mean, true_image(scene, 4, "grid").mean)
    with pytest.raises(ValueError, match="power of two"):
        true_image(scene, 6)
    with pytest.raises(ValueError, match="pattern"):
        true_image(scene, 4, "poisson")
    # a row's samples do not depend on the band it is drawn in
    gains = [m.a_gain for m in scene_maps(scene)]
    one = list(scene_samples(scene, gains, 4, "jittered", seed=3, rows=1))
    five = list(scene_samples(scene, gains, 4, "jittered", seed=3, rows=5))
    assert np.array_equal(np.concatenate([c for _, _, c, _ in one]), np.concatenate([c for _, _, c, _ in five]))
    assert np.array_equal(np.concatenate([s.s for *_, s in one]), np.concatenate([s.s for *_, s in five]))
