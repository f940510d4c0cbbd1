"""Pose reaching: bring the tip to a goal point with a goal tip direction."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.model.ik import solve_pose_ik
from cdcr_gym.tasks.base import (
    REWARD_TYPES,
    GoalTask,
    check_goal_pair,
    check_points,
    robot_state_fields,
)
from cdcr_gym.tasks.observation import Field

__all__ = ["Pose", "pose_errors"]


def pose_errors(achieved: np.ndarray, desired: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance m, angle rad) between poses (..., 6) = (position m, direction), over the last
    axis. Directions need not be unit vectors (they are normalised; a zero one counts as π)."""
    a = np.asarray(achieved, np.float64)
    d = np.asarray(desired, np.float64)
    distance = np.linalg.norm(a[..., :3] - d[..., :3], axis=-1)
    u, v = a[..., 3:6], d[..., 3:6]
    cross = np.linalg.norm(np.cross(u, v), axis=-1)
    dot = np.sum(u * v, axis=-1)
    angle = np.where((cross == 0.0) & (dot <= 0.0), np.pi, np.arctan2(cross, dot))
    return distance, angle


class Pose(GoalTask):
    """Reach a goal tip position **and** tip direction (and hold them).

    **Goal**: a pose drawn each episode from the backend's own reachable set, like Reach's goal:
    a shape is drawn by ``model.workspace.sample_tensions`` and the goal is the tip position
    (m, R0) and unit tip tangent of the backend's static equilibrium under those tensions
    (``Backend.equilibrium``). A goal given in ``reset(options={"goal": ...})`` is a (6,) array
    (position m, direction) replaced by the pose the backend reaches under the tensions of the
    model's least-squares pose IK within the tension limits (``model.ik.solve_pose_ik``).

    **One section**: a one-section robot has two shape degrees of freedom, so its tip direction
    is fixed by its tip position (θ = 2·atan2(ρ, z), φ = atan2(y, x)). The task still runs (the
    drawn goals are consistent poses) but then reduces to Reach. ``CCKAPose-v0`` defaults to
    the two-section ``tdcr2`` robot, where position and direction are independent (four shape
    degrees of freedom for five pose coordinates: goals are drawn from reachable shapes), and so
    does ``BulletPose-v0`` (``cdcr_gym.envs.factory.DEFAULT_ROBOTS``).

    **Observation fields** (flat): ``tip`` (3, m), ``tip_direction`` (3, unit), ``goal``
    (3, m), ``goal_direction`` (3, unit), ``error`` = goal − tip (3, m), ``error_tanh`` =
    tanh(error / 1 cm) (3), ``direction_error`` = goal_direction − tip_direction (3), then the
    robot state (normalised ``tensions`` and ``cable_lengths``). Goal-conditioned
    (``GoalCDCREnv``): ``observation`` = tip, tip_direction and robot state; ``achieved_goal``
    and ``desired_goal`` = (position m, direction) (6,).
    Flat, tdcr2 robot (33 entries):

    | index | observation | min | max | unit |
    |-------|-------------|-----|-----|------|
    | 0–2 | tip position x, y, z in R0 | -0.4 | 0.4 | m |
    | 3–5 | unit tip tangent in R0 | -1 | 1 | – |
    | 6–8 | goal position x, y, z in R0 | -0.4 | 0.4 | m |
    | 9–11 | unit goal direction in R0 | -1 | 1 | – |
    | 12–14 | goal − tip | -0.8 | 0.8 | m |
    | 15–17 | tanh((goal − tip) / 0.01 m) | -1 | 1 | – |
    | 18–20 | goal_direction − tip_direction | -2 | 2 | – |
    | 21–26 | cable tensions / max_tension | 0 | 1 | – |
    | 27–32 | (cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans | -1 | 1 | – |

    Goal-conditioned ``observation``, tdcr2 (18 entries):

    | index | observation | min | max | unit |
    |-------|-------------|-----|-----|------|
    | 0–2 | tip position x, y, z in R0 | -0.4 | 0.4 | m |
    | 3–5 | unit tip tangent in R0 | -1 | 1 | – |
    | 6–11 | cable tensions / max_tension | 0 | 1 | – |
    | 12–17 | (cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans | -1 | 1 | – |

    **Reward**: ``"dense"``: −(distance + ``angle_weight``·angle) per step (distance m, angle
    rad between the tip and goal directions: default 0.05 m/rad, so 5° costs as much as
    4.4 mm); ``"sparse"``: −1 until success, then 0. ``compute_reward`` is vectorised over the
    last axis (HER). **Success**: distance <= ``distance_threshold`` and angle <=
    ``angle_threshold``. **info**: ``distance`` (m), ``angle`` (rad), ``is_success``, ``goal``
    (m), ``goal_direction``.

    **Starting state**: the env's (straight by default). **Episode end**: truncation, or success
    with ``terminate_on_success``.

    Args:
        reward_type: ``"dense"`` or ``"sparse"``.
        distance_threshold: success radius (m), > 0.
        angle_threshold: success angle (rad), in (0, π]; default 5° = 0.0873 rad.
        angle_weight: weight (m/rad) of the angle in the dense reward, >= 0.
    """

    name = "Pose"
    goal_size = 6

    def __init__(
        self,
        reward_type: str = defaults.REWARD_TYPE,
        distance_threshold: float = defaults.DISTANCE_THRESHOLD,
        angle_threshold: float = float(np.deg2rad(5.0)),
        angle_weight: float = 0.05,
    ) -> None:
        self.reward_type = validation.choice(reward_type, "reward_type", REWARD_TYPES)
        self.distance_threshold = validation.positive(distance_threshold, "distance_threshold")
        self.angle_threshold = validation.positive(angle_threshold, "angle_threshold", np.pi)
        self.angle_weight = validation.positive(angle_weight, "angle_weight", allow_zero=True)
        self._dense = reward_type == "dense"

    def bind(self, params, num_envs: int) -> None:
        super().bind(params, num_envs)
        self.goal_direction = np.zeros((self.num_envs, 3))
        self.goal_direction[:, 2] = 1.0

    def fields(self, goal_conditioned: bool) -> list[Field]:
        block = self.position_fields()
        xyz = ("x", "y", "z")
        tip_dir = Field.uniform("tip_direction", 3, -1, 1, "–", "unit tip tangent in R0", xyz)
        robot = robot_state_fields(self.params)
        if goal_conditioned:
            return [block["tip"], tip_dir, *robot]
        return [
            block["tip"],
            tip_dir,
            block["goal"],
            Field.uniform("goal_direction", 3, -1, 1, "–", "unit goal direction in R0", xyz),
            block["error"],
            block["error_tanh"],
            Field.uniform("direction_error", 3, -2, 2, "–", "goal_direction − tip_direction", xyz),
            *robot,
        ]

    def goal_space(self) -> spaces.Box:
        ell = self.params.length
        low = np.array([-ell] * 3 + [-1.0] * 3, dtype=np.float32)
        return spaces.Box(low, -low, dtype=np.float32)

    # -- goals ----------------------------------------------------------------------------------
    def reset_goals(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        backend: Backend,
        goal: np.ndarray | None = None,
    ) -> None:
        if goal is None:
            r = self.sample_goal_readings(rngs, backend)
            position, direction = r.tip, r.tip_direction
        else:
            goal = self.check_goal(goal, idx.size)
            sol = solve_pose_ik(goal[:, :3], goal[:, 3:], self.params)
            model_dir = backend.equilibrium(sol.tensions)
            position, direction = model_dir.tip, model_dir.tip_direction
        self.goal[idx] = position
        self.goal_direction[idx] = direction / np.linalg.norm(direction, axis=1, keepdims=True)

    # -- per step -------------------------------------------------------------------------------
    def observe_extra(
        self, readings: Readings, out: np.ndarray, s: dict[str, slice], goal_conditioned: bool
    ) -> None:
        out[s["tip_direction"]] = readings.tip_direction.T
        if not goal_conditioned:
            out[s["goal_direction"]] = self.goal_direction.T
            out[s["direction_error"]] = (self.goal_direction - readings.tip_direction).T

    def achieved_goal(self, readings: Readings) -> np.ndarray:
        return np.concatenate([readings.tip, readings.tip_direction], axis=1)

    def desired_goal(self) -> np.ndarray:
        return np.concatenate([self.goal, self.goal_direction], axis=1)

    def _reward(self, distance: np.ndarray, angle: np.ndarray) -> np.ndarray:
        if self._dense:
            return -(distance + self.angle_weight * angle)
        ok = (distance <= self.distance_threshold) & (angle <= self.angle_threshold)
        return ok - 1.0

    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        distance, angle = pose_errors(self.achieved_goal(readings), self.desired_goal())
        success = (distance <= self.distance_threshold) & (angle <= self.angle_threshold)
        info = {
            "distance": distance,
            "angle": angle,
            "is_success": success,
            "goal": self.goal.copy(),
            "goal_direction": self.goal_direction.copy(),
        }
        return self._reward(distance, angle), success, info

    def check_goal(self, goal: Any, m: int) -> np.ndarray:
        """A given pose: shape (6,) or (m, 6) (position m in R0, direction), finite, the
        position within 10 robot lengths of the base, the direction non-zero. Returns (m, 6).

        Raises:
            ValueError: naming ``options['goal']``, its shape or the offending value.
        """
        goal = check_points(goal, "options['goal']", m, 6, self.params.length)
        if np.any(np.linalg.norm(goal[:, 3:], axis=1) == 0.0):
            raise ValueError(
                f"options['goal'] direction (entries 3-5) must be non-zero, got {goal!r}"
            )
        return goal

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        achieved_goal, desired_goal = check_goal_pair(achieved_goal, desired_goal, 6)
        return self._reward(*pose_errors(achieved_goal, desired_goal))

    def info_keys(self) -> tuple[str, ...]:
        return ("distance", "angle", "is_success", "goal", "goal_direction")

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        return {"goal": self.goal[index].copy()}
