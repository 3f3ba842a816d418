"""Which of the 8 actions stands for the action shield's escape in replay.

Boxed in, the environment runs the shield's escape velocity instead of the chosen action (the step's
`escaped` flag, python/dqn_dovs_py/env.py). The escape is a velocity of the dynamic window chosen on a
lattice (ActionShieldConfig::escape_window_samples steps per half-diagonal, plus the strongest braking;
include/dqn_dovs/policy/action_shield.h), not one of the 8 actions, and the environment reports neither
the velocity nor an action index, only the flag. What the data does give is the robot's velocity before
the step (the state's v and w features) and after it (the successor's): the simulator reaches the
commanded velocity of the window within the control period, so the successor's (v, w) is the escape
velocity. The action stored for an escaped step is the one whose velocity is nearest to it, in the
window's own units (dv = a_v dt, dw = a_w dt); equal distances go to the chosen action, then to the
lowest index.

The action velocities mirror computeActions (src/dovs/actions.cpp): the four window corners clipped into
the feasible triangle along the way from the current velocity, "keep", and the goal line's intersection
with the feasible window (5 highest, 6 lowest, 7 at the current v). The goal comes from the state's goal
features; its distance is clipped at the normalisation's scale (10 m), which only bends the goal line of
goals farther than that, and only slightly. test/python/test_escape.py checks the mirror against the C++
environment on every step it takes.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import yaml

NUM_ACTIONS = 8
GRID_CELLS = 400
# Feature indices after the grid (include/dqn_dovs/dovs/state.h).
FEATURE_V, FEATURE_W, FEATURE_GOAL_DISTANCE, FEATURE_GOAL_ANGLE = 0, 1, 2, 3
ROBOT_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "robot.yaml")

# computeActions' tolerances are 1e-9 on double velocities; the state's float32 features carry the velocities
# to about 1e-7 relative, so a goal line that touches the window there would be missed at 1e-9.
_TOL = 1e-6
# A goal closer than this has no goal line (kGoalAtRobotTolerance_m).
_GOAL_AT_ROBOT_M = 1e-3
# Distances (in window units) closer than this count as equal when choosing the nearest action.
_TIE = 1e-6


class RobotLimitsError(ValueError):
    """The robot's limits cannot be read, or disagree with the environment's; the message names the field."""


@dataclass(frozen=True)
class RobotLimits:
    """The differential drive's limits (DESIGN section 3; include/dqn_dovs/common/robot_model.h)."""

    v_max: float = 0.7
    w_max: float = math.pi
    a_v: float = 0.5
    a_w: float = 2.0
    dt: float = 0.2

    @property
    def dv(self) -> float:
        return self.a_v * self.dt

    @property
    def dw(self) -> float:
        return self.a_w * self.dt


def load_robot_limits(normalization: dict[str, float], path: str = ROBOT_FILE) -> RobotLimits:
    """The limits the environment runs: v_max and w_max from its state normalisation (its own speed scales),
    the accelerations and the control period from config/robot.yaml, whose speeds must agree with them."""
    try:
        with open(path) as f:
            robot = (yaml.safe_load(f) or {}).get("robot")
    except OSError as error:
        raise RobotLimitsError(f"{path}: cannot be read ({error.strerror})") from None
    if not isinstance(robot, dict):
        raise RobotLimitsError(f"{path}: no 'robot' section")
    values = {}
    for key in ("v_max", "w_max", "a_v", "a_w", "dt"):
        value = robot.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise RobotLimitsError(f"{path}: robot/{key} must be a positive number, got {value!r}")
        values[key] = float(value)
    for key, scale in (("v_max", "v_scale_mps"), ("w_max", "w_scale_rps")):
        if scale not in normalization:
            raise RobotLimitsError(f"the environment's normalisation has no {scale!r}")
        env_value = float(normalization[scale])
        if abs(env_value - values[key]) > 1e-4 * values[key]:
            raise RobotLimitsError(f"{path}: robot/{key} = {values[key]} but the environment runs {env_value} "
                                   f"({scale})")
        values[key] = env_value
    return RobotLimits(**values)


def _feasible_set(limits: RobotLimits) -> list[tuple[float, float, float]]:
    # Half-planes n_v v + n_w w <= c of the triangle 0 <= v <= v_max, |w| / w_max + v / v_max <= 1.
    return [(-1.0, 0.0, 0.0), (1.0, 0.0, limits.v_max), (1.0 / limits.v_max, 1.0 / limits.w_max, 1.0),
            (1.0 / limits.v_max, -1.0 / limits.w_max, 1.0)]


def _rhombus(v: float, w: float, limits: RobotLimits) -> list[tuple[float, float, float]]:
    dv, dw = limits.dv, limits.dw
    return [(sv / dv, sw / dw, 1.0 + sv * v / dv + sw * w / dw) for sv in (-1.0, 1.0) for sw in (-1.0, 1.0)]


def _feasible(v: float, w: float, limits: RobotLimits, tol: float) -> bool:
    return -tol <= v <= limits.v_max + tol and abs(w) / limits.w_max + v / limits.v_max <= 1.0 + tol


def _clip_to_feasible(v: float, w: float, limits: RobotLimits) -> tuple[float, float]:
    if _feasible(v, w, limits, 0.0):
        return v, w
    sign = -1.0 if w < 0.0 else 1.0
    a, b = max(v / limits.v_max, 0.0), abs(w) / limits.w_max
    if a + b > 1.0:
        excess = (a + b - 1.0) / 2.0
        a, b = a - excess, b - excess
        if a < 0.0:
            a, b = 0.0, 1.0
        elif b < 0.0:
            a, b = 1.0, 0.0
    return a * limits.v_max, sign * b * limits.w_max


