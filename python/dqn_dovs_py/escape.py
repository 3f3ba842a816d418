"""The action stored in replay where the shield's escape ran instead of the chosen action.

Boxed in, the environment runs the shield's escape velocity instead of the chosen action (the step's `escaped`
flag, python/dqn_dovs_py/env.py). The escape is a velocity of the dynamic window chosen on a lattice, usually
none of the 8 actions; the environment reports the action that stands for it (`executed_action`: the action
whose velocity is nearest to the escape's in the window's units dv = a_v dt, dw = a_w dt; ties to the chosen
action, then the lowest index; src/python/core_module.cpp). Replay stores that action under a mask that allows
only it, so the targets learn what the robot did, not the choice it ignored.
"""

from __future__ import annotations

import numpy as np

NUM_ACTIONS = 8


def one_action_masks(actions: np.ndarray, num_actions: int = NUM_ACTIONS) -> np.ndarray:
    """Masks that allow exactly the given action each (bool [len(actions), num_actions])."""
    actions = np.asarray(actions, dtype=np.int64)
    if np.any((actions < 0) | (actions >= num_actions)):
        raise ValueError(f"actions must lie in [0, {num_actions}): {actions.tolist()}")
    masks = np.zeros((actions.shape[0], num_actions), dtype=bool)
    masks[np.arange(actions.shape[0]), actions] = True
    return masks
