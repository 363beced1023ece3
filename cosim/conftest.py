"""Shared fixtures for co-simulation tests: every test here drives an HDL simulator (``SIM``, default icarus)."""

import pytest

from cosim.harness import simulator


def pytest_collection_modifyitems(items):
    for item in items:
        if "/cosim/" in str(item.fspath):
            item.add_marker(pytest.mark.cosim)


@pytest.fixture(scope="session")
def sim():
    return simulator()


def assert_bit_exact(result):
    """Fail with the first mismatching rows (inputs, RTL and model codes) unless every output bit matched."""
    assert result["vectors"] > 0, "no vectors were simulated"
    assert result["mismatches"] == 0, result.describe()
