"""``bumpmap cache-sweep`` (``tools/cache_sweep.py``): configurations, the choice rule, the sums over both maps
against the model run map by map, the record and the picture on a small scene, bad input."""

from __future__ import annotations

import json

import pytest

from fxmodel.core.paths import ROOT
from fxmodel.units.texcache import Layout, TexCacheParams, simulate
from tools import cache_sweep
from tools.main import main


def test_cache_for_needs_power_of_two_sets():
    p = cache_sweep.cache_for(4, 4, 2)
    assert (p.sets, p.ways, p.size_bytes) == (32, 2, 4096)
    assert cache_sweep.cache_for(4, 4, 3) is None            # 4096 / (64 * 3) is not whole
    assert cache_sweep.cache_for(0.5, 8, 4) is None           # four 256-byte lines are more than 512 bytes
    assert cache_sweep.cache_for(0.5, 8, 1).sets == 2


def test_choose_takes_the_smallest_within_slack():
    def row(size, ways, block, a, b):
        return {"cache": {"size_bytes": size, "ways": ways, "block": block},
                "scenes": {"a": {"sdram_ns_per_fragment": a}, "b": {"sdram_ns_per_fragment": b}}}
    rows = [row(1024, 1, 4, 100.0, 10.0), row(2048, 2, 4, 54.0, 10.0), row(2048, 1, 4, 56.0, 10.0),
            row(4096, 1, 4, 50.0, 9.0)]
    assert cache_sweep.choose(rows, ["a", "b"], 0.10) is rows[1]
    assert cache_sweep.choose(rows, ["a", "b"], 0.0) is rows[3]


@pytest.fixture(scope="module")
def small():
    return cache_sweep.scene_traces("tin-plane", size=48)


def test_sums_are_the_maps_model_runs(small):
    p = TexCacheParams(block=4, sets=4, ways=2)
    res = cache_sweep.run_config(small, p)
    total = 0
    assert list(small["traces"]) == list(cache_sweep.MAPS)
    for m in cache_sweep.MAPS:
        trace = small["traces"][m]
        assert len(trace) == small["fragments"]
        total += simulate(p, Layout(small["surfaces"], 4), trace).totals["memory_bytes"]
    assert res["memory_bytes"] == total
    assert res["bytes_per_fragment"] == total / small["fragments"]


def test_mip_preset_sweeps_the_level_caches():
    """With the ``mip`` preset the color texture's levels are surfaces and its lookups go to an even-level and an
    odd-level cache, one lookup per level needed (more than one lookup a fragment, at most two)."""
    data = cache_sweep.scene_traces(str(ROOT / "tests/scenes/grazing-floor.toml"), size=32, preset="mip")
    assert list(data["traces"]) == ["bump_map", "texture_even", "texture_odd"]
    assert data["levels"]["texture"] > 2 and len(data["surfaces"]) == 1 + data["levels"]["texture"]
    n = data["fragments"]
    tex = len(data["traces"]["texture_even"]) + len(data["traces"]["texture_odd"])
    assert n < tex <= 2 * n
    res = cache_sweep.run_config(data, TexCacheParams(block=4, sets=4, ways=2))
    assert set(res["maps"]) == set(data["traces"]) and res["lookups"] == n + tex


def test_command_writes_record_and_picture(tmp_path, capsys):
    rec, png = tmp_path / "r" / "t.json", tmp_path / "t.png"
    code = main(["cache-sweep", "--scenes", "tin-plane", "--size", "32", "--sizes-kb", "1", "2", "--blocks", "4",
                 "--ways", "1", "2", "--record", str(rec), "--picture", str(png)])
    assert code == 0
    data = json.loads(rec.read_text())
    assert data["machine"]["nproc"] >= 1 and data["command"].startswith("bumpmap cache-sweep")
    assert len(data["sweep"]) == 4
    scene = data["per_scene"]["tin-plane"]
    assert scene["sustained_textures"] <= scene["engine_fragments_per_s"]
    res = scene["result"]
    ns = 1e9 * res["bytes_per_fragment"] / 200e6 + 60 * res["bursts_per_fragment"]
    assert scene["sdram_ns_per_fragment"] == pytest.approx(ns)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.rglob("*.tmp"))
    assert capsys.readouterr().out.strip() == cache_sweep.table(data)


def test_bad_input_is_one_line(capsys):
    assert main(["cache-sweep", "--scenes", "no-such-scene", "--sizes-kb", "1"]) == 2
    assert main(["cache-sweep", "--ways", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(e.startswith("error: ") for e in err)


def test_docs_tables_are_the_records():
    """``docs/texcache.md`` shows the generated pages (``bumpmap docs``), and each is
    :func:`tools.cache_sweep.table` of its committed record (``tests/tools/test_docs.py`` checks they are current)."""
    text = (ROOT / "docs" / "texcache.md").read_text()
    for name in ("texcache", "texcache-mip"):
        assert f'--8<-- "generated/{name}.md"' in text
        record = json.loads((ROOT / "docs" / "records" / f"{name}.json").read_text())
        page = (ROOT / "docs" / "generated" / f"{name}.md").read_text()
        assert page.startswith(cache_sweep.table(record)), f"regenerate docs/generated/{name}.md: bumpmap docs"
