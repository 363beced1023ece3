"""Job folders of the co-simulation (:mod:`cosim.job`): a label from a scene file never names a path outside the
build folder, and clean-up deletes only folders this process made (docs, "Exit codes and limits")."""

from __future__ import annotations

import pytest

from cosim.job import job_folder, remove_job, safe_label


@pytest.mark.parametrize("label", ["../../etc", "/abs/path", "Fig 9/a", "..", ".hidden", "", None, "a" * 300,
                                   "scene_..%2f..", "ünïcode name"])
def test_a_label_never_leaves_the_jobs_folder(tmp_path, label):
    path = job_folder(tmp_path, label, {"label": label})
    assert path.parent == tmp_path / "jobs" and path.is_dir() and not any(path.iterdir())
    assert "/" not in safe_label(label) and not safe_label(label).startswith(".") and len(safe_label(label)) <= 40
    remove_job(path)
    assert not path.exists()


def test_two_jobs_of_one_definition_get_two_folders(tmp_path):
    a, b = job_folder(tmp_path, "x", {"k": 1}), job_folder(tmp_path, "x", {"k": 1})
    assert a != b and a.name.split("-")[:2] == b.name.split("-")[:2]
    assert job_folder(tmp_path, "x", {"k": 2}).name.split("-")[1] != a.name.split("-")[1]


def test_remove_job_deletes_only_folders_it_made(tmp_path):
    foreign = tmp_path / "jobs" / "x-0123456789abcdef-made_elsewhere"
    foreign.mkdir(parents=True)
    (foreign / "keep.txt").write_text("mine")
    remove_job(foreign)
    assert (foreign / "keep.txt").read_text() == "mine"
