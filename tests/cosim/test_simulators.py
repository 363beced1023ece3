"""Simulator options written once (:mod:`cosim.simulators`): the harness and the streaming wrapper pass the same
Verilator options, the wrapper adds only what its delays need."""

from __future__ import annotations

import pytest

from cosim.simulators import VERILATOR_ARGS, VERILATOR_TIMING_ARGS, build_args, simulator


def test_build_args():
    assert build_args("icarus") == [] and build_args("icarus", timing=True) == []
    assert build_args("verilator") == list(VERILATOR_ARGS)
    assert build_args("verilator", timing=True) == list(VERILATOR_ARGS) + list(VERILATOR_TIMING_ARGS)
    assert "--timing" not in build_args("verilator")


def test_unknown_simulator_is_refused():
    with pytest.raises(ValueError, match="supported simulators"):
        simulator("modelsim")
