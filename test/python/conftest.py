"""Shared fixtures of the Python tests."""

import os

import pytest


@pytest.fixture
def core():
    """The compiled environment module dqn_dovs_py._core; the test is skipped when it is not built, unless
    DQN_DOVS_REQUIRE_CORE=1 (then it fails)."""
    try:
        from dqn_dovs_py import _core  # noqa: PLC0415
    except ImportError as error:
        if os.environ.get("DQN_DOVS_REQUIRE_CORE") == "1":
            pytest.fail(f"dqn_dovs_py._core is not built: {error}")
        pytest.skip(f"dqn_dovs_py._core is not built: {error}")
    return _core
