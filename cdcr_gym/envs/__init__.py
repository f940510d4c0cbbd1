"""Gymnasium environments: the reach task on any backend."""

from cdcr_gym.envs.reach import GoalReachEnv, ReachEnv

__all__ = ["ReachEnv", "GoalReachEnv"]
