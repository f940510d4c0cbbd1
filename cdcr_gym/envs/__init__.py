"""Gymnasium faces of the env core: the single env (N = 1) and the batched vector env."""

from __future__ import annotations

from cdcr_gym.envs.env import CDCREnv, GoalCDCREnv

__all__ = ["CDCREnv", "GoalCDCREnv"]
