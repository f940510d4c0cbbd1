"""Oracles for the Track and Pose tasks: inverse kinematics on the CCKA/PCC model every step.

* :class:`TrackingIKController` (Track): IK on where the target will be after this step,
  ``target + target_velocity·dt`` (a one-step feed-forward read from the observation), so on the
  analytic backend the error left is the path's curvature over one step (µm), not the 1 mm a
  lagging controller would keep at the default speed.
* :class:`PoseIKController` (Pose): pose IK (``cdcr_gym.model.ik.solve_pose_ik``) on the goal
  position and tip direction, cached per goal (the LM solve costs milliseconds).

Both are :class:`~cdcr_gym.controllers.ik.AnalyticIKController` s with another goal: open loop
(the default) they command the IK tensions (or cable lengths) from the current state in the env's
action mode, closed loop on the model only (open loop on another backend). With ``feedback=True``
they correct from the measured tip (and, for Pose, the measured tip direction) by the resolved-rate
law of :mod:`cdcr_gym.controllers.ik`. Track nulls the error of this step and adds the target's
motion over the step as a feed-forward, J⁺·(target_velocity·dt)/ρ, so the integrator need not lag
a moving target. ρ estimates how much more the real robot bends than the model for the held
command, without state: the bending norm of the *sensed* cable lengths over that of the held
tensions (both through the PCC model), clipped to ``RATIO_RANGE`` and 1 while the held shape is
nearly straight (``RATIO_MIN_BENDING``). On the analytic backend ρ = 1; on bullet (gravity on)
it is ≈ 1.2 and takes the mean tracking RMS from 2.19 to 1.64 mm (100 episodes, docs/tasks.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.controllers.ik import FEEDBACK_GAIN, AnalyticIKController
from cdcr_gym.model.ik import solve_pose_ik
from cdcr_gym.model.params import RobotParams
from cdcr_gym.tasks.observation import ObservationSpec

__all__ = ["TrackingIKController", "PoseIKController"]

#: Clip range of the physics/model bending ratio that scales Track's closed-loop feed-forward.
RATIO_RANGE = (0.7, 1.5)
#: Held bending (rad, norm over sections) below which the ratio is taken as 1 (0/0 when straight).
RATIO_MIN_BENDING = 0.1


class TrackingIKController(AnalyticIKController):
    """IK on the target one step ahead, for the Track task's flat observation.

    Args:
        params: the robot the IK assumes.
        spec: the env's observation layout; the controller reads ``target``,
            ``target_velocity``, ``tensions`` and ``cable_lengths``.
        action_mode: the env's action mode.
        tension_step: the env's ``tension_step`` (fraction of max_tension per step).
        length_step: the env's ``length_step`` (m per step).
        timestep: the time (s) the target moves per step (``Track.step_time``), > 0.
        feedback: False: open loop; True: closed loop on the measured tip, with the target's
            motion over the step as feed-forward (module docstring).
        gain: integrator gain per control step of the closed loop, in (0, 1].
    """

    DRIVE_IK = False  # displacement modes: the tension/shape targets, converted

    def __init__(
        self,
        params: RobotParams,
        spec: ObservationSpec,
        action_mode: str = "tension_delta",
        tension_step: float = 0.05,
        length_step: float = 0.002,
        timestep: float = 0.02,
        feedback: bool = False,
        gain: float = FEEDBACK_GAIN,
        displacement_step: float = defaults.DISPLACEMENT_STEP,
        *,
        drive_softening: float = 0.0,
    ) -> None:
        super().__init__(
            params,
            spec,
            action_mode,
            tension_step,
            length_step,
            feedback,
            gain,
            displacement_step,
            drive_softening=drive_softening,
        )
        self.timestep = validation.positive(timestep, "timestep")

    @classmethod
    def from_env(
        cls, env: Any, feedback: bool = False, gain: float = FEEDBACK_GAIN
    ) -> TrackingIKController:
        """A controller matched to a Track ``env`` (single or batched, possibly wrapped)."""
        env = env.unwrapped
        return cls(
            env.params,
            env.observation_spec,
            env.action_mode,
            env.tension_step,
            env.length_step,
            env.task.step_time(env.core.backend),
            feedback,
            gain,
            env.displacement_step,
            drive_softening=env.drive_softening,
        )

    def _feedback_terms(self, obs: Any) -> tuple[np.ndarray, np.ndarray, Any, np.ndarray]:
        spec = self.spec
        forward = self.timestep * spec.decode(obs, "target_velocity")
        target = spec.decode(obs, "target")
        # the physics robot bends more (or less) per commanded model radian than the model:
        # the sensed shape over the held one scales the feed-forward (stateless estimate)
        forward = forward / self._bending_ratio(obs)[..., None]
        # the error of this step, the motion of the target over the step fed forward: at a
        # steady pace the tip then sits on the target (an error on the target one step ahead
        # would leave it one step, speed·dt, behind)
        return target - spec.decode(obs, "tip"), forward, obs, target + forward

    def _bending_ratio(self, obs: Any) -> np.ndarray:
        """|bending of the sensed cable lengths| / |bending of the held tensions| (...), clipped
        to RATIO_RANGE; 1 where the held shape is nearly straight (below RATIO_MIN_BENDING)."""
        tensions, lengths = self._robot_state(obs)
        model = self._model
        held = np.linalg.norm(model.bending_from_tensions(tensions), axis=(-2, -1))
        sensed = np.linalg.norm(model.bending_from_lengths(lengths), axis=(-2, -1))
        ratio = np.clip(sensed / np.maximum(held, 1e-12), *RATIO_RANGE)
        return np.where(held > RATIO_MIN_BENDING, ratio, 1.0)

    def _unpack(self, obs: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        spec = self.spec
        target = spec.decode(obs, "target") + self.timestep * spec.decode(obs, "target_velocity")
        tensions = spec.decode(obs, "tensions") * self.params.max_tension
        lengths = spec.decode(obs, "cable_lengths") * self._length_span + self._run_lengths
        return target, tensions, lengths


class PoseIKController(AnalyticIKController):
    """Pose IK (position and tip direction) as a policy for the Pose task (flat or Dict).

    The goal is read from ``goal`` and ``goal_direction`` (flat) or ``desired_goal`` (Dict: the
    position then the direction); solutions are cached per goal. Arguments as
    :class:`~cdcr_gym.controllers.ik.AnalyticIKController`; closed loop, the features nulled are
    the tip (m) and ℓ·(tip direction) (ℓ the robot's length, the weight ``solve_pose_ik`` gives
    the direction), measured from ``tip`` and ``tip_direction`` (flat) or ``achieved_goal``.
    """

    DRIVE_IK = False  # displacement modes: the tension/shape targets, converted

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def features(self, w: np.ndarray) -> np.ndarray:
        """Tip (m) and ℓ·(tip direction) (m), (..., 6), of the model shapes w (..., S, 2)."""
        tip, direction = self._model.tip_and_direction_from_bending(w)
        return np.concatenate([tip, self.params.length * direction], axis=-1)

    def _goal_features(self, goal: np.ndarray) -> np.ndarray:
        goal = np.array(goal, dtype=np.float64)
        goal[..., 3:] *= self.params.length
        return goal

    def _feedback_terms(self, obs: Any) -> tuple[np.ndarray, np.ndarray, Any, np.ndarray]:
        if isinstance(obs, dict):
            goal = np.asarray(obs["desired_goal"], dtype=np.float64)
            measured = np.asarray(obs["achieved_goal"], dtype=np.float64)
            state = obs["observation"]
        else:
            spec, state = self.spec, obs
            goal = np.concatenate(
                [spec.decode(obs, "goal"), spec.decode(obs, "goal_direction")], -1
            )
            measured = np.concatenate(
                [spec.decode(obs, "tip"), spec.decode(obs, "tip_direction")], -1
            )
        error = goal - measured
        error[..., 3:] *= self.params.length
        return error, np.zeros_like(error), state, goal

    def targets(self, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pose-IK solution for goals (..., 6) (position m, direction): (tensions N, lengths m)."""
        goal = np.asarray(goal, dtype=np.float64)
        key = goal.tobytes() + str(goal.shape).encode()
        hit = self._cache.get(key)
        if hit is None:
            solution = solve_pose_ik(goal[..., :3], goal[..., 3:], self.params)
            hit = solution.tensions, self._model.lengths_from_bending(solution.bending)
            if len(self._cache) > 4096:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def _unpack(self, obs: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        spec = self.spec
        if isinstance(obs, dict):
            goal = np.asarray(obs["desired_goal"], dtype=np.float64)
            state = obs["observation"]
        else:
            state = obs
            goal = np.concatenate(
                [spec.decode(obs, "goal"), spec.decode(obs, "goal_direction")], axis=-1
            )
        tensions = spec.decode(state, "tensions") * self.params.max_tension
        lengths = spec.decode(state, "cable_lengths") * self._length_span + self._run_lengths
        return goal, tensions, lengths
