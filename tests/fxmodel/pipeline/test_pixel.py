"""The pixel pipeline model (fxmodel.pipeline.pixel) and scene rendering (host.render, host.reference)."""

import dataclasses
import json
import re
import warnings

import numpy as np
import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.core.paths import ROOT
from fxmodel.core.unit import preset
from fxmodel.pipeline.pixel import FLAG_BITS
from host.reference import max_lsb, psnr, sample_float
from host.render import prepare, render
from host.shipped import scene_preset
from tools.main import main

SCENES = sorted((ROOT / "scenes").glob("*.toml"))
P = preset("pipeline")


def test_pipeline_is_the_composition_of_its_units():
    rng = np.random.default_rng(8)
    frags = P.random_inputs(rng, 500)
    tr = P.trace(frags)
    names = [p.name for p in P.inputs]
    col = {n: frags[:, i] for i, n in enumerate(names)}
    st = P.persp.compute(np.stack([col[p.name] for p in P.persp.inputs], 1))
    npr = P.bump.compute(np.column_stack([frags[:, names.index("Nx"):names.index("Nx") + 3],
                                          P.bump_map.compute(st[:, 0:2]),
                                          np.stack([col[p.name] for p in P.bump.inputs[5:]], 1)]))
    assert np.array_equal(tr["N'"], npr)
    r = P.reflect.compute(np.column_stack([npr[:, :3], np.stack([col["Ex"], col["Ey"], col["Ez"]], 1)]))
    sp = P.specular.compute(P.cube.compute(r[:, :3])[:, :3])
    d = P.diffuse.compute(P.cube.compute(npr[:, :3])[:, :3])
    out = P.shade.compute(np.column_stack([P.texture.compute(st[:, 2:4]), d, sp]))
    assert np.array_equal(tr["rgb"], out[:, :3])
    assert np.array_equal(P.compute(frags)[:, :3], out[:, :3])


def test_flags_report_saturation_and_degenerate_vectors():
    rng = np.random.default_rng(9)
    frags = P.random_inputs(rng, 3000)
    flags = P.compute(frags)[:, 3]
    assert ((flags >> FLAG_BITS["bump_saturated"]) & 1).any()
    zero = frags.copy()
    names = [p.name for p in P.inputs]
    for c in "xyz":
        zero[:, names.index(f"E{c}")] = 0
    assert np.all((P.compute(zero[:50])[:, 3] >> FLAG_BITS["degenerate"]) & 1)


def test_mismatched_stage_formats_name_the_stage():
    with pytest.raises(ValueError, match=r"^reflect\.n_fmt=Fmt"):
        dataclasses.replace(P, reflect=dataclasses.replace(P.reflect, n_fmt=Fmt(True, 2, 14)))
    with pytest.raises(ValueError, match=r"^persp\.color=False: must be True"):
        dataclasses.replace(P, persp=dataclasses.replace(P.persp, color=False))


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_shipped_scenes_within_one_lsb_of_the_float_reference(path):
    frame = prepare(path, size=64, preset=scene_preset(path))
    report = render(frame)
    model = report.pop("_model_bytes")
    assert report["pixels"] > 500 and len(model) == report["pixels"]
    assert report["max_lsb_vs_float"] <= 1, report
    assert report["psnr_db_vs_float"] >= 50 and report["psnr_db_vs_ideal"] >= 35
    assert not frame.stats["clamped_fragment_inputs"]


