"""Preset files and ``bumpmap fit`` (scene-driven word lengths)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from fxmodel.core.fixed import Fmt
from fxmodel.pipeline.presets import (
    BUILTIN_PRESET_UNITS,
    PRESET_UNITS,
    TOP_KEYS,
    PipelinePreset,
    PresetError,
    load_preset,
    preset_path,
    preset_units,
    write_preset,
)
from host.reference import max_lsb
from host.render import from_triangles, prepare, render
from tools.fit import KNOB_STEPS, fit, knobs_of, units_of
from tools.main import main as bumpmap

SCENE = "scenes/tin-plane.toml"
DEFAULT = BUILTIN_PRESET_UNITS["default"]


@pytest.fixture
def presets(tmp_path, monkeypatch):
    monkeypatch.setenv("FXMODEL_PRESETS", str(tmp_path))
    return tmp_path


def _smaller_units():
    k = knobs_of(DEFAULT)
    return units_of({**k, "coord_bits": 18, "persp_p": 19, "persp_b": 20, "word": 16, "weight_bits": 9,
                     "cube_size": 12}, DEFAULT)


def test_preset_file_round_trips_and_prepare_uses_it(presets):
    units = _smaller_units()
    path = write_preset("small-test", units)
    assert path == presets / "small-test.toml"
    back = load_preset("small-test")
    for key in ("persp", "bump", "reflect", "cube", "shade", "weight_bits", "cube_size"):
        assert back[key] == units[key], key
    assert back["persp"] != DEFAULT["persp"]
    frame = prepare(SCENE, size=32, preset="small-test")
    assert frame.params.persp == units["persp"] and frame.params.cube == units["cube"]
    assert frame.params.reflect.r_bits == 16 and frame.params.texture.weight_bits == 9
    assert frame.params.diffuse.texels.shape == (6, 14, 14, 3)        # 12 texels a face edge, plus the border
    assert frame.stats["cube_size"] == 12
    assert prepare(SCENE, size=32, preset="small-test", cube_size=10).params.diffuse.texels.shape[1] == 12
    assert PRESET_UNITS["small-test"]["bump"] == units["bump"]


def test_prepare_takes_a_units_dict_as_the_preset(presets):
    units = _smaller_units()
    write_preset("small-dict", units)
    by_dict = prepare(SCENE, size=24, preset=units)
    assert by_dict.params == prepare(SCENE, size=24, preset="small-dict").params
    assert (by_dict.codes == prepare(SCENE, size=24, preset="small-dict").codes).all()
    frozen = preset_units(units)                    # a units dict is validated into a frozen PipelinePreset
    assert isinstance(frozen, PipelinePreset) and frozen == units and dict(frozen) == {**dict(frozen), **units}
    assert preset_units(frozen) is frozen and preset_units("default") is DEFAULT
    with pytest.raises(dataclasses.FrozenInstanceError):
        frozen.cube_size = 8
    assert dataclasses.replace(frozen, cube_size=8)["cube_size"] == 8
    with pytest.raises(ValueError, match="cube_size"):             # validated like every parameter object
        dataclasses.replace(frozen, cube_size=0)


@pytest.mark.parametrize("bad, error, match", [
    (3, TypeError, "preset name .str. or a units dict.*not int 3"),
    (("default",), TypeError, "not tuple"),
    ({**DEFAULT, "colour": 1}, ValueError, "preset key='colour': unknown"),
    ({k: v for k, v in DEFAULT.items() if k != "cube"}, ValueError, "needs 'cube'"),
    ({**DEFAULT, "bump": DEFAULT["persp"]}, ValueError, r"type\(preset\['bump'\]\)='PerspParams': must be BumpParams"),
    ({**DEFAULT, "weight_bits": 9.5}, ValueError, "weight_bits.*must be an int"),
    ({**DEFAULT, "cube_size": 0}, ValueError, r"cube_size.*must be an int in 1\.\.1024"),
    ({**DEFAULT, "cube_size": True}, ValueError, "cube_size"),
])
def test_bad_preset_values_are_named(bad, error, match):
    with pytest.raises(error, match=match):
        preset_units(bad)
    with pytest.raises(error, match=match):
        prepare(SCENE, size=8, preset=bad)


def test_missing_fields_keep_default(presets):
    (presets / "part.toml").write_text('[persp]\ncoord_bits = 20\n')
    units = load_preset("part")
    assert units["persp"] == dataclasses.replace(DEFAULT["persp"], coord_bits=20)
    assert units["bump"] == DEFAULT["bump"] and units["weight_bits"] == TOP_KEYS["weight_bits"][0]


def test_a_file_without_diffuse_extra_frac_keeps_its_meaning(presets):
    """The key the built-in default sets (the diffuse blend finer than its texels): a file that leaves it out was
    written before it existed and reads as 0, not the default's; a written preset names it."""
    assert DEFAULT["diffuse_extra_frac"] > 0
    (presets / "old.toml").write_text('[persp]\ncoord_bits = 20\n')
    (presets / "new.toml").write_text('diffuse_extra_frac = 2\n')
    assert load_preset("old")["diffuse_extra_frac"] == 0 and load_preset("new")["diffuse_extra_frac"] == 2
    assert "diffuse_extra_frac = 3" in write_preset("w", {**DEFAULT, "diffuse_extra_frac": 3}).read_text()
    for name, extra in (("old", 0), ("new", 2), ("default", DEFAULT["diffuse_extra_frac"])):
        p = prepare(SCENE, size=16, preset=name).params
        texels = preset_units(name)["shade"].diffuse_fmt
        assert p.diffuse.extra_frac == extra and p.diffuse.channels == (texels,) * 3
        assert p.shade.diffuse_fmt == p.diffuse.out_channels[0] == Fmt(False, texels.int_bits, texels.frac_bits + extra)