def _clip_along(v: float, w: float, to_v: float, to_w: float, limits: RobotLimits) -> tuple[float, float]:
    tau = 1.0
    d_v, d_w = to_v - v, to_w - w
    for n_v, n_w, c in _feasible_set(limits):
        g = n_v * d_v + n_w * d_w
        if g > 0.0:
            tau = min(tau, (c - (n_v * v + n_w * w)) / g)
    tau = min(max(tau, 0.0), 1.0)
    return v + tau * d_v, w + tau * d_w


def action_velocities(v: float, w: float, goal_x: float, goal_y: float,
                      limits: RobotLimits) -> tuple[np.ndarray, np.ndarray]:
    """The 8 actions' velocities [8, 2] (v, w) and validity [8] at the current velocity (v, w) with the goal
    at (goal_x, goal_y) in the robot frame, as computeActions makes them."""
    v, w = _clip_to_feasible(v, w, limits)
    dv, dw = limits.dv, limits.dw
    velocities = np.tile([v, w], (NUM_ACTIONS, 1)).astype(np.float64)
    valid = np.zeros(NUM_ACTIONS, bool)
    for i, (cv, cw) in enumerate(((v + dv, w), (v - dv, w), (v, w - dw), (v, w + dw))):
        velocities[i] = _clip_along(v, w, cv, cw, limits)
    valid[:5] = True

    if goal_x * goal_x + goal_y * goal_y < _GOAL_AT_ROBOT_M ** 2:
        return velocities, valid
    turn_in_place = goal_x < 0.0
    if turn_in_place:
        direction = (0.0, -1.0 if goal_y < 0.0 else 1.0)
    else:
        curvature = 2.0 * goal_y / (goal_x * goal_x + goal_y * goal_y)
        direction = (1.0, curvature)
    lo, hi, empty = 0.0, math.inf, False
    for n_v, n_w, c in _feasible_set(limits) + _rhombus(v, w, limits):
        g = n_v * direction[0] + n_w * direction[1]
        scale = abs(n_v) + abs(n_w)
        if g > _TOL * scale:
            hi = min(hi, c / g)
        elif g < -_TOL * scale:
            lo = max(lo, c / g)
        elif c < -_TOL * scale:
            empty = True
    touch = _TOL * (1.0 + abs(hi))
    if empty or not (lo <= hi + touch):
        return velocities, valid
    if lo > hi:
        lo = hi = 0.5 * (lo + hi)

    def at(lam: float) -> tuple[float, float]:
        return _clip_to_feasible(lam * direction[0], lam * direction[1], limits)

    velocities[5], velocities[6] = at(hi), at(lo)
    valid[5] = valid[6] = True
    if not turn_in_place:
        on_line = (v, curvature * v)
        in_rhombus = abs(on_line[0] - v) / dv + abs(on_line[1] - w) / dw <= 1.0 + _TOL
        if in_rhombus and _feasible(on_line[0], on_line[1], limits, _TOL):
            velocities[7] = on_line
            valid[7] = True
    elif v <= _TOL:
        lam = min(max(w * direction[1], lo), hi)
        velocities[7] = at(lam)
        valid[7] = True
    return velocities, valid


def decode_velocity(states: np.ndarray, normalization: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The robot's (v, w) in m/s and rad/s from states [n, 408]."""
    features = np.asarray(states, np.float64)[:, GRID_CELLS:]
    return (features[:, FEATURE_V] * float(normalization["v_scale_mps"]),
            features[:, FEATURE_W] * float(normalization["w_scale_rps"]))


def decode_goal(states: np.ndarray, normalization: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The goal (x, y) in the robot frame from states [n, 408] (its distance clipped at the normalisation's
    scale)."""
    features = np.asarray(states, np.float64)[:, GRID_CELLS:]
    distance = features[:, FEATURE_GOAL_DISTANCE] * float(normalization["goal_distance_scale_m"])
    angle = features[:, FEATURE_GOAL_ANGLE] * float(normalization["goal_angle_scale_rad"])
    return distance * np.cos(angle), distance * np.sin(angle)


def executed_actions(states: np.ndarray, next_states: np.ndarray, normalization: dict[str, float],
                     limits: RobotLimits, chosen: np.ndarray | None = None) -> np.ndarray:
    """For steps that ran the escape: the action (int64 [n]) whose velocity in `states` is nearest to the
    velocity the robot has in `next_states`, i.e. the escape velocity it executed. Distances are measured in
    units of the window's half-diagonals; equal distances go to the `chosen` action, then to
    the lowest index."""
    v, w = decode_velocity(states, normalization)
    goal_x, goal_y = decode_goal(states, normalization)
    next_v, next_w = decode_velocity(next_states, normalization)
    out = np.zeros(len(v), np.int64)
    for i in range(len(v)):
        velocities, valid = action_velocities(v[i], w[i], goal_x[i], goal_y[i], limits)
        distance = np.hypot((velocities[:, 0] - next_v[i]) / limits.dv, (velocities[:, 1] - next_w[i]) / limits.dw)
        distance[~valid] = np.inf
        nearest = np.flatnonzero(distance <= distance.min() + _TIE)
        preferred = None if chosen is None else int(chosen[i])
        out[i] = preferred if preferred in nearest else int(nearest[0])
    return out


def one_action_masks(actions: np.ndarray, num_actions: int = NUM_ACTIONS) -> np.ndarray:
    """bool [n, num_actions] masks allowing only actions[i] in row i."""
    actions = np.asarray(actions, np.int64)
    masks = np.zeros((actions.size, num_actions), bool)
    masks[np.arange(actions.size), actions] = True
    return masks