def test_render_command_writes_png_and_report(tmp_path, capsys):
    out = tmp_path / "x.png"
    assert main(["render", str(ROOT / "scenes" / "tin-plane.toml"), str(out), "--size", "40"]) == 0
    summary = capsys.readouterr().out                        # the short summary by default
    assert re.search(r"verdict\s+pass", summary) and str(out) in summary and "{" not in summary
    assert re.search(r"model vs truth \(c\)\s+[\d.]+ dB, FLIP", summary)      # reference (c) by default
    assert main(["render", str(ROOT / "scenes" / "tin-plane.toml"), str(out), "--size", "40", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    from PIL import Image
    img = np.asarray(Image.open(out))
    assert img.shape == (40, 40, 3) and rep["pixels"] > 0 and rep["verdict"]["pass"]


def test_bad_scene_is_one_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[image]\nwidth = 'wide'\n")
    assert main(["render", str(bad), str(tmp_path / "x.png")]) == 2           # bad input: exit 2, one line
    err = capsys.readouterr().err
    assert "bad.toml" in err and err.count("\n") == 1
    assert not (tmp_path / "x.png").exists()


def test_reference_metrics_and_float_sampler():
    a = np.array([[0, 10, 254]], dtype=np.uint8)
    assert psnr(a, a) == float("inf") and max_lsb(a, a + 1) == 1
    assert abs(psnr(a, a + 1) - 48.13) < 0.01
    empty = np.zeros((0, 3), dtype=np.uint8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no "mean of empty slice" on a frame with no covered pixel
        assert psnr(empty, empty) == float("inf") and max_lsb(empty, empty) == 0
    tex = np.arange(12, dtype=float).reshape(1, 2, 3, 2)
    # the centre of texel (1, 0) returns it exactly; repeat wraps
    got = sample_float(tex, np.array([0, 0]), np.array([0.5, 1.5]), np.array([0.25, 0.25]), "bilinear", "repeat")
    assert np.allclose(got, [tex[0, 0, 1], tex[0, 0, 1]])


def _mip_pipeline(**top):
    from fxmodel.pipeline.lighting import Light, Lighting
    from fxmodel.pipeline.pixel import PipelineParams
    from fxmodel.pipeline.presets import BUILTIN_PRESET_UNITS
    base = preset("pipeline")
    tex = np.random.default_rng(4).integers(0, 256, size=(12, 10, 3))
    lighting = Lighting(lights=(Light((0.0, 0.5, 1.0), (1.0, 1.0, 1.0)),), ambient=(0.1, 0.1, 0.1),
                        specular=(0.5, 0.5, 0.5), shininess=10.0)
    units = {**BUILTIN_PRESET_UNITS["default"], **top}
    return PipelineParams.assemble(bump_codes=base.bump_map.texels.codes[0], texture_bytes=tex, lighting=lighting,
                                   cube_face=8, preset=units)[0]


def test_mip_mapping_is_off_by_default_and_composes_lod_and_trilinear():
    """Off by default (no LOD unit, no increments among the inputs); with mip_levels the color texture is sampled
    trilinearly at the LOD unit's level of the fragment's Uc, Vc, W and the triangle's increments."""
    from fxmodel.pipeline.pixel import LOD_INPUTS
    off = _mip_pipeline()
    assert off.lod is None and off.texture.filter == "bilinear"
    assert not {p.name for p in off.inputs} & set(LOD_INPUTS)
    on = _mip_pipeline(mip_levels=16, lod_bias=-128, level_bits=6)
    assert on.lod.bias == -128 and on.texture.level_bits == 6 and on.texture.level_sizes[-1] == (1, 1)
    assert [p.name for p in on.inputs][-6:] == list(LOD_INPUTS)
    codes = np.concatenate([on.hard_cases(), on.random_inputs(np.random.default_rng(2), 300)])
    tr = on.trace(codes)
    col = {p.name: codes[:, i] for i, p in enumerate(on.inputs)}
    lod, _ = on.lod.compute(*(col[n] for n in ("Uc", "Vc", "W", *LOD_INPUTS)))
    assert np.array_equal(tr["lod"], lod)
    sc, tc = tr["st"][:, 2], tr["st"][:, 3]
    assert np.array_equal(tr["tex"], on.texture.compute(np.stack([sc, tc, lod], 1)))
    assert len(np.unique(np.clip(lod >> 8, 0, on.texture.levels - 1))) > 1       # several levels reached
    two = _mip_pipeline(mip_levels=2)
    assert two.texture.levels == 2


def test_mip_mapping_mismatch_names_the_field():
    on = _mip_pipeline(mip_levels=16)
    with pytest.raises(ValueError, match="lod.size"):
        dataclasses.replace(on, lod=dataclasses.replace(on.lod, size=(4, 4)))
    with pytest.raises(ValueError, match="texture.filter"):
        dataclasses.replace(on, lod=None)


@pytest.mark.parametrize("blend_frac", [0, 9])
def test_grazing_floor_with_mip_mapping_within_one_lsb_of_its_float_reference(blend_frac):
    """The grazing floor with MIP mapping (preset grazing-floor-mip, a smaller frame; its trilinear blends exact or
    narrowed, ``blend_frac``): every well-conditioned pixel within 1 LSB of reference (a) drawing the same pyramid
    at the LOD unit's level, the level within its bound on every fragment, several levels in use, and the frame
    differs from the unfiltered one."""
    from fxmodel.pipeline.presets import preset_units
    from tools.mip import lod_worst
    path = ROOT / "scenes" / "grazing-floor.toml"
    frame = prepare(path, size=128, preset={**preset_units("grazing-floor-mip"), "blend_frac": blend_frac})
    assert frame.params.texture.blend_frac == blend_frac
    assert frame.params.lod is not None and frame.params.lod.bias == -128
    report = render(frame)
    assert report["max_lsb_vs_float_well_conditioned"] <= 1
    lod = lod_worst(frame)
    assert lod["within_bound"] and lod["level_range"][1] - max(lod["level_range"][0], 0) > 3
    plain = render(prepare(path, size=128, preset="grazing-floor-wide"), references=False)
    assert (plain["_model_bytes"] != report["_model_bytes"]).any()
