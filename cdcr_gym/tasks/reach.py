"""Tip reaching: bring the tip to a goal point and hold it there."""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.tasks.base import ERROR_SCALE, REWARD_TYPES, GoalTask

__all__ = ["Reach", "ERROR_SCALE"]


class Reach(GoalTask):
    """Reach a goal point with the tip (and hold it).

    **Goal**: a point (m, in R0) drawn each episode from the backend's own reachable set: a
    shape is drawn by ``model.workspace.sample_tensions`` (one section: area-uniform on the
    tension-reachable surface; several: see that function) and the goal is the tip of the
    backend's static equilibrium under those tensions (``Backend.equilibrium``); in a
    displacement action mode, the equilibrium of a displacement command within the drives'
    range (``Task.sample_goal_readings``). A goal given
    in ``reset(options={"goal": ...})`` is projected onto the reachable set of the model (the
    nearest tip within the tension limits, ``model.ik.solve_ik``); it must be finite and within
    10 robot lengths of the base (``ValueError`` otherwise: a goal that far is a mistake).

    **Observation fields** (flat): ``tip`` (3, m), ``goal`` (3, m), ``error`` = goal − tip
    (3, m), ``error_tanh`` = tanh(error / 1 cm) (3), then the robot state (normalised
    ``tensions`` and ``cable_lengths``, one per cable). Goal-conditioned: ``observation`` =
    tip and robot state, ``achieved_goal`` = tip, ``desired_goal`` = goal.

    **Reward**: ``"dense"``: −d per step, d = ‖goal − tip‖ (m); with ``reward_log_scale`` = s
    (m), −s·ln(1 + d/s) instead: −d near the goal (d ≪ s) and only logarithmic far from it (d ≫
    s), so errors below s keep a larger share of the (normalised) reward's variation than under
    −d, where the first steps of a reach dominate it (the slope at d is 1/(1 + d/s) of −d's). ``"sparse"``:
    −1 while the distance exceeds ``distance_threshold``, else 0. **Success**: distance <=
    ``distance_threshold``. **info**: ``distance`` (m), ``is_success``, ``goal`` (m).

    Args:
        reward_type: ``"dense"`` or ``"sparse"``.
        distance_threshold: success radius (m), > 0.
        reward_log_scale: None (default: −d) or s > 0 (m): the dense reward −s·ln(1 + d/s).
            ``ValueError`` with a sparse reward.
    """

    name = "Reach"
    goal_size = 3

    def __init__(
        self,
        reward_type: str = defaults.REWARD_TYPE,
        distance_threshold: float = defaults.DISTANCE_THRESHOLD,
        reward_log_scale: float | None = None,
    ) -> None:
        self.reward_type = validation.choice(reward_type, "reward_type", REWARD_TYPES)
        self.distance_threshold = validation.positive(distance_threshold, "distance_threshold")
        self.reward_log_scale = None
        if reward_log_scale is not None:
            if self.reward_type != "dense":
                raise ValueError(
                    f"reward_log_scale shapes the dense reward, got reward_type={reward_type!r} "
                    f"with reward_log_scale={reward_log_scale!r}"
                )
            self.reward_log_scale = validation.positive(
                reward_log_scale, "reward_log_scale", unit="m"
            )

    def reward_from_distance(self, distance: Any) -> Any:
        """The task's reward of distances (m), elementwise: −s·ln(1 + d/s) with
        ``reward_log_scale`` = s, else :meth:`GoalTask.reward_from_distance` (−d or sparse)."""
        s = self.reward_log_scale
        if s is None:
            return super().reward_from_distance(distance)
        return -s * np.log1p(np.asarray(distance) / s)

    def reset_goals(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        backend: Backend,
        goal: np.ndarray | None = None,
    ) -> None:
        if goal is None:
            goals = self.sample_goal_readings(rngs, backend).tip
        else:
            goals = solve_ik(self.check_goal(goal, idx.size), self.params).tip
        self.goal[idx] = goals