@pytest.mark.parametrize("text, key", [
    ('[persp]\ncoord_bits = "wide"\n', "persp.coord_bits"),
    ('[persp.recip]\nm = 99\n', "persp.recip"),
    ('[bump]\nn_fmt = "x2.16"\n', "bump.n_fmt"),
    ('[reflect]\nbogus = 1\n', "reflect.bogus"),
    ('colour = 1\n', "colour"),
    ('weight_bits = 40\n', "weight_bits"),
    ('cube_size = 0\n', "cube_size"),
    ('cube_size = "big"\n', "cube_size"),
    ('diffuse_extra_frac = 9\n', "diffuse_extra_frac"),
    ('[bump]\nrounding = "SIDEWAYS"\n', "bump.rounding"),
])
def test_bad_preset_file_names_file_and_key(presets, text, key):
    (presets / "bad.toml").write_text(text)
    with pytest.raises(PresetError) as err:
        load_preset("bad")
    assert str(presets / "bad.toml") in str(err.value) and key in str(err.value)
    with pytest.raises(ValueError, match="bad.toml"):            # prepare() surfaces it as a ValueError too
        prepare(SCENE, size=16, preset="bad")


def test_not_toml_is_named(presets):
    (presets / "broken.toml").write_text("[persp\n")
    with pytest.raises(PresetError, match="broken.toml.*not valid TOML"):
        load_preset("broken")


def test_unknown_preset_errors_clearly(presets, capsys):
    with pytest.raises(KeyError, match="unknown pipeline preset 'nope'.*nope.toml"):
        PRESET_UNITS["nope"]
    assert bumpmap(["render", SCENE, str(presets / "x.png"), "--size", "16", "--preset", "nope"]) == 2
    assert "unknown pipeline preset 'nope'" in capsys.readouterr().err


def test_fit_small_scene_stays_within_bound_and_shrinks(presets, monkeypatch):
    def no_registering(self, key, value):                # candidates go to prepare() as units dicts
        raise AssertionError(f"fit registered {key!r} in PRESET_UNITS")

    monkeypatch.setattr(type(PRESET_UNITS), "__setitem__", no_registering)
    report = fit(SCENE, max_lsb=3, size=None, name="tiny", progress=False, passes=1,
                 scene_size=48)
    units = load_preset("tiny")
    k = knobs_of(units)
    default = knobs_of(DEFAULT)
    assert set(k) == set(KNOB_STEPS)
    assert all(k[n] <= default[n] for n in k), {n: (k[n], default[n]) for n in k if k[n] > default[n]}
    assert sum(k.values()) < sum(default.values())               # it found something to save
    assert report["hardware"]["fit"]["table_bits"] <= report["hardware"]["default"]["table_bits"]
    # the written preset, drawn on its own as the engine draws it (from triangles, its raster_guard included), is
    # within the bound of reference (a) on every pixel
    assert report["judged_from"] == "triangles"
    frame = prepare(SCENE, size=48, preset="tiny")
    rep = render(frame, model=from_triangles(frame).in_frame_order())
    a, _ = frame.references()
    assert max_lsb(rep["_model_bytes"], a) <= 3
    assert rep["max_lsb_vs_float"] == report["final"]["max_lsb_vs_float"] <= 3
    # and drawn from the front end's fragments, as `bumpmap render` draws it, within the bound too
    assert max_lsb(render(frame)["_model_bytes"], a) <= 3
    # and no more than the bound further from the ideal reference (b) than default (what holds the cube size:
    # reference (a) samples the same reflectance cubes)
    base = prepare(SCENE, size=48)
    base_rep = render(base)
    _, b = frame.references()
    assert max_lsb(rep["_model_bytes"], b) <= max_lsb(base_rep["_model_bytes"], base.references()[1]) + 3
    assert k["cube_size"] >= 4, "the cube size must be held by reference (b)"


