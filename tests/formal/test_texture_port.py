"""The board's texture port (``formal/texture_port.py``): the core's side keeps the AXI4 manager rules with the
caches' reads crossing and the uploads' writes on one port, no beat made up, the flags raised, and its covers are
reached (a line read through to the caches, an upload's write answered)."""

from __future__ import annotations

import pytest

from formal.runner import Job, run_job, tools_missing
from formal.texture_port import DEPTH, texture_port_set
from fxmodel.core.paths import build_dir

pytestmark = pytest.mark.skipif(tools_missing() is not None, reason=str(tools_missing()))
OUT = build_dir("formal", "test")


@pytest.mark.parametrize("kind", ["proof", "bounded"])
def test_the_port_keeps_the_axi4_rules(kind):
    h = texture_port_set(kind)
    res = run_job(Job(f"texture_port_{kind}", h.m, h.ports, "bmc", DEPTH), OUT)
    assert res.status == "PASS" and h.asserted, res


def test_the_port_reaches_its_covers():
    h = texture_port_set("cover")
    res = run_job(Job("texture_port_cover", h.m, h.ports, "cover", 40), OUT)
    assert res.status == "PASS" and set(h.covered) == {"line_read_reach", "write_answered_reach"}, res
