"""The analytic-IK controller: the oracle that learned policies are judged against.

A small policy object (observation in, action out) that knows the robot model: it finds the arc
whose tip is the goal (``kinematics.arc_from_tip``), the minimal tensions or cable lengths that
hold it (``statics.tensions_from_arc`` / ``kinematics.lengths_from_arc``), and the action that
commands them from the current state. In the analytic env it reaches every goal exactly (one step
with absolute tensions; within the episode with increments). On another backend (pybullet,
gravity, discrete disks) it is *open loop*: it commands what CCKA says and does not correct.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import kinematics, statics
from cdcr_gym.envs import task
from cdcr_gym.params import RobotParams

__all__ = ["AnalyticIKController"]


class AnalyticIKController:
    """Analytic inverse kinematics as a policy for :class:`~cdcr_gym.envs.reach.ReachEnv`.

    Args:
        params: the robot the IK assumes.
        action_mode: the env's action mode (``tension``, ``tension_delta``, ``length_delta``).
        tension_step: the env's ``tension_step`` (fraction of max_tension per step).
        length_step: the env's ``length_step`` (m per step).

    Use :meth:`from_env` to copy these from an env. :meth:`predict` follows stable-baselines3's
    signature, so the evaluation code can run this and a PPO model the same way.
    """

    def __init__(
        self,
        params: RobotParams,
        action_mode: str = "tension_delta",
        tension_step: float = 0.05,
        length_step: float = 0.002,
    ) -> None:
        if action_mode not in task.ACTION_MODES:
            raise ValueError(f"action_mode must be one of {task.ACTION_MODES}, got {action_mode!r}")
        self.params = params
        self.action_mode = action_mode
        self.tension_step = float(tension_step)
        self.length_step = float(length_step)

    @classmethod
    def from_env(cls, env: Any) -> AnalyticIKController:
        """A controller matched to ``env`` (a ReachEnv, possibly wrapped)."""
        env = env.unwrapped
        return cls(env.params, env.action_mode, env.tension_step, env.length_step)

    def targets(self, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """IK solution for ``goal`` (..., 3) m: (tensions (..., 3) N, cable lengths (..., 3) m)."""
        p = self.params
        theta, phi, _ = kinematics.arc_from_tip(goal, p.length)
        tensions, _ = statics.tensions_from_arc(theta, phi, p)
        lengths = kinematics.lengths_from_arc(theta, phi, p.length, p.cable_radius)
        return tensions, lengths

    def _unpack(self, obs: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(goal m, tensions N, lengths m) from a flat or Dict observation, batched."""
        p = self.params
        if isinstance(obs, dict):
            goal = np.asarray(obs["desired_goal"], dtype=np.float64)
            state = np.asarray(obs["observation"], dtype=np.float64)[..., 3:9]
        else:
            flat = np.asarray(obs, dtype=np.float64)
            if flat.shape[-1] != task.flat_observation_size():
                raise ValueError(
                    f"obs must be a flat ReachEnv observation of length "
                    f"{task.flat_observation_size()}, got shape {flat.shape}"
                )
            goal = flat[..., 3:6]
            state = flat[..., 12:18]
        tensions = state[..., :3] * p.max_tension
        lengths = state[..., 3:] * (np.pi * p.cable_radius) + p.length
        return goal, tensions, lengths

    def action(self, obs: Any) -> np.ndarray:
        """The action (..., 3) float32 in [−1, 1] that drives the robot towards the IK solution."""
        p = self.params
        goal, tensions, lengths = self._unpack(obs)
        target_tensions, target_lengths = self.targets(goal)
        if self.action_mode == "tension":
            action = 2.0 * target_tensions / p.max_tension - 1.0
        elif self.action_mode == "tension_delta":
            action = (target_tensions - tensions) / (self.tension_step * p.max_tension)
        else:
            action = (target_lengths - lengths) / self.length_step
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, None]:
        """stable-baselines3-style ``predict``: ``(action, None)``."""
        return self.action(observation), None

    __call__ = action