def test_a_candidate_is_judged_on_both_frames_the_tools_draw(monkeypatch):
    """From triangles, a candidate is ok only when the frame from the front end's fragments (what `bumpmap render`
    judges) is within the bound of (a) as well: the two quantize the attributes differently, and a preset fitted
    to the engine's frame alone missed `render`'s verdict by an LSB on a strongly bumped scene."""
    import tools.fit as fit_mod
    over = {"triangles": 0, "fragments": 0}

    def fake(frame, triangles):
        lsb = over["triangles" if triangles else "fragments"]
        return {"max_lsb_vs_float_well_conditioned": lsb, "max_lsb_vs_ideal": 0}
    monkeypatch.setattr(fit_mod, "_render", fake)
    monkeypatch.setattr(fit_mod, "_refused", lambda frame: 0)
    cand = fit_mod.Candidate(scene=prepare(SCENE, size=16).scene, knobs=tuple(sorted(knobs_of(DEFAULT).items())),
                             base=tuple(sorted(DEFAULT.items())), sizes=(None,), ref=((0, 0, 0),), max_lsb=2,
                             triangles=True)
    assert fit_mod.check_candidate(cand)["ok"]
    over["fragments"] = 3
    assert not fit_mod.check_candidate(cand)["ok"]
    assert not fit_mod.check_candidate(dataclasses.replace(cand, triangles=False))["ok"]
    over.update(triangles=3, fragments=0)
    assert not fit_mod.check_candidate(cand)["ok"]
    # a scene the scan converter cannot draw is judged from fragments alone: one frame a size
    assert fit_mod.check_candidate(dataclasses.replace(cand, triangles=False)) == {"ok": True, "renders": 1}


def test_fit_cli_writes_preset_and_json(presets, capsys):
    assert bumpmap(["fit", SCENE, "--max-lsb", "4", "--size", "0", "--passes", "1", "--quiet", "--name", "c",
                     "--out", str(presets / "out"), "--scene-size", "32"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["path"] == str(preset_path("c", presets / "out"))
    assert out["final"]["max_lsb_vs_float"] <= 4
    assert {"table_bits", "memory_bits", "dsp", "bram"} <= set(out["hardware"]["savings"])
    assert out["ranges"]["max_abs_uv"] > 0 and 0 < out["ranges"]["min_W"] <= out["ranges"]["max_W"] <= 1


def test_units_of_rejects_invalid_knobs():
    k = knobs_of(DEFAULT)
    assert units_of(k, DEFAULT)["persp"] == DEFAULT["persp"]
    with pytest.raises(ValueError):
        units_of({**k, "persp_b": k["persp_p"] - 1}, DEFAULT)        # table word narrower than the result
    assert Fmt.parse(str(units_of(k, DEFAULT)["bump"].out_fmt)).width == k["word"]


def test_speculative_search_takes_the_same_path_as_the_sequential_one(presets):
    """fit judges up to `speculate` candidates of a knob's descent at once (Dask workers with --jobs); the
    verdicts decide one path, so the preset is the same, only more candidates are rendered."""
    one = fit(SCENE, max_lsb=3, size=None, name="one", progress=False, passes=1, scene_size=24)
    three = fit(SCENE, max_lsb=3, size=None, name="three", progress=False, passes=1, scene_size=24, speculate=3)
    assert three["knobs"] == one["knobs"] and three["final"] == one["final"]
    assert three["renders"] >= one["renders"]


def test_speculation_lists_the_next_candidates_of_a_descent_breadth_first():
    from tools.fit import _descent, _speculate

    known = {}
    assert _speculate(16, 8, 0, known.get, 3) == [8, 0, 12]        # now; after ok (8 - 8); after not ok (16 - 4)
    known.update({8: True, 0: False})
    assert _descent(16, 8, 0, known.get) == (8, 4, 4)              # 8 kept, 0 refused: next 8 - 4
    assert _speculate(5, 8, 2, {}.get, 1) == [3]                   # steps below the minimum are skipped
    assert _descent(2, 1, 2, {}.get)[2] is None                    # nothing left to try
