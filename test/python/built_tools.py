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


def check_eval_needs_the_state_flags(model: str, flags: list[str], refusal: str, out_dir: Path) -> None:
    """dqn_dovs_eval refuses the network `model` on the default state, naming `refusal`, and runs it with `flags`
    (what compare_models.state_flags gives for it): a network trained on another state encoding or layout is never
    run on states it was not trained on."""
    import subprocess  # noqa: PLC0415

    common = [str(built_tool("dqn_dovs_eval")), "--methods", "dqn_dovs", "--generate", "5", "--obstacles", "4",
              "--episodes", "2", "--threads", "1", "--model", model]
    refused = subprocess.run(common + ["--out", str(out_dir / "default_state")], capture_output=True, text=True)
    assert refused.returncode != 0
    assert refusal in refused.stdout + refused.stderr
    ran = subprocess.run(common + flags + ["--out", str(out_dir / "its_state")], capture_output=True, text=True)
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert (out_dir / "its_state" / "results.csv").is_file()


def check_evaluates_like(reference: str, model: str, flags: list[str], out_dir: Path) -> None:
    """The network `model`, run by dqn_dovs_eval with `flags` (its state layout), drives the same generated episodes
    exactly as the network `reference` on the default state: the same outcomes, times and paths, episode for episode
    (timings and the method's name aside). A network widened with zero weights for new inputs must pass."""
    import subprocess  # noqa: PLC0415

    common = [str(built_tool("dqn_dovs_eval")), "--methods", "dqn_dovs", "--generate", "7", "--obstacles", "6",
              "--episodes", "6", "--threads", "1", "--no-report"]
    runs = {}
    for name, extra in (("reference", ["--model", reference]), ("model", ["--model", model, *flags])):
        out = out_dir / name
        done = subprocess.run(common + extra + ["--out", str(out)], capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr
        lines = (out / "results.csv").read_text().splitlines()
        header = lines[0].split(",")
        keep = [i for i, c in enumerate(header) if not c.endswith("_ms") and c not in ("wall_s", "method")]
        runs[name] = [[row.split(",")[i] for i in keep] for row in lines[1:]]
    assert len(runs["reference"]) == 6
    assert runs["model"] == runs["reference"]
