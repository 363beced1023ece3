"""``bumpmap filtering``: the record of the scenes against the true image and of the filtering study."""

import json

from PIL import Image

from tools.main import main


def test_filtering_writes_a_strict_json_record_and_the_picture(tmp_path, capsys):
    record, picture = tmp_path / "filtering.json", tmp_path / "grazing-floor.png"
    assert main(["filtering", "--scenes", "grazing-floor", "tin-plane", "--size", "32", "--samples", "2",
                 "--check-samples", "4", "--reference-samples", "0", "--pan-frames", "2", "--record", str(record),
                 "--picture", str(picture)]) == 0
    text = record.read_text()
    assert "Infinity" not in text and "NaN" not in text
    rec = json.loads(text)
    assert rec["command"].startswith("bumpmap filtering") and rec["machine"]["nproc"] >= 1
    floor = rec["scenes"]["grazing-floor"]
    assert floor["preset"] == "grazing-floor-wide" and floor["full_pixels"] > 0
    for key in ("model", "float_a", "filtered"):
        assert set(floor[key]["full"]) >= {"psnr_db", "rmse", "max_lsb", "p99_lsb", "flip_mean"}
    rows = rec["study"]["grazing-floor"]["rows"]
    assert sum(r.get("chosen", False) for r in rows) == 1 and "convergence" in rec["study"]["grazing-floor"]
    assert rec["lod"]["grazing-floor"]["color"]["within_bound"] and rec["lod"]["tin-plane"]["bump"]["within_bound"]
    assert rec["flicker"]["frames"] == 2 and rec["flicker"]["flicker_none"] >= 0
    img = Image.open(picture)
    assert img.size[0] > 3 * 32 and not list(tmp_path.glob(".*.tmp"))          # none | ours | truth, no temp left


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert main(["filtering", "--scenes", "no-such-scene", "--record", str(tmp_path / "r.json")]) == 2
    assert main(["filtering", "--samples", "6", "--record", str(tmp_path / "r.json")]) == 2
    assert "powers of two" in capsys.readouterr().err and not (tmp_path / "r.json").exists()
