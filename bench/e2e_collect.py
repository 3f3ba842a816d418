#!/usr/bin/env python3
"""Collects planner/latency samples (seconds from a scan's stamp to the planner's action for it) while the
simulated robot drives; restarts the scenario whenever the goal is reached, so the pipeline keeps working.
Writes the flat JSON figures of bench_e2e.sh. Run by bench/bench_e2e.sh against its own ROS master."""
import argparse
import json
import os
import statistics
import sys
import time

import rospy
from std_msgs.msg import Float64
from std_srvs.srv import Empty
from dqn_dovs.msg import PlannerStatus


def percentile(values, q):
    """Nearest-rank percentile (q in [0, 100]) of a non-empty list."""
    s = sorted(values)
    rank = max(1, int(round(q / 100.0 * len(s) + 0.5)))
    return s[min(rank, len(s)) - 1]


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--out", required=True)
    p.add_argument("--duration", type=float, default=40.0, help="seconds of sampling")
    p.add_argument("--startup-timeout", type=float, default=60.0)
    p.add_argument("--key-prefix", default="", help="prefix of the figures' keys; they join those already in --out")
    p.add_argument("--label", default="3 processes", help="how the pipeline runs, for the printout")
    args = p.parse_args()

    rospy.init_node("bench_e2e_collect", anonymous=True, disable_signals=True)
    samples = []
    resets = [0]
    state = {"reached": False}

    def on_latency(m):
        samples.append(m.data * 1000.0)

    def on_status(m):
        state["reached"] = m.state == PlannerStatus.REACHED

    rospy.Subscriber("planner/latency", Float64, on_latency, queue_size=100, tcp_nodelay=True)
    rospy.Subscriber("planner/status", PlannerStatus, on_status, queue_size=10)
    reset = rospy.ServiceProxy("simulator/reset", Empty)

    deadline = time.time() + args.startup_timeout
    while not samples and time.time() < deadline and not rospy.is_shutdown():
        time.sleep(0.1)
    if not samples:
        print("bench_e2e: no planner/latency sample: the pipeline did not start driving", file=sys.stderr)
        return 1
    samples.clear()  # the first ones include start-up
    start = time.time()
    episode_start = start
    while time.time() - start < args.duration and not rospy.is_shutdown():
        time.sleep(0.1)
        if state["reached"] or time.time() - episode_start > 60.0:
            reset()
            resets[0] += 1
            state["reached"] = False
            episode_start = time.time()
    if len(samples) < 50:
        print(f"bench_e2e: only {len(samples)} samples", file=sys.stderr)
        return 1
    figures = {
        "latency_ms_median": round(statistics.median(samples), 3),
        "latency_ms_p99": round(percentile(samples, 99.0), 3),
        "latency_ms_mean": round(statistics.fmean(samples), 3),
        "latency_ms_max": round(max(samples), 3),
        "samples": len(samples),
        "scenario_restarts": resets[0],
    }
    merged = {}
    if args.key_prefix and os.path.exists(args.out):
        with open(args.out) as f:
            merged = json.load(f)
    merged.update({args.key_prefix + k: v for k, v in figures.items()})
    with open(args.out, "w") as f:
        json.dump(merged, f, indent=2)
        f.write("\n")
    print(f"e2e: scan stamp -> planner action (tracker + DOVS + planner, {args.label}, wall clock)")
    print(f"{'samples':>10} {'median ms':>10} {'p99 ms':>10} {'mean ms':>10} {'max ms':>10}")
    print(f"{len(samples):>10} {figures['latency_ms_median']:>10.3f} {figures['latency_ms_p99']:>10.3f} "
          f"{figures['latency_ms_mean']:>10.3f} {figures['latency_ms_max']:>10.3f}")
    print(f"target p99 <= 2 ms: {'met' if figures['latency_ms_p99'] <= 2.0 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
