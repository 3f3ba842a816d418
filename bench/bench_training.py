#!/usr/bin/env python3
"""Benchmark `training`: trainer throughput on this machine (CPU, one torch thread).

Runs the real trainer (C++ environments + PyTorch learning) for a shortened curriculum and reports
`env_steps_per_s` (whole loop, learning included), `updates_per_s`, `env_only_steps_per_s` and
`learn_only_updates_per_s` from the run's summary.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--out", default="bench/results/training.json")
    p.add_argument("--scale", type=float, default=0.01, help="fraction of every curriculum stage")
    p.add_argument("--scenarios", default=None, help="unused (the trainer draws its own scenarios)")
    args = p.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with tempfile.TemporaryDirectory() as tmp:
        run = os.path.join(tmp, "run")
        cmd = [sys.executable, "-m", "dqn_dovs_py.train", "--config", os.path.join(root, "config", "curriculum.yaml"),
               "--out", run, "--scale", str(args.scale), "--device", "cpu", "--threads", "1", "--no-progress"]
        env = dict(os.environ, PYTHONPATH=os.path.join(root, "python"))
        subprocess.run(cmd, check=True, env=env, cwd=root, stdout=subprocess.DEVNULL)
        with open(os.path.join(run, "summary.json")) as f:
            summary = json.load(f)
    keys = ["env_steps_per_s", "updates_per_s", "env_only_steps_per_s", "learn_only_updates_per_s"]
    result = {k: round(float(summary[k]), 2) for k in keys}
    result["episodes"] = summary["episodes"]
    result["env_steps"] = summary["env_steps"]
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
    print(f"{'figure':<28}{'value':>12}")
    for k, v in result.items():
        print(f"{k:<28}{v:>12}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
