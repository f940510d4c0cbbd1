"""The random-policy reference: actions drawn uniformly from the env's action space.

The floor of every benchmark table: what a task scores when the agent knows nothing. Beside the
oracles (the ceiling) it says how much of the gap between the two a learned policy closes.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

__all__ = ["RandomPolicy"]


class RandomPolicy:
    """``policy(obs) -> actions``: i.i.d. uniform actions in a ``Box`` action space.

    ``obs``: a batch of observations, an array of shape ``(n, obs_dim)`` or a dict of such arrays
    (goal-conditioned envs); the result has shape ``(n, *action_space.shape)``, float32. The draws
    come from ``numpy.random.default_rng(seed)``: the same sequence of calls gives the same
    actions (the gymnasium action space's own ``sample`` is not used, so the env's seeding is left
    untouched).
    """

    def __init__(self, action_space: gym.spaces.Space, seed: int = 0) -> None:
        if not isinstance(action_space, gym.spaces.Box):
            raise ValueError(
                f"action_space must be a gymnasium Box (continuous actions), got {action_space!r}"
            )
        low, high = np.asarray(action_space.low), np.asarray(action_space.high)
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
            raise ValueError(
                f"action_space must be bounded to draw uniform actions, got low={low!r}, "
                f"high={high!r}"
            )
        self.low, self.high = low.astype(np.float64), high.astype(np.float64)
        self.rng = np.random.default_rng(seed)

    @classmethod
    def from_env(cls, env: gym.Env, seed: int = 0) -> RandomPolicy:
        """The random policy of ``env``'s action space."""
        return cls(env.action_space, seed)

    def __call__(self, obs: Any) -> np.ndarray:
        if isinstance(obs, dict):
            n = len(next(iter(obs.values())))
        else:
            n = len(obs)
        draws = self.rng.uniform(self.low, self.high, size=(n, *self.low.shape))
        return draws.astype(np.float32)

    #: the controllers' name for the same call (``controller.action(obs)``)
    action = __call__
