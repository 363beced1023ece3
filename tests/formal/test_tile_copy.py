"""The tile's clear and copy (``formal/tile_copy.py``, ``board.frame.TileCopy``): proven by k-induction (a walk
begins only after ``quiet`` clocks of quiet, the depth test's contract; each word written once, in order, at its
pixel; a SWAP's copy whole before ``copied`` toggles), with the copy waiting for every write too; its covers
reached; and a read-out one clock slower than the copy expects caught with a counterexample."""

from __future__ import annotations

import pytest

from formal.runner import Job, run_job, tools_missing
from formal.tile_copy import DEPTH, tile_copy_set
from fxmodel.core.paths import build_dir

pytestmark = pytest.mark.skipif(tools_missing() is not None, reason=str(tools_missing()))
OUT = build_dir("formal", "test")


@pytest.mark.parametrize("wait_every_copy", [False, True])
def test_tile_copy_is_proven(wait_every_copy):
    h = tile_copy_set("proof", wait_every_copy=wait_every_copy)
    res = run_job(Job(f"tile_copy_prove_{int(wait_every_copy)}", h.m, h.ports, "prove", DEPTH), OUT)
    assert res.status == "PASS", res
    assert {"walk_begins_quiet", "clear_with_read", "writes_in_order", "write_word_is_its_pixel",
            "copied_after_whole_swap_copy"} <= set(h.asserted)


def test_tile_copy_reaches_a_clear_a_stall_and_a_whole_copy():
    h = tile_copy_set("cover")
    res = run_job(Job("tile_copy_cover", h.m, h.ports, "cover", 40), OUT)
    assert res.status == "PASS" and set(h.covered) == {"swap_copy_reach", "clear_reach", "room_stall_reach"}, res


def test_a_late_readout_word_is_caught():
    h = tile_copy_set("proof", broken_latency=1)
    res = run_job(Job("tile_copy_broken", h.m, h.ports, "bmc", 30), OUT)
    assert res.status == "FAIL" and "write_word_is_its_pixel" in res.failed and res.traces, res
