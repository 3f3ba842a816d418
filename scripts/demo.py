#!/usr/bin/env python3
"""The full ROS pipeline in simulation with the shipped model on a few shared scenarios, headless.

Starts `roslaunch dqn_dovs sim.launch` (simulator_node, obstacle_tracker_node, dovs_node,
planner_node) with its own ROS master, loads each scenario through the simulator's
`~load_scenario` service, waits for the planner to report the goal reached, a collision or the
500-step time limit, prints each episode's outcome and time, records a bag of the first
episode, and draws every trajectory (robot, obstacles, goal) into one PNG.
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time

DEFAULT_SCENARIOS = ["1-3/1", "1-5/2", "1-8/3", "1-10/4", "1-12/5", "1-15/6"]


def parse_args() -> argparse.Namespace:
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenarios-dir", default=os.path.join(root, "..", "shared", "scenarios", "rumor"))
    p.add_argument("--scenarios", nargs="+", default=DEFAULT_SCENARIOS, help="N-obstacle/episode, e.g. 1-8/3")
    p.add_argument("--out", default=os.path.join(root, "out", "demo"))
    p.add_argument("--model", default=os.path.join(root, "models", "dqn_dovs.dqnw"))
    p.add_argument("--realtime-factor", type=float, default=2.0)
    p.add_argument("--time-limit", type=float, default=100.0, help="simulated seconds (500 steps of 0.2 s)")
    p.add_argument("--port", type=int, default=11411, help="port of the demo's own ROS master")
    return p.parse_args()


def main() -> int:
    args = parse_args()
    os.makedirs(args.out, exist_ok=True)
    files = []
    for name in args.scenarios:
        path = os.path.abspath(os.path.join(args.scenarios_dir, f"{name}.dovs"))
        if not os.path.isfile(path):
            print(f"demo: scenario file {path} does not exist", file=sys.stderr)
            return 2
        files.append((name, path))
    if not os.path.isfile(args.model):
        print(f"demo: model {args.model} does not exist", file=sys.stderr)
        return 2

    env = dict(os.environ)
    env["ROS_MASTER_URI"] = f"http://localhost:{args.port}"
    env.setdefault("ROS_HOME", os.path.join(args.out, "ros_home"))
    os.environ.update(env)
    launch_log = open(os.path.join(args.out, "roslaunch.log"), "w")
    launch = subprocess.Popen(
        ["roslaunch", "-p", str(args.port), "dqn_dovs", "sim.launch", f"scenario:={files[0][1]}",
         f"model:={os.path.abspath(args.model)}", f"realtime_factor:={args.realtime_factor}", "goal_from_scenario:=true"],
        stdout=launch_log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        return run_episodes(args, files, launch)
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        try:
            launch.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, signal.SIGKILL)
        launch_log.close()


def run_episodes(args, files, launch) -> int:
    import rospy  # Debian's ROS 1 Python client
    from nav_msgs.msg import Odometry
    from dqn_dovs.msg import PlannerStatus, SimStatus, TrackedObstacleArray
    from dqn_dovs.srv import LoadScenario

    import rosgraph

    deadline = time.time() + 60
    while not rosgraph.is_master_online() and time.time() < deadline and launch.poll() is None:
        time.sleep(0.2)
    rospy.init_node("dqn_dovs_demo", anonymous=True, disable_signals=True)
    state = {"status": None, "planner": None, "robot": [], "obstacles": {}}

    def on_status(m):
        state["status"] = m

    def on_planner(m):
        state["planner"] = m

    def on_odom(m):
        state["robot"].append((m.pose.pose.position.x, m.pose.pose.position.y))

    def on_truth(m):
        for o in m.obstacles:
            state["obstacles"].setdefault(o.id, []).append((o.center.x, o.center.y, o.is_static))

    rospy.Subscriber("sim/status", SimStatus, on_status, queue_size=20)
    rospy.Subscriber("planner/status", PlannerStatus, on_planner, queue_size=20)
    rospy.Subscriber("odom", Odometry, on_odom, queue_size=50)
    rospy.Subscriber("ground_truth/obstacles", TrackedObstacleArray, on_truth, queue_size=20)

    print("demo: starting the pipeline (simulator_node, obstacle_tracker_node, dovs_node, planner_node)", flush=True)
    try:
        rospy.wait_for_service("simulator/load_scenario", timeout=60.0)
    except rospy.ROSException:
        print("demo: simulator_node did not come up; see " + os.path.join(args.out, "roslaunch.log"), file=sys.stderr)
        return 1
    load = rospy.ServiceProxy("simulator/load_scenario", LoadScenario)
    deadline = time.time() + 60
    while state["planner"] is None and time.time() < deadline:
        time.sleep(0.2)
    if state["planner"] is None:
        print("demo: planner_node did not come up; see " + os.path.join(args.out, "roslaunch.log"), file=sys.stderr)
        return 1

    results = []
    bag_path = os.path.join(args.out, "demo.bag")
    for k, (name, path) in enumerate(files):
        recorder = None
        if k == 0:
            recorder = subprocess.Popen(
                ["rosbag", "record", "-O", bag_path, "/scan", "/odom", "/tf", "/tf_static", "/move_base_simple/goal",
                 "/cmd_vel", "/obstacles", "/dovs", "/planner/status", "/planner/action", "/ground_truth/obstacles",
                 "__name:=demo_recorder"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
            time.sleep(1.5)
        res = load(path=path, seed=k + 1, obstacle_count=0, dynamic_fraction=0.85)
        if not res.success:
            print(f"demo: {name}: {res.message}", file=sys.stderr)
            return 1
        state["robot"].clear()
        state["obstacles"].clear()
        state["status"] = None
        goal = (res.goal.pose.position.x, res.goal.pose.position.y)
        outcome, t_end = "timeout", args.time_limit
        wall_deadline = time.time() + 3 * args.time_limit / max(args.realtime_factor, 0.1) + 30
        while time.time() < wall_deadline and launch.poll() is None:
            time.sleep(0.05)
            st, pl = state["status"], state["planner"]
            if st is None or st.scenario != res.message.split("'")[1]:
                continue
            if st.collided:
                outcome, t_end = "collision", st.episode_time
                break
            if pl is not None and pl.state == PlannerStatus.REACHED and st.goal_distance < 0.15 and st.speed < 0.2:
                outcome, t_end = "success", st.episode_time
                break
            if st.episode_time > args.time_limit:
                outcome, t_end = "timeout", st.episode_time
                break
        if launch.poll() is not None:
            print("demo: the pipeline stopped; see " + os.path.join(args.out, "roslaunch.log"), file=sys.stderr)
            return 1
        if recorder is not None:
            os.killpg(recorder.pid, signal.SIGINT)
            recorder.wait(timeout=20)
        results.append({"name": name, "outcome": outcome, "time": t_end, "robot": list(state["robot"]),
                        "obstacles": {i: list(v) for i, v in state["obstacles"].items()}, "goal": goal})
        print(f"demo: {name:>6}  {outcome:<9}  {t_end:6.1f} s", flush=True)

    png = os.path.join(args.out, "trajectories.png")
    plot(results, png)
    successes = sum(r["outcome"] == "success" for r in results)
    print(f"demo: {successes}/{len(results)} reached the goal; trajectories in {png}; bag in {bag_path}")
    rospy.signal_shutdown("demo done")
    return 0


def plot(results, png: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(3, len(results))
    rows = int(math.ceil(len(results) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.2 * rows), squeeze=False)
    for ax, r in zip(axes.flat, results):
        ax.plot([-4, 4, 4, -4, -4], [-4, -4, 4, 4, -4], color="black", lw=2)
        for track in r["obstacles"].values():
            xs, ys = [p[0] for p in track], [p[1] for p in track]
            static = track[0][2]
            ax.plot(xs, ys, color="grey" if static else "tab:blue", lw=1, alpha=0.7)
            ax.add_patch(plt.Circle((xs[-1], ys[-1]), 0.2, color="grey" if static else "tab:blue", alpha=0.5))
            ax.plot(xs[-1], ys[-1], "x", color="black", ms=5)
        if r["robot"]:
            xs, ys = zip(*r["robot"])
            ax.plot(xs, ys, color="tab:red", lw=2)
            ax.add_patch(plt.Circle((xs[-1], ys[-1]), 0.2, color="tab:red", alpha=0.6))
            ax.plot(xs[-1], ys[-1], "x", color="darkred", ms=8)
        ax.plot(*r["goal"], "*", color="green", ms=14)
        ax.set_title(f"{r['name']}: {r['outcome']} ({r['time']:.1f} s)")
        ax.set_aspect("equal")
        ax.set_xlim(-4.2, 4.2)
        ax.set_ylim(-4.2, 4.2)
    for ax in list(axes.flat)[len(results):]:
        ax.axis("off")
    fig.suptitle("DQN-DOVS through the ROS pipeline (robot red, moving obstacles blue, static grey, goal green)")
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
