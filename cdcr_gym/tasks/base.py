"""The task interface: what the agent must do, separate from the robot (dm_control's split).

A :class:`Task` samples each episode's goal from the env's generator, declares its observation
fields, and turns the backend's :class:`~cdcr_gym.backends.base.Readings` into observations,
rewards, success flags and ``info`` entries. It reads the robot only through the readings and
``Backend.equilibrium`` (to draw goals the backend can reach); it never commands the robot.

Everything is batched over the N envs of the core (the single env is N = 1): goals are (N, ·)
arrays, readings (N, ·) arrays.
"""

from __future__ import annotations

import abc
from typing import Any

import numpy as np
from gymnasium import spaces

from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.envs.observation import Field, ObservationSpec
from cdcr_gym.model.params import RobotParams

__all__ = [
    "Task",
    "robot_state_fields",
    "fill_robot_state",
    "robot_state_values",
    "one_env_info",
    "REWARD_TYPES",
]

#: Reward types: dense (a negative cost each step) or sparse (−1 until success, then 0).
REWARD_TYPES = ("dense", "sparse")


def robot_state_fields(params: RobotParams) -> list[Field]:
    """The robot-state fields every task observes: normalised tensions and cable lengths.

    * ``tensions``: T_i / max_tension, in [0, 1];
    * ``cable_lengths``: (l_i − L_i)/(π r_i m_i), in [−1, 1], where L_i is the backbone length
      cable i runs along, r_i its radius and m_i the number of sections it passes (each bends
      by at most π, so |l_i − L_i| <= π r_i m_i).
    """
    c = params.n_cables
    return [
        Field.uniform("tensions", c, 0.0, 1.0, "–", "cable tensions / max_tension"),
        Field.uniform(
            "cable_lengths",
            c,
            -1.0,
            1.0,
            "–",
            "(cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans",
        ),
    ]


class RobotStateScale:
    """Constants of :func:`fill_robot_state` for a robot (precomputed once)."""

    def __init__(self, params: RobotParams) -> None:
        sections = np.asarray(params.cable_section)
        self.inv_max_tension = 1.0 / params.max_tension
        self.run_lengths = np.asarray(params.cable_run_lengths)
        self.inv_length_span = 1.0 / (np.pi * np.asarray(params.cable_radii) * (sections + 1))
        self.inv_length_span_col = self.inv_length_span[:, None]  # (C, 1): per field row
        self.run_lengths_col = self.run_lengths[:, None]
        self.run_lengths_list = self.run_lengths.tolist()
        self.inv_span_list = self.inv_length_span.tolist()


def fill_robot_state(
    out: np.ndarray,
    tension_slice: slice,
    length_slice: slice,
    readings: Readings,
    scale: RobotStateScale,
) -> None:
    """Write the ``tensions`` and ``cable_lengths`` fields of ``readings`` into the field-major
    observation buffer ``out`` (size, N)."""
    np.multiply(
        readings.tensions.T, scale.inv_max_tension, out=out[tension_slice], casting="unsafe"
    )
    np.multiply(
        readings.cable_lengths.T - scale.run_lengths_col,
        scale.inv_length_span_col,
        out=out[length_slice],
        casting="unsafe",
    )


def goal_distance(achieved_goal: np.ndarray, desired_goal: np.ndarray) -> np.ndarray:
    """Euclidean distance (m) between goal vectors (..., 3), in float64 (shape (...))."""
    return np.linalg.norm(
        np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64), axis=-1
    )


def one_env_info(info: dict[str, np.ndarray]) -> dict[str, Any]:
    """Env 0's entries of a batched ``info`` (N = 1): a Python scalar for an (1,) entry, else
    the env's row (a view)."""
    return {key: value.item() if value.shape == (1,) else value[0] for key, value in info.items()}


def robot_state_values(readings: Readings, scale: RobotStateScale) -> dict[str, list[float]]:
    """The ``tensions`` and ``cable_lengths`` fields of env 0 as Python floats (the arithmetic of
    :func:`fill_robot_state`, for tasks' one-env fast paths)."""
    return {
        "tensions": [t * scale.inv_max_tension for t in readings.tensions.ravel().tolist()],
        "cable_lengths": [
            (length - run) * inv
            for length, run, inv in zip(
                readings.cable_lengths.ravel().tolist(), scale.run_lengths_list, scale.inv_span_list
            )
        ],
    }


