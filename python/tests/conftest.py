"""Shared test support: paths of the repository and its gonio binary."""

import os
import pathlib

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent
# `gonio simulate --material fe-0.115 --seed 1` (the demo's iron sample, simulated).
FE_SWEEP = HERE / "data" / "fe-0.115.csv"


def find_gonio_bin():
    """The gonio command (GONIO_BIN, else the workspace's debug or release build), or None."""
    for p in (os.environ.get("GONIO_BIN"), REPO / "target/debug/gonio", REPO / "target/release/gonio"):
        if p and pathlib.Path(p).is_file():
            return str(p)
    return None


@pytest.fixture
def gonio_bin():
    """The gonio command; skips the test without one."""
    found = find_gonio_bin()
    if found is None:
        pytest.skip("no gonio binary (set GONIO_BIN or build the workspace)")
    return found
