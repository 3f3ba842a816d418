"""scripts/select_model.sh end to end: it evaluates every candidate of a run with the built dqn_dovs_eval on
generated episodes, ranks them, writes selection.csv / selection.md and prints the winner last; bad input is
named."""

import csv
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from built_tools import built_tool

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "select_model.sh"
MODEL = REPO / "models" / "dqn_dovs.dqnw"


def _eval_tool() -> Path:
    return built_tool("dqn_dovs_eval")


def _run(run_dir, **env):
    full = dict(os.environ, DQN_DOVS_EVAL=str(_eval_tool()), SEEDS="9101 9102", OBSTACLES="3-4", EPISODES="2",
                THREADS="1", **env)
    return subprocess.run(["bash", str(SCRIPT), str(run_dir)], capture_output=True, text=True, timeout=300,
                          env=full, cwd=REPO)


def test_ranks_every_candidate(tmp_path):
    run = tmp_path / "run"
    (run / "snapshots").mkdir(parents=True)
    shutil.copy(MODEL, run / "snapshots" / "ep000250.dqnw")
    shutil.copy(MODEL, run / "best.dqnw")
    result = _run(run)
    assert result.returncode == 0, result.stderr
    winner = result.stdout.strip().splitlines()[-1]
    assert winner in (str(run / "snapshots" / "ep000250.dqnw"), str(run / "best.dqnw"))
    with open(run / "selection" / "selection.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["model"] for r in rows} == {str(run / "snapshots" / "ep000250.dqnw"), str(run / "best.dqnw")}
    assert set(rows[0]) == {"model", "mean", "upper_mean", "success_3", "success_4"}
    # The same network on the same episodes scores the same, and the rates are those of 2 x 2 episodes per count.
    assert rows[0]["mean"] == rows[1]["mean"]
    for r in rows:
        for n in (3, 4):
            assert float(r[f"success_{n}"]) in (0.0, 0.25, 0.5, 0.75, 1.0)
    text = (run / "selection" / "selection.md").read_text()
    assert "seeds 9101 9102, obstacles 3-4, 2 episodes per count and seed" in text
    assert text.count("| 1 |") == 1 and "| 2 |" in text


def test_corrupt_candidate_fails_with_its_name(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "best.dqnw").write_bytes(b"not a weight file")
    result = _run(run)
    assert result.returncode == 1
    assert f"evaluation of {run / 'best.dqnw'} failed" in result.stderr


def test_missing_run_and_empty_run_are_named(tmp_path):
    result = _run(tmp_path / "absent")
    assert result.returncode == 2 and "run directory" in result.stderr and "absent" in result.stderr
    (tmp_path / "empty").mkdir()
    result = _run(tmp_path / "empty")
    assert result.returncode == 2 and "no .dqnw files" in result.stderr
