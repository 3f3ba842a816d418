#!/usr/bin/env python3
"""Benchmark `env`: the Python training environment's throughput per world family and LIDAR profile.

For every world family (room: 15 discs; the others: 15 people walking, social force, legs in the scan) and the
`sim` and `urg04lx` profiles, one `VecEnv` of 8 environments on one thread (one core) steps random valid
actions for `--seconds` of wall time after a warm-up. Each environment step is one 0.2 s control period: the
simulator's physics in sub-steps of at most 0.05 s, the scans of that period through the tracker, the DOVS and
the state. Reported per case: `<family>_<sensor>_env_steps_per_s` and `<family>_<sensor>_sim_steps_per_s`
(0.05 s simulator steps per second: environment steps x 4), plus the lowest of the latter.
"""
import argparse
import json
import os
import sys
import time

import numpy as np

FAMILIES = ["room", "crowd", "corridor", "doorway", "clutter", "junction"]
SENSORS = ["sim", "urg04lx"]
CONTROL_PERIOD_S = 0.2
SIM_STEP_S = 0.05


def measure(core_module, family: str, sensor: str, seconds: float, envs: int, people: int) -> float:
    env = core_module.VecEnv(envs, 4242, threads=1, world_options={"world": family, "sensor": sensor})
    # Start and goal far apart, everyone moving: the episodes stay long and crowded.
    env.set_stage(4.0, 8.0, people, people, "dynamic")
    rng = np.random.default_rng(1)
    _, mask = env.reset()

    def act(m):
        choice = np.empty(m.shape[0], dtype=np.int64)
        for i, row in enumerate(m):
            valid = np.flatnonzero(row)
            choice[i] = rng.choice(valid) if valid.size else 0
        return choice

    for _ in range(20):  # warm-up
        mask = env.step(act(mask))["mask"]
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        mask = env.step(act(mask))["mask"]
        steps += envs
    return steps / (time.perf_counter() - start)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="bench/results/env.json")
    p.add_argument("--seconds", type=float, default=3.0, help="wall time measured per case")
    p.add_argument("--envs", type=int, default=8)
    p.add_argument("--people", type=int, default=15)
    p.add_argument("--scenarios", default=None, help="unused (the environments generate their worlds)")
    args = p.parse_args()
    from dqn_dovs_py.env import import_core

    core = import_core()
    result = {}
    for family in FAMILIES:
        for sensor in SENSORS:
            rate = measure(core, family, sensor, args.seconds, args.envs, args.people)
            result[f"{family}_{sensor}_env_steps_per_s"] = round(rate, 1)
            result[f"{family}_{sensor}_sim_steps_per_s"] = round(rate * CONTROL_PERIOD_S / SIM_STEP_S, 1)
            print(f"  {family:<9} {sensor:<8} {rate:8.1f} env steps/s  {rate * 4:8.1f} sim steps/s", flush=True)
    result["min_sim_steps_per_s"] = min(v for k, v in result.items() if k.endswith("_sim_steps_per_s"))
    result["people"] = args.people
    result["envs"] = args.envs
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
