"""scripts/select_model.sh end to end: it evaluates every candidate of a run with the built dqn_dovs_eval on
generated episodes, ranks them, writes selection.csv / selection.md and prints the winner last; bad input is
named."""

import csv
import os
import shutil
import subprocess
from pathlib import Path

import pytest
import torch
from built_tools import built_tool
from dqn_dovs_py.export import export_model, load_weights, model_from_weights

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


def _perturbed_copy(path):
    """The shipped network with slightly different weights: another valid candidate."""
    weights = load_weights(MODEL)
    net = model_from_weights(weights)
    with torch.no_grad():
        for p in net.parameters():
            p.add_(0.01 * torch.randn_like(p, generator=torch.Generator().manual_seed(5)))
    export_model(net, path, weights.normalization, "perturbed copy for test_select_model")


def test_ranks_every_candidate_once(tmp_path):
    run = tmp_path / "run"
    (run / "snapshots").mkdir(parents=True)
    snapshot, best, model = run / "snapshots" / "ep000250.dqnw", run / "best.dqnw", run / "model.dqnw"
    shutil.copy(MODEL, snapshot)
    shutil.copy(MODEL, best)  # the same bytes as the snapshot: evaluated once, listed as its alias
    _perturbed_copy(model)
    result = _run(run)
    assert result.returncode == 0, result.stderr
    assert result.stderr.count("generator seed 9101") == 2  # two distinct candidates, one run per seed each
    winner = result.stdout.strip().splitlines()[-1]
    assert winner in (str(snapshot), str(model))
    with open(run / "selection" / "selection.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["model"] for r in rows} == {str(snapshot), str(model)}
    assert set(rows[0]) == {"model", "also", "mean", "upper_mean", "success_3", "success_4"}
    assert {r["model"]: r["also"] for r in rows} == {str(snapshot): str(best), str(model): ""}
    assert [float(r["mean"]) for r in rows] == sorted((float(r["mean"]) for r in rows), reverse=True)
    # The rates are those of 2 seeds x 2 episodes per count.
    for r in rows:
        for n in (3, 4):
            assert float(r[f"success_{n}"]) in (0.0, 0.25, 0.5, 0.75, 1.0)
        assert float(r["mean"]) == pytest.approx((float(r["success_3"]) + float(r["success_4"])) / 2, abs=1e-4)
    text = (run / "selection" / "selection.md").read_text()
    assert "seeds 9101 9102, obstacles 3-4, 2 episodes per count and seed" in text
    assert text.count("| 1 |") == 1 and "| 2 |" in text and "| 3 |" not in text
    assert f"(same file: `{best}`)" in text


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


def test_ranking_by_mean_then_upper_half(tmp_path):
    # The ranking step alone, on hand-made evaluations: a tie on the mean is broken by the upper half of the
    # counts; a missing evaluation is a clear error.
    import json  # noqa: PLC0415

    from dqn_dovs_py import select_model  # noqa: PLC0415

    sel = tmp_path / "selection"
    rates = {"c1": {3: 0.9, 4: 0.5}, "c2": {3: 0.5, 4: 0.9}, "c3": {3: 0.4, 4: 0.4}}
    for c, per_n in rates.items():
        (sel / c / "9").mkdir(parents=True)
        (sel / c / "model_path").write_text(f"/runs/{c}.dqnw\n")
        (sel / c / "aliases").write_text("")
        (sel / c / "9" / "summary.json").write_text(json.dumps({f"success_{n}": r for n, r in per_n.items()}))
    ranked = select_model.rank(select_model.read_candidates(str(sel), ["9"], [3, 4]), [3, 4])
    assert [c.model for c in ranked] == ["/runs/c2.dqnw", "/runs/c1.dqnw", "/runs/c3.dqnw"]
    assert select_model.main(["--selection", str(sel), "--seeds", "9", "--obstacles", "3-4", "--episodes", "1"]) == 0
    assert (sel / "selection.csv").read_text().splitlines()[1].startswith("/runs/c2.dqnw,,0.7000,0.9000")
    (sel / "c3" / "9" / "summary.json").unlink()
    assert select_model.main(["--selection", str(sel), "--seeds", "9", "--obstacles", "3-4", "--episodes", "1"]) == 1
