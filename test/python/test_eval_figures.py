"""The evaluation benchmarks' figures (python -m dqn_dovs_py.eval_figures) from a real dqn_dovs_eval run: the
method's rates, the rival's success and time ratio, the pooled paired comparison, the run's size; bad input is
named."""

import json
import subprocess
from pathlib import Path

from built_tools import built_tool
from dqn_dovs_py import eval_figures
from dqn_dovs_py.benchmark_report import paired_comparison, read_results

REPO = Path(__file__).resolve().parents[2]


def _evaluate(out, methods):
    cmd = [str(built_tool("dqn_dovs_eval")), "--methods", methods, "--generate", "31", "--obstacles", "4-5",
           "--episodes", "3", "--trajectories", "0", "--out", str(out), "--model",
           str(REPO / "models" / "dqn_dovs.dqnw")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=REPO)
    assert proc.returncode == 0, proc.stderr


def test_figures_with_a_rival(tmp_path):
    run = tmp_path / "eval"
    _evaluate(run, "dqn_dovs,s_dovs")
    out = tmp_path / "eval-dqn.json"
    assert eval_figures.main(["--eval-dir", str(run), "--method", "dqn_dovs", "--rival", "s_dovs",
                              "--episodes-per-count", "3", "--wall", "2.0", "--out", str(out)]) == 0
    f = json.loads(out.read_text())
    summary = json.loads((run / "summary.json").read_text())
    assert f["success_mean"] == summary["dqn_dovs.success_mean"]
    assert f["success_4"] == summary["dqn_dovs.success_4"] and "success_6" not in f
    assert f["s_dovs_success_mean"] == summary["s_dovs.success_mean"]
    assert f["time_ratio_vs_sdovs"] == summary["s_dovs.time_ratio_mean"]
    pooled = paired_comparison(read_results(str(run / "results.csv")), "dqn_dovs", "s_dovs")[None]
    assert (f["wins_vs_sdovs"], f["losses_vs_sdovs"]) == (pooled.wins, pooled.losses)
    assert f["episodes"] == 12 and f["episodes_per_count"] == 3 and f["episodes_per_s"] == 6.0
    assert not any(k.startswith("collisions") or "contact" in k for k in f)


def test_figures_of_one_method_and_bad_input(tmp_path):
    run = tmp_path / "eval"
    _evaluate(run, "s_dovs")
    out = tmp_path / "eval-sdovs.json"
    assert eval_figures.main(["--eval-dir", str(run), "--method", "s_dovs", "--episodes-per-count", "3",
                              "--wall", "1.04", "--out", str(out)]) == 0
    f = json.loads(out.read_text())
    assert set(f) == {"success_mean", "collision_mean", "timeout_mean", "success_4", "success_5",
                      "episodes_per_count", "wall_s"}
    assert f["wall_s"] == 1.0
    # A method the run does not have, and a folder without a run, are refused (exit 1).
    assert eval_figures.main(["--eval-dir", str(run), "--method", "s_dovs", "--rival", "dwa",
                              "--episodes-per-count", "3", "--wall", "1", "--out", str(out)]) == 1
    assert eval_figures.main(["--eval-dir", str(tmp_path / "none"), "--method", "s_dovs",
                              "--episodes-per-count", "3", "--wall", "1", "--out", str(out)]) == 1
