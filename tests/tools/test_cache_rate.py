"""``bumpmap cache-rate`` (``tools/cache_rate.py``): the table from a record, bad input refused with exit 2 before
any simulation. (The co-simulation itself is tested in ``cosim/test_rtl_texfetch.py``.)"""

from __future__ import annotations

from tools import cache_rate
from tools.main import main


def fake_record(bursts_equal=True):
    rate = {"0": {"cycles": 100, "fragments_per_clock": 0.5, "mismatches": 0, "bursts_equal": True,
                  "rtl_bytes": 256, "model_bytes": 256, "misses": {"bump_map": 1, "texture": 2}, "of_reference": 1.0},
            "20": {"cycles": 125, "fragments_per_clock": 0.4, "mismatches": 0, "bursts_equal": bursts_equal,
                   "rtl_bytes": 256, "model_bytes": 256, "misses": {"bump_map": 1, "texture": 2},
                   "of_reference": 0.8}}
    return {"result": {"latencies": [0, 20], "fragments": 50, "simulator": "icarus",
                       "cache": {"block": 8, "sets": 32, "ways": 4, "lookup_depth": 128, "misses": 8},
                       "scenes": [{"scene": "s", "size": "8x8", "frame_fragments": 60, "fragments": 50,
                                   "rates": rate}]}}


def test_table_shows_rates_their_share_and_exactness():
    text = cache_rate.table(fake_record())
    row = [line for line in text.splitlines() if line.startswith("| `s`")][0]
    assert "| 1, 2 |" in row and "0.500" in row and "0.400 (80.0 %)" in row and row.rstrip(" |").endswith("yes")
    assert "**no**" in cache_rate.table(fake_record(bursts_equal=False))


def test_bad_input_exits_2(capsys):
    assert main(["cache-rate", "--fragments", "0"]) == 2
    assert main(["cache-rate", "--misses", "2"]) == 2
    assert "misses=2" in capsys.readouterr().err
