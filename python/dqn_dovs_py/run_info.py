"""results/benchmark/run_info.json: how a `make benchmark-table` run was made (scripts/benchmark_table.sh writes it
through this module; python/dqn_dovs_py/benchmark_report.py prints it in docs/benchmark.md).

    python -m dqn_dovs_py.run_info --out results/benchmark/run_info.json --commit abc1234 --model models/dqn_dovs.dqnw \
        --tracker-command "dqn_dovs_eval ..." --tracker-wall 180.2 --perfect-command "..." --perfect-wall 116.5 \
        --total-wall 301.0
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import sys

from .performance_report import machine_info


def sha256_of(path: str) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def run_info(commit: str, model: str, tracker: tuple[str, float], perfect: tuple[str, float], total_wall_s: float,
             now: datetime.datetime | None = None) -> dict:
    """The record: date (UTC), commit, model and its sha256, the machine (nproc, cpu model), and per perception
    the evaluation's command and wall time."""
    machine = machine_info()
    now = now or datetime.datetime.now(datetime.timezone.utc)
    return {
        "date": now.strftime("%Y-%m-%d %H:%M UTC"),
        "commit": commit, "model": model, "model_sha256": sha256_of(model),
        "nproc": machine["nproc"], "cpu_model": machine["cpu_model"],
        "tracker": {"command": tracker[0], "wall_s": float(tracker[1])},
        "perfect": {"command": perfect[0], "wall_s": float(perfect[1])},
        "total_wall_s": float(total_wall_s),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m dqn_dovs_py.run_info", description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True)
    p.add_argument("--commit", required=True)
    p.add_argument("--model", required=True)
    p.add_argument("--tracker-command", required=True)
    p.add_argument("--tracker-wall", type=float, required=True)
    p.add_argument("--perfect-command", required=True)
    p.add_argument("--perfect-wall", type=float, required=True)
    p.add_argument("--total-wall", type=float, required=True)
    a = p.parse_args(argv)
    try:
        info = run_info(a.commit, a.model, (a.tracker_command, a.tracker_wall), (a.perfect_command, a.perfect_wall),
                        a.total_wall)
    except OSError as e:
        print(f"run_info: model {a.model}: {e.strerror}", file=sys.stderr)
        return 1
    with open(a.out, "w") as f:
        json.dump(info, f, indent=2)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
