"""Fixtures shared by every test module (tests/LAYER/test_*.py); helper functions are in
tests/helpers.py."""
from __future__ import annotations

import os
import warnings

import pytest

from tests.helpers import URDF_DIR, _double_pendulum_urdf

# the once-per-machine compile notice is a second stderr line; tests that count an error's lines
# must not depend on whether the kernel cache was warm (tests/core/test_compile_time.py turns it on)
os.environ.setdefault("PINCLEAR_QUIET_COMPILE", "1")


@pytest.fixture(scope="session")
def double_pendulum_urdf():
    p = _double_pendulum_urdf()
    if p is None or not p.exists():
        pytest.skip("example-robot-data's double_pendulum.urdf is not installed")
    return p


@pytest.fixture(scope="session")
def four_bar():
    import pinclear

    return pinclear.load(URDF_DIR / "four_bar.yaml")


@pytest.fixture(scope="session")
def four_bar_revolute():
    import pinclear

    return pinclear.load(URDF_DIR / "four_bar_revolute.yaml")


@pytest.fixture(scope="session")
def parallelogram():
    import pinclear

    return pinclear.load(URDF_DIR / "parallelogram.yaml")


@pytest.fixture(scope="session")
def sim():
    """pinclear.simulate without the RuntimeWarning a failed run emits (the tests assert status)."""
    import pinclear

    def run(mech, t_end, **kw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return pinclear.simulate(mech, t_end, **kw)

    return run
