"""A small deterministic corridor task with the dqn_dovs_py._core.VecEnv interface, so the
trainer's whole loop (collection, n-step, replay, learning, curriculum, evaluation,
checkpoints, export) can be tested where the C++ environment is not built.

The robot stands on a line of cells and must walk to the goal cell and stop there:
  actions 0 forward, 1 back, 2-4 stay, 5 "arrive" (moves forward; valid only one cell
  before the goal), 6-7 never valid.
Reaching the goal -> +15, terminated (success); stepping back behind the start -> -15,
terminated (collision); otherwise -2.5 x the change in distance; 40 steps -> truncated
(timeout). The state uses the real layout: a 20 x 20 grid
of +-1 (row 0 marks the robot's cell, row 1 the goal's) and 8 features.
"""

import numpy as np

MAX_STEPS = 40
CELLS = 20


class ChainCore:
    def __init__(self, num_envs, seed, perfect_info=False):
        self.n = num_envs
        self.rng = np.random.default_rng(seed)
        self.distance = (1, 3)
        self.pos = np.zeros(num_envs, int)
        self.goal = np.zeros(num_envs, int)
        self.steps = np.zeros(num_envs, np.int32)

    def set_stage(self, goal_distance_min, goal_distance_max, obstacles_min, obstacles_max, obstacle_type):
        self.distance = (max(1, int(round(goal_distance_min))), min(CELLS - 2, int(round(goal_distance_max))))

    def normalization(self):
        return {"cells": float(CELLS), "max_steps": float(MAX_STEPS)}

    def _reset_env(self, i):
        self.pos[i] = 0
        self.goal[i] = self.rng.integers(self.distance[0], self.distance[1] + 1)
        self.steps[i] = 0

    def _observe(self):
        state = -np.ones((self.n, 408), np.float32)
        idx = np.arange(self.n)
        state[idx, self.pos] = 1.0
        state[idx, CELLS + self.goal] = 1.0
        state[:, 400:] = 0.0
        state[:, 400] = self.pos / CELLS
        state[:, 401] = (self.goal - self.pos) / CELLS
        mask = np.ones((self.n, 8), bool)
        mask[:, 5] = self.goal - self.pos == 1
        mask[:, 6:] = False
        return state, mask

    def reset(self):
        for i in range(self.n):
            self._reset_env(i)
        return self._observe()

    def step(self, actions):
        _, mask_before = self._observe()
        assert np.all(mask_before[np.arange(self.n), actions]), "the trainer sent an invalid action"
        old_distance = self.goal - self.pos
        move = np.select([actions == 0, actions == 1, actions == 5], [1, -1, 1], 0)
        self.pos = self.pos + move
        self.steps += 1
        distance = self.goal - self.pos
        success = distance == 0
        collision = self.pos < 0
        terminated = success | collision
        truncated = ~terminated & (self.steps >= MAX_STEPS)
        reward = np.where(success, 15.0, np.where(collision, -15.0, -2.5 * (distance - old_distance)))
        outcome = np.where(success, 1, np.where(collision, 2, np.where(truncated, 3, 0))).astype(np.int8)
        self.pos = np.clip(self.pos, 0, CELLS - 1)
        next_state, next_mask = self._observe()
        episode_steps = self.steps.copy()
        for i in np.flatnonzero(terminated | truncated):
            self._reset_env(i)
        state, mask = self._observe()
        return {"next_state": next_state, "next_mask": next_mask, "reward": reward.astype(np.float32),
                "terminated": terminated, "truncated": truncated, "outcome": outcome, "state": state,
                "mask": mask, "episode_steps": episode_steps}
