"""Gymnasium faces of the env core: the single env (N = 1) and the batched vector env.

The env classes are exported lazily, so that the building blocks below them
(``cdcr_gym.envs.observation``, used by the tasks) import without pulling in the envs.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CDCREnv", "GoalCDCREnv", "ReachEnv", "GoalReachEnv"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from cdcr_gym.envs import env

        return getattr(env, name)
    raise AttributeError(f"module 'cdcr_gym.envs' has no attribute {name!r}")
