"""``bumpmap engine-rate`` (``tools/engine_rate.py``): the table from a record, bad input refused with exit 2 before
any simulation. (The co-simulation itself is tested in ``cosim/test_rtl_engine_fetch.py``.)"""

from __future__ import annotations

from tools import engine_rate
from tools.main import main


def fake_record(bursts_equal=True, stalled_mismatches=0):
    def run(cpf, mism=0, equal=True):
        return {"cycles": int(cpf * 50), "clocks_per_fragment": cpf, "mismatches": mism, "bursts_equal": equal,
                "rtl_bytes": 256, "model_bytes": 256, "misses": {"bump_map": 1, "texture": 2},
                "raster_clocks": 40}
    rates = {"0": run(1.25), "20": run(1.5, equal=bursts_equal)}
    rates["0"]["rate_of_reference"], rates["20"]["rate_of_reference"] = 1.0, 1.25 / 1.5
    return {"result": {"latencies": [0, 20], "wait_states": 0.2, "simulator": "icarus", "size": None,
                       "cache": {"block": 8, "sets": 32, "ways": 4, "lookup_depth": 128, "misses": 8},
                       "scenes": [{"scene": "s", "size": "8x8", "triangles": 2, "fragments": 50, "rates": rates,
                                   "stalled": {"20": run(2.0, mism=stalled_mismatches)}}]}}


def test_table_shows_clocks_their_share_and_exactness():
    text = engine_rate.table(fake_record())
    row = [line for line in text.splitlines() if line.startswith("| `s`")][0]
    assert "| 1, 2 |" in row and "| 5.12 |" in row and "1.250" in row and "1.500 (83.3 %)" in row
    assert row.rstrip(" |").endswith("yes")
    assert "**no**" in engine_rate.table(fake_record(bursts_equal=False))
    bad = engine_rate.table(fake_record(stalled_mismatches=3))
    assert "| 3 | **no** |" in bad


def test_bad_input_exits_2(capsys):
    assert main(["engine-rate", "--latencies", "-1"]) == 2
    assert main(["engine-rate", "--wait-states", "1.5"]) == 2
    assert main(["engine-rate", "--misses", "2"]) == 2
    assert "misses=2" in capsys.readouterr().err


def test_chosen_cache_is_the_sweeps():
    """The cache ``bumpmap sim --textures external`` and ``engine-rate`` use is the one ``cache-sweep`` chose."""
    import json

    from fxmodel.units.texcache import CHOSEN_CACHE
    from tools.record import RECORDS
    chosen = json.loads((RECORDS / "texcache.json").read_text())["chosen"]["cache"]
    keys = ("block", "sets", "ways", "replacement", "index")
    assert {k: getattr(CHOSEN_CACHE, k) for k in keys} == {k: chosen[k] for k in keys}