class Task(abc.ABC):
    """A task on the env core (batched over N envs).

    Subclasses implement the abstract methods; the env core calls :meth:`bind` once, then
    :meth:`reset_goals` at every (partial) reset, and after every step :meth:`advance` then
    :meth:`evaluate`; the envs end an episode where :meth:`terminal` says so.
    """

    #: Short name used in registered ids (``"Reach"`` → ``CCKAReach-v0``).
    name: str = ""
    #: Size of the goal vector of the goal-conditioned (Dict) observation; 0 = no GoalEnv form.
    goal_size: int = 0

    params: RobotParams
    num_envs: int

    def bind(self, params: RobotParams, num_envs: int) -> None:
        """Attach the task to a robot and a number of envs (allocates the goal arrays)."""
        self.params = params
        self.num_envs = int(num_envs)

    @abc.abstractmethod
    def observation_spec(self, goal_conditioned: bool) -> ObservationSpec:
        """The flat observation layout, or with ``goal_conditioned`` the ``observation`` part
        of the Dict observation (achieved/desired goals are separate)."""

    @abc.abstractmethod
    def reset_goals(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        backend: Backend,
        goal: np.ndarray | None = None,
    ) -> None:
        """Draw new goals for envs ``idx`` from their generators ``rngs`` (one per env, in
        order), or set the given ``goal`` (len(idx), goal size) — validated and projected by
        the task."""

    @abc.abstractmethod
    def observe(self, readings: Readings, out: np.ndarray, goal_conditioned: bool) -> None:
        """Fill the field-major observation buffer ``out`` (spec size, N) from ``readings``
        (field rows are contiguous: writing them is much faster than strided columns)."""

    @abc.abstractmethod
    def achieved_goal(self, readings: Readings) -> np.ndarray:
        """(N, goal_size) achieved goals (goal-conditioned form)."""

    @abc.abstractmethod
    def desired_goal(self) -> np.ndarray:
        """(N, goal_size) desired goals (goal-conditioned form)."""

    @abc.abstractmethod
    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        """(reward (N,), success (N,) bool, task info entries of (N, ...) arrays)."""

    def observe_one(self, readings: Readings) -> np.ndarray:
        """The flat observation (spec size,) float32 of a task bound to one env (the single
        env's hot path). Default: :meth:`observe` into a one-column buffer; a task may override
        it with the same arithmetic in Python floats."""
        out = np.empty((self.observation_spec(False).size, 1), dtype=np.float32)
        self.observe(readings, out, False)
        return out[:, 0]

    def evaluate_one(self, readings: Readings) -> tuple[float, bool, dict[str, Any]]:
        """(reward, success, info) of a task bound to one env: :meth:`evaluate`'s entries for
        env 0 (a Python float or bool for a per-env scalar, else the env's array). Default:
        :meth:`evaluate` and its row 0; a task may override it with the same arithmetic in
        Python floats."""
        reward, success, info = self.evaluate(readings)
        return float(reward[0]), bool(success[0]), one_env_info(info)

    @abc.abstractmethod
    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """Goal-conditioned reward, vectorised over leading dimensions (for HER)."""

    def goal_space(self) -> spaces.Box:
        """The Box of one achieved/desired goal (goal-conditioned form): by default a point,
        each coordinate within ±(robot length) m."""
        ell = self.params.length
        return spaces.Box(-ell, ell, shape=(self.goal_size,), dtype=np.float32)

    def advance(self, backend: Backend, readings: Readings) -> None:
        """Move the task on by one control step, after the backend has moved (a moving target,
        a collision check on the backend's geometry). Called by the env core after every step,
        before :meth:`evaluate`; default: nothing."""

    def terminal(self) -> np.ndarray:
        """(N,) bool: envs whose episode the task ends now (e.g. on a collision); default none.
        Read-only (callers combine it into their own arrays)."""
        none = getattr(self, "_never_terminal", None)
        if none is None or none.shape != (self.num_envs,):
            none = self._never_terminal = np.zeros(self.num_envs, dtype=bool)
            none.flags.writeable = False
        return none

    def info_keys(self) -> tuple[str, ...]:
        """Names of the ``info`` entries :meth:`evaluate` returns."""
        return ()

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        """What the renderer draws for env ``index`` besides the robot (e.g. ``goal``)."""
        return {}
