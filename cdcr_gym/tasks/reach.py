"""Tip reaching: bring the tip to a goal point and hold it there."""

from __future__ import annotations

import math
from itertools import chain
from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.envs.observation import Field, ObservationSpec
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.model.workspace import sample_tensions_each
from cdcr_gym.tasks.base import (
    REWARD_TYPES,
    RobotStateScale,
    Task,
    fill_robot_state,
    goal_distance,
    robot_state_fields,
    robot_state_values,
)

__all__ = ["Reach", "ERROR_SCALE"]

#: Length scale (m) of the saturated error feature tanh((goal − tip)/ERROR_SCALE).
ERROR_SCALE = 0.01
_INV_ERROR_SCALE = 1.0 / ERROR_SCALE  # the same float as the batched path's 1.0 / ERROR_SCALE


class Reach(Task):
    """Reach a goal point with the tip (and hold it).

    **Goal**: a point (m, in R0) drawn each episode from the backend's own reachable set: a
    shape is drawn by ``model.workspace.sample_tensions`` (one section: area-uniform on the
    tension-reachable surface; several: see that function) and the goal is the tip of the
    backend's static equilibrium under those tensions (``Backend.equilibrium``). A goal given
    in ``reset(options={"goal": ...})`` is projected onto the reachable set of the model (the
    nearest tip within the tension limits, ``model.ik.solve_ik``).

    **Observation fields** (flat): ``tip`` (3, m), ``goal`` (3, m), ``error`` = goal − tip
    (3, m), ``error_tanh`` = tanh(error / 1 cm) (3), then the robot state (normalised
    ``tensions`` and ``cable_lengths``, one per cable). Goal-conditioned: ``observation`` =
    tip and robot state, ``achieved_goal`` = tip, ``desired_goal`` = goal.

    **Reward**: ``"dense"``: −‖goal − tip‖ (m) per step; ``"sparse"``: −1 while the distance
    exceeds ``distance_threshold``, else 0. **Success**: distance <= ``distance_threshold``.
    **info**: ``distance`` (m), ``is_success``, ``goal`` (m).

    Args:
        reward_type: ``"dense"`` or ``"sparse"``.
        distance_threshold: success radius (m), > 0.
    """

    name = "Reach"
    goal_size = 3

    def __init__(self, reward_type: str = "dense", distance_threshold: float = 0.005) -> None:
        self.reward_type = validation.choice(reward_type, "reward_type", REWARD_TYPES)
        self.distance_threshold = validation.positive(distance_threshold, "distance_threshold")
        self._dense = reward_type == "dense"

    def bind(self, params, num_envs: int) -> None:
        super().bind(params, num_envs)
        # (N, 3) view of field-major rows (3, N): observations copy contiguous rows
        self.goal = np.zeros((3, self.num_envs)).T
        self.goal[:, 2] = params.length
        self._scale = RobotStateScale(params)
        self._specs = {gc: self._build_spec(gc) for gc in (False, True)}
        self._slices = {gc: spec.slices for gc, spec in self._specs.items()}
        self._field_order = tuple(self._specs[False].slices)

    def _build_spec(self, goal_conditioned: bool) -> ObservationSpec:
        ell = self.params.length
        xyz = ("x", "y", "z")
        tip = Field.uniform("tip", 3, -ell, ell, "m", "tip position x, y, z in R0", xyz)
        if goal_conditioned:
            return ObservationSpec([tip, *robot_state_fields(self.params)])
        return ObservationSpec(
            [
                tip,
                Field.uniform("goal", 3, -ell, ell, "m", "goal position x, y, z in R0", xyz),
                Field.uniform("error", 3, -2 * ell, 2 * ell, "m", "goal − tip", xyz),
                Field.uniform("error_tanh", 3, -1.0, 1.0, "–", "tanh((goal − tip) / 0.01 m)", xyz),
                *robot_state_fields(self.params),
            ]
        )

    def observation_spec(self, goal_conditioned: bool) -> ObservationSpec:
        return self._specs[goal_conditioned]

    # -- goals ----------------------------------------------------------------------------------
    def reset_goals(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        backend: Backend,
        goal: np.ndarray | None = None,
    ) -> None:
        if goal is None:
            goals = backend.equilibrium(sample_tensions_each(rngs, self.params)).tip
        else:
            goal = validation.real_array(goal, "options['goal']")
            if goal.shape not in ((3,), (idx.size, 3)):
                raise ValueError(
                    f"options['goal'] must have shape (3,) or ({idx.size}, 3), "
                    f"got shape {goal.shape}"
                )
            goals = solve_ik(np.broadcast_to(goal, (idx.size, 3)), self.params).tip
        self.goal[idx] = goals

    # -- per step -------------------------------------------------------------------------------
    def observe(self, readings: Readings, out: np.ndarray, goal_conditioned: bool) -> None:
        s = self._slices[goal_conditioned]
        tip = readings.tip
        out[s["tip"]] = tip.T
        if not goal_conditioned:
            error = (self.goal - tip).T
            out[s["goal"]] = self.goal.T
            out[s["error"]] = error
            np.tanh(error * (1.0 / ERROR_SCALE), out=out[s["error_tanh"]], casting="unsafe")
        fill_robot_state(out, s["tensions"], s["cable_lengths"], readings, self._scale)

    def observe_one(self, readings: Readings) -> np.ndarray:
        """:meth:`observe` of the flat layout for one env, in Python floats (same arithmetic;
        at N = 1 a numpy call per field costs more than the numbers)."""
        tip = readings.tip.ravel().tolist()
        goal = self.goal.ravel().tolist()
        error = [g - t for g, t in zip(goal, tip)]
        tanh = math.tanh
        values = robot_state_values(readings, self._scale)
        values["tip"] = tip
        values["goal"] = goal
        values["error"] = error
        values["error_tanh"] = [tanh(e * _INV_ERROR_SCALE) for e in error]
        return np.array(
            list(chain.from_iterable(map(values.__getitem__, self._field_order))),
            dtype=np.float32,
        )

    def achieved_goal(self, readings: Readings) -> np.ndarray:
        return readings.tip

    def desired_goal(self) -> np.ndarray:
        return self.goal

    def _reward(self, distance: np.ndarray) -> np.ndarray:
        if self._dense:
            return -distance
        return -((distance > self.distance_threshold) * 1.0)

    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        e = self.goal - readings.tip
        distance = np.sqrt(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1] + e[:, 2] * e[:, 2])
        success = distance <= self.distance_threshold
        info = {"distance": distance, "is_success": success, "goal": self.goal.copy(order="K")}
        return self._reward(distance), success, info

    def evaluate_one(self, readings: Readings) -> tuple[float, bool, dict[str, Any]]:
        """:meth:`evaluate` for one env, in Python floats (same arithmetic)."""
        t0, t1, t2 = readings.tip.ravel().tolist()
        g0, g1, g2 = self.goal.ravel().tolist()
        e0, e1, e2 = g0 - t0, g1 - t1, g2 - t2
        d = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        success = d <= self.distance_threshold
        reward = -d if self._dense else -float(d > self.distance_threshold)
        return reward, success, {"distance": d, "is_success": success, "goal": self.goal[0].copy()}

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        distance = goal_distance(achieved_goal, desired_goal)
        return self._reward(distance)

    def info_keys(self) -> tuple[str, ...]:
        return ("distance", "is_success", "goal")

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        return {"goal": self.goal[index].copy()}
