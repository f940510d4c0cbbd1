"""The inverse-kinematics controller: the reach oracle that learned policies are judged against.

A small policy object (observation in, action out) that knows the robot model: it solves the
inverse kinematics of the goal (``cdcr_gym.model.ik.solve_ik``: closed form for one section,
numerical for several), takes the minimal tensions (or the cable lengths) of that shape, and
commands them from the current state. It reads the observation by field name through the env's
``ObservationSpec``. On the analytic backend it reaches every reachable goal exactly (one step
with absolute tensions; within the episode with increments). On another backend (pybullet,
gravity, discrete disks) it is *open loop*: it commands what the model says and does not correct.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.envs.actuation import ACTION_MODES
from cdcr_gym.envs.observation import ObservationSpec
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.model.params import RobotParams

__all__ = ["AnalyticIKController"]


class AnalyticIKController:
    """Inverse kinematics as a policy for a reach env (flat or goal-conditioned).

    Args:
        params: the robot the IK assumes.
        spec: the env's observation layout (flat, or the ``observation`` part of the Dict); the
            controller reads ``goal`` (flat only), ``tensions`` and ``cable_lengths`` from it.
        action_mode: the env's action mode (``tension``, ``tension_delta``, ``length_delta``).
        tension_step: the env's ``tension_step`` (fraction of max_tension per step).
        length_step: the env's ``length_step`` (m per step).

    Use :meth:`from_env` to copy these from an env. :meth:`predict` follows stable-baselines3's
    signature, so the evaluation code can run this and a trained model the same way.
    """

    def __init__(
        self,
        params: RobotParams,
        spec: ObservationSpec,
        action_mode: str = "tension_delta",
        tension_step: float = 0.05,
        length_step: float = 0.002,
    ) -> None:
        self.params = params
        self.spec = spec
        self.action_mode = validation.choice(action_mode, "action_mode", ACTION_MODES)
        self.tension_step = validation.positive(tension_step, "tension_step", upper=1.0)
        self.length_step = validation.positive(length_step, "length_step")
        self._model = PCCModel(params)
        self._run_lengths = np.asarray(params.cable_run_lengths)
        sections = np.asarray(params.cable_section)
        self._length_span = np.pi * np.asarray(params.cable_radii) * (sections + 1)

    @classmethod
    def from_env(cls, env: Any) -> AnalyticIKController:
        """A controller matched to ``env`` (a CDCREnv or the batched env, possibly wrapped)."""
        env = env.unwrapped
        return cls(
            env.params, env.observation_spec, env.action_mode, env.tension_step, env.length_step
        )

    def targets(self, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """IK solution for ``goal`` (..., 3) m: (tensions (..., C) N, cable lengths (..., C) m)."""
        solution = solve_ik(goal, self.params)
        return solution.tensions, self._model.lengths_from_bending(solution.bending)

    def _unpack(self, obs: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(goal m, tensions N, cable lengths m) from a flat or Dict observation, batched."""
        spec = self.spec
        if isinstance(obs, dict):
            goal = np.asarray(obs["desired_goal"], dtype=np.float64)
            state = obs["observation"]
        else:
            state = obs
            goal = spec.decode(obs, "goal")
        tensions = spec.decode(state, "tensions") * self.params.max_tension
        lengths = spec.decode(state, "cable_lengths") * self._length_span + self._run_lengths
        return goal, tensions, lengths

    def action(self, obs: Any) -> np.ndarray:
        """The action (..., C) float32 in [−1, 1] that drives the robot towards the IK solution."""
        p = self.params
        goal, tensions, lengths = self._unpack(obs)
        target_tensions, target_lengths = self.targets(goal)
        if self.action_mode == "tension":
            action = 2.0 * target_tensions / p.max_tension - 1.0
        elif self.action_mode == "tension_delta":
            action = (target_tensions - tensions) / (self.tension_step * p.max_tension)
        else:
            action = (target_lengths - lengths) / self.length_step
        if self.action_mode != "tension":
            # scale, not clip: the commands move straight towards the target, and the reachable
            # set is convex (a linear image of the tension box), so length steps never leave it
            # (per-cable clipping can stall at the set's boundary, where the env scales back)
            largest = np.max(np.abs(action), axis=-1, keepdims=True)
            action = action / np.maximum(largest, 1.0)
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
