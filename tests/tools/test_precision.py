"""``bumpmap precision``: the split of the fixed-point error before rounding, the swapped and widened frames."""

import numpy as np
import pytest

from fxmodel.pipeline.presets import preset_units
from tools.main import main
from tools.precision import scene_figures, split


def _terms(rng, k=50):
    return {"t": rng.integers(0, 256, (k, 3)).astype(float), "D": rng.uniform(0, 2, (k, 3)),
            "S": rng.uniform(0, 40, (k, 3))}


def test_split_is_zero_for_equal_terms_and_names_a_constant_bias_of_d():
    rng = np.random.default_rng(1)
    a = _terms(rng)
    zero = split(a, a)
    assert zero["mean"] == [0.0] * 3 and all(v == [0.0] * 3 for k, v in zero.items() if k.startswith("rms"))
    m = {**a, "D": a["D"] - 2.0 ** -11}                       # D low by the same amount everywhere
    s = split(m, a)
    expect = -a["t"].mean(axis=0) * 2.0 ** -11
    assert s["mean"] == pytest.approx(expect, abs=1e-4)
    assert s["rms_texture"] == [0.0] * 3 and s["rms_specular"] == [0.0] * 3
    assert s["rms"] == pytest.approx(s["rms_diffuse"], abs=1e-4)


def test_split_parts_add_up_to_the_difference():
    rng = np.random.default_rng(2)
    a, m = _terms(rng), _terms(rng)
    s = split(m, a)
    total = m["t"] * m["D"] + m["S"] - (a["t"] * a["D"] + a["S"])
    assert s["rms"] == pytest.approx(np.sqrt(np.mean(total ** 2, axis=0)), abs=1e-4)
    # the three parts add up to the total: its RMS is at most the sum of theirs (and not zero here)
    for c in range(3):
        assert 0 < s["rms"][c] <= s["rms_texture"][c] + s["rms_diffuse"][c] + s["rms_specular"][c] + 1e-3


def test_tin_plane_error_is_the_diffuse_factor_and_widening_it_moves_the_model_towards_float():
    fig = scene_figures("tin-plane", samples=1, fracs=(12,), size=48, flip=False)
    b, frames = fig["before_rounding"], fig["frames"]
    assert fig["preset"] == "default" and fig["diffuse_fmt"] == str(preset_units("default")["shade"].diffuse_fmt)
    assert all(d > 4 * s for d, s in zip(b["rms_diffuse"], b["rms_specular"]))
    assert frames["float (a)"]["vs_a_max_lsb"] == 0 and frames["float (a)"]["vs_a_psnr_db"] is None
    model, wide, swap = frames["model"], frames["model, D u2.12"], frames["model, D from (a)"]
    assert model["vs_a_max_lsb"] <= 1 and wide["vs_a_max_lsb"] <= 1
    assert wide["vs_a_psnr_db"] > model["vs_a_psnr_db"] and swap["vs_a_psnr_db"] > model["vs_a_psnr_db"]
    assert wide["bram"] >= model["bram"] and wide["dsp"] == model["dsp"]


def test_a_finer_diffuse_blend_moves_the_tin_plane_towards_float_at_no_block_ram():
    """The ``--extra-frac`` frames: the preset's texels, the diffuse sampler's blend rounded finer; +0 is the blend
    at the texels' format (no better than the shipped default), the block RAM the same."""
    fig = scene_figures("tin-plane", samples=1, fracs=(), size=48, flip=False, extras=(0, 3))
    frames = fig["frames"]
    assert fig["diffuse_extra_frac"] == preset_units("default")["diffuse_extra_frac"]
    coarse, fine = frames["model, D blend +0 bits"], frames["model, D blend +3 bits"]
    assert fine["vs_a_psnr_db"] > coarse["vs_a_psnr_db"]
    assert fine["bram"] == coarse["bram"] and fine["dsp"] == coarse["dsp"]


def test_bad_fraction_bits_are_refused(capsys):
    assert main(["precision", "--scenes", "tin-plane", "--diffuse-frac", "0"]) == 2
    assert "--diffuse-frac 0" in capsys.readouterr().err
    assert main(["precision", "--scenes", "tin-plane", "--extra-frac", "9"]) == 2
    assert "--extra-frac 9" in capsys.readouterr().err
