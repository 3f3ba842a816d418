"""results/benchmark/run_info.json (python -m dqn_dovs_py.run_info) and scripts/benchmark_table.sh end to end on a tiny
run (one method, one obstacle count, one episode) written outside results/ and docs/."""

import hashlib
import json
import os
import subprocess
from pathlib import Path

from built_tools import built_tool
from dqn_dovs_py import run_info

REPO = Path(__file__).resolve().parents[2]
MODEL = REPO / "models" / "dqn_dovs.dqnw"


def test_run_info_records_the_run(tmp_path):
    out = tmp_path / "run_info.json"
    assert run_info.main(["--out", str(out), "--commit", "abc1234", "--model", str(MODEL),
                          "--tracker-command", "dqn_dovs_eval --methods dqn_dovs", "--tracker-wall", "12.5",
                          "--perfect-command", "dqn_dovs_eval --perfect-info", "--perfect-wall", "3",
                          "--total-wall", "15.5"]) == 0
    info = json.loads(out.read_text())
    assert info["model_sha256"] == hashlib.sha256(MODEL.read_bytes()).hexdigest()
    assert info["commit"] == "abc1234" and info["nproc"] == os.cpu_count()
    assert info["tracker"] == {"command": "dqn_dovs_eval --methods dqn_dovs", "wall_s": 12.5}
    assert info["perfect"]["wall_s"] == 3.0 and info["total_wall_s"] == 15.5
    assert info["date"].endswith(" UTC")
    assert run_info.main(["--out", str(out), "--commit", "x", "--model", str(tmp_path / "none.dqnw"),
                          "--tracker-command", "a", "--tracker-wall", "1", "--perfect-command", "b",
                          "--perfect-wall", "1", "--total-wall", "2"]) == 1


def test_benchmark_table_script_end_to_end(tmp_path):
    env = dict(os.environ, EPISODES="1", OBSTACLES="2", METHODS="dqn_dovs,s_dovs", THREADS="1",
               DQN_DOVS_EVAL=str(built_tool("dqn_dovs_eval")), OUT_DOC=str(tmp_path / "docs" / "benchmark.md"),
               OUT_DIR=str(tmp_path / "results" / "benchmark"))
    (tmp_path / "docs").mkdir()
    proc = subprocess.run(["bash", str(REPO / "scripts" / "benchmark_table.sh")], capture_output=True, text=True,
                          timeout=600, env=env, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    info = json.loads((tmp_path / "results" / "benchmark" / "run_info.json").read_text())
    assert "--episodes 1" in info["tracker"]["command"] and "--perfect-info" in info["perfect"]["command"]
    assert (tmp_path / "results" / "benchmark" / "tracker" / "results.csv").exists()
    text = (tmp_path / "docs" / "benchmark.md").read_text()
    assert "## Tracker in the loop" in text and "## Perfect information" in text
