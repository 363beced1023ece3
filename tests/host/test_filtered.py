"""The filtered float reference (``host.filtered``): no filtering is reference (a); the lobe widening."""

import numpy as np

from fxmodel.core.paths import ROOT
from host.filtered import Choice, lobe_widening, lookups_per_pixel, render_filtered
from host.render import prepare

TIN = ROOT / "scenes" / "tin-plane.toml"


def test_no_filtering_is_reference_a_and_filtering_changes_the_frame():
    frame = prepare(TIN, size=48)
    a, _ = frame.references()
    assert np.array_equal(render_filtered(frame, Choice()), a)
    lean = render_filtered(frame, Choice(color="trilinear", bump="lean"))
    assert not np.array_equal(lean, a)


def test_lobe_widening_keeps_the_lobe_without_variance_and_halves_it_at_one_over_s():
    n = np.array([[0.0, 0.0, 1.0]])
    E = np.array([[0.0, 0.0, 1.0]])                      # head-on: R moves by twice the normal's tilt both ways
    A = np.array([[[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]])
    s2, energy = lobe_widening(n, E, A, np.zeros((1, 2, 2)), 40.0)
    assert s2[0] == 40.0 and energy[0] == 1.0
    # slope variance v per axis: the reflection's per-axis variance 4 v; 1 / s' = 1 / s + 4 v
    v = 1 / 160
    s2, energy = lobe_widening(n, E, A, np.eye(2)[None] * v, 40.0)
    assert np.isclose(s2[0], 20.0) and np.isclose(energy[0], 21 / 41)


def test_lookups_per_pixel_of_each_mode():
    frame = prepare(TIN, size=32)
    assert lookups_per_pixel(frame, Choice()) == {"color": 1.0, "bump": 1.0}
    assert lookups_per_pixel(frame, Choice(color="trilinear", bump="lean")) == {"color": 2.0, "bump": 2.0}
    aniso = lookups_per_pixel(frame, Choice(color="anisotropic", bump="lean", bump_footprint="anisotropic", taps=4))
    assert 2.0 <= aniso["bump"] <= 8.0
