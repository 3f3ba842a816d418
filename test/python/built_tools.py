"""The project's built C++ tools for the Python tests: found in $DQN_DOVS_BIN_DIR (scripts/run_tests.sh points it at
install/lib/dqn_dovs). A missing directory or tool fails the test with the reason; it is never skipped."""

import os
from pathlib import Path

import pytest


def built_tool(name: str) -> Path:
    bin_dir = os.environ.get("DQN_DOVS_BIN_DIR")
    if not bin_dir:
        pytest.fail(f"DQN_DOVS_BIN_DIR is not set: point it at the directory holding the built {name}")
    tool = Path(bin_dir) / name
    if not (tool.is_file() and os.access(tool, os.X_OK)):
        pytest.fail(f"{name} not found or not executable in DQN_DOVS_BIN_DIR={bin_dir}: build the core tools first")
    return tool
