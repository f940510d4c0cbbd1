"""The task interface: what the agent must do, separate from the robot (dm_control's split).

A :class:`Task` samples each episode's goal from the env's generator, declares its observation
fields, and turns the backend's :class:`~cdcr_gym.backends.base.Readings` into observations,
rewards, success flags and ``info`` entries. It reads the robot only through the readings and
``Backend.equilibrium`` (to draw goals the backend can reach); it never commands the robot.

Everything is batched over the N envs of the core (the single env is N = 1, on the same code):
goals are (N, ·) arrays, readings (N, ·) arrays, observations written into a field-major
(size, N) buffer.
"""

from __future__ import annotations

import abc
import math
from typing import Any

import numpy as np
from gymnasium import spaces

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.tendons import holding_displacements
from cdcr_gym.model.workspace import sample_tensions_each
from cdcr_gym.tasks.observation import Field, ObservationSpec

__all__ = [
    "Task",
    "GoalTask",
    "robot_state_fields",
    "fill_robot_state",
    "goal_distance",
    "check_points",
    "check_goal_pair",
    "GOAL_REACH",
    "REWARD_TYPES",
    "ERROR_SCALE",
]

#: Reward types: dense (a negative cost each step) or sparse (−1 until success, then 0).
REWARD_TYPES = ("dense", "sparse")

#: Length scale (m) of the saturated error feature tanh((goal − tip)/ERROR_SCALE).
ERROR_SCALE = 0.01
# as a 0-d float64 array: a cheaper numpy operand than a Python float (the same bits)
_INV_ERROR_SCALE = np.array(1.0 / ERROR_SCALE)


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
        self.inv_max_tension = np.array(1.0 / params.max_tension)  # 0-d: a cheap operand
        self.run_lengths = np.asarray(params.cable_run_lengths)
        self.inv_length_span = 1.0 / (np.pi * np.asarray(params.cable_radii) * (sections + 1))
        self.inv_length_span_col = self.inv_length_span[:, None]  # (C, 1): per field row
        self.run_lengths_col = self.run_lengths[:, None]


def fill_robot_state(
    out: np.ndarray,
    tension_slice: slice,
    length_slice: slice,
    readings: Readings,
    scale: RobotStateScale,
    work: tuple[np.ndarray, np.ndarray],
) -> None:
    """Write the ``tensions`` and ``cable_lengths`` fields of ``readings`` into the field-major
    observation buffer ``out`` (size, N), computed in the two float64 scratch arrays ``work``
    (C, N) (overwritten) and copied (see :meth:`GoalTask.bind`)."""
    a, b = work
    out[tension_slice] = np.multiply(readings.tensions.T, scale.inv_max_tension, a)
    lengths = np.subtract(readings.cable_lengths.T, scale.run_lengths_col, b)
    out[length_slice] = np.multiply(lengths, scale.inv_length_span_col, a)


#: GoalTask attributes that are per-step scratch (reallocated after unpickling).
_SCRATCH = ("_work", "_work_points", "_work_cables")

#: A given goal position may lie at most this many robot lengths from the base.
GOAL_REACH = 10.0


def check_points(value: Any, name: str, m: int, size: int, length: float) -> np.ndarray:
    """Given goals ``value`` of shape (size,) or (m, size) (the first 3 entries a position m in
    R0), finite, each position within :data:`GOAL_REACH` × ``length`` of the base, as an
    (m, size) float64 array.

    Raises:
        ValueError: naming ``name``, the shape wanted or the offending value.
    """
    arr = validation.real_array(value, name, allow_bool=False)
    if arr.shape not in ((size,), (m, size)):
        raise ValueError(
            f"{name} must have shape ({size},) or ({m}, {size}), got shape {arr.shape}"
        )
    arr = np.array(np.broadcast_to(arr, (m, size)))
    far = np.linalg.norm(arr[:, :3], axis=1) > GOAL_REACH * length
    if far.any():
        raise ValueError(
            f"{name}: a goal position must lie within {GOAL_REACH:g} robot lengths "
            f"({GOAL_REACH * length:g} m) of the base, got {arr[np.flatnonzero(far)[0], :3]!r} "
            f"(m, in R0)"
        )
    return arr


def check_goal_pair(achieved: Any, desired: Any, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``compute_reward``'s goals: real, finite, last axis ``size``, shapes that broadcast.

    Raises:
        ValueError: naming ``achieved_goal`` or ``desired_goal`` and the shape or value.
    """
    if (  # the env's own call every step: two float arrays of one shape, cheap to check
        type(achieved) is np.ndarray
        and type(desired) is np.ndarray
        and achieved.dtype.kind == "f"
        and desired.dtype.kind == "f"
        and achieved.shape == desired.shape
        and achieved.shape[-1:] == (size,)
    ):
        if achieved.size <= 8:
            finite = all(map(math.isfinite, achieved.ravel().tolist() + desired.ravel().tolist()))
        else:
            finite = bool(np.isfinite(achieved).all() and np.isfinite(desired).all())
        if finite:
            return achieved, desired
    out = []
    for value, name in ((achieved, "achieved_goal"), (desired, "desired_goal")):
        if type(value) is np.ndarray and value.dtype.kind == "f":
            arr = value
            if not np.isfinite(arr).all():
                raise ValueError(f"{name} must be finite, got {value!r}")
        else:
            arr = validation.real_array(value, name, allow_bool=False)
        if arr.shape[-1:] != (size,):
            raise ValueError(f"{name} must have shape (..., {size}), got shape {arr.shape}")
        out.append(arr)
    try:
        np.broadcast_shapes(out[0].shape, out[1].shape)
    except ValueError:
        raise ValueError(
            f"achieved_goal and desired_goal must have broadcastable shapes (..., {size}), got "
            f"{out[0].shape} and {out[1].shape}"
        ) from None
    return out[0], out[1]


def goal_distance(
    achieved_goal: np.ndarray,
    desired_goal: np.ndarray,
    work: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Euclidean distance (m) between points (..., 3), over the last axis, in float64 (shape
    (...)): the one distance of every goal task (reward, success, ``info``, HER). ``work``:
    two float64 scratch arrays of the points' broadcast shape (overwritten) for the
    intermediate results of a caller that computes it every step (see :meth:`GoalTask.bind`)."""
    if work is None:
        e = np.subtract(achieved_goal, desired_goal, dtype=np.float64)
        e = e * e
    else:
        e = np.subtract(achieved_goal, desired_goal, work[0])
        e = np.multiply(e, e, work[1])
    return np.sqrt(e[..., 0] + e[..., 1] + e[..., 2])


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
    #: The drives' ``(d_min, d_max)`` (m) when the env commands tendon displacements (set by
    #: the env core in a displacement action mode), else None: :meth:`sample_goal_readings`
    #: then draws goals the drives can hold.
    goal_displacement_range: tuple[float, float] | None = None

    def bind(self, params: RobotParams, num_envs: int) -> None:
        """Attach the task to a robot and a number of envs (allocates the goal arrays)."""
        self.params = params
        self.num_envs = int(num_envs)

    def sample_goal_readings(self, rngs: list[np.random.Generator], backend: Backend) -> Readings:
        """Readings of one reachable goal shape per generator in ``rngs`` (M = len(rngs)).

        Tensions are drawn by ``model.workspace.sample_tensions_each`` and the shape is the
        backend's static equilibrium under them (``Backend.equilibrium``). In a displacement
        action mode (:attr:`goal_displacement_range` set) the goal must also be one the drives
        can hold: the displacements that hold those tensions at that shape,
        d = s + (T − T0)/k + c·Σ(T − T0) (s the backend's shortenings, c the robot's
        ``base_compliance``; a slack tendon at its slack point:
        :func:`cdcr_gym.model.tendons.holding_displacements`),
        are clipped to ``displacement_range``, and a shape whose d was clipped is replaced by
        the drives' equilibrium under the clipped d (``Backend.displacement_equilibrium``).
        So every goal is the equilibrium of a displacement command within the range.
        """
        r = backend.equilibrium(sample_tensions_each(rngs, self.params))
        if self.goal_displacement_range is None:
            return r
        low, high = self.goal_displacement_range
        p = self.params
        d = holding_displacements(
            backend.straight_cable_lengths - r.cable_lengths,
            r.tensions,
            p.cable_stiffness,
            p.cable_pretension,
            p.base_compliance,
        )
        out = (d < low) | (d > high)
        rows = np.flatnonzero(out.any(axis=1))
        if rows.size == 0:
            return r
        held = backend.displacement_equilibrium(np.clip(d[rows], low, high))
        fields = {}
        for name, value in r._asdict().items():
            if isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) == len(rngs):
                value = value.copy()
                value[rows] = getattr(held, name)
            fields[name] = value
        return type(r)(**fields)

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

    def check_goal(self, goal: Any, m: int) -> np.ndarray:
        """``reset(options={"goal": goal})`` for ``m`` envs, validated without changing
        anything: the (m, goal_size) float64 goals. The env checks every reset option this way
        before it draws or changes anything (a refused reset leaves the env as it was).

        Raises:
            ValueError: naming ``options['goal']``: this task takes no given goal (default).
        """
        raise ValueError(f"options['goal'] is not supported by the {type(self).__name__} task")

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """Goal-conditioned reward, vectorised over leading dimensions (for HER); a task
        without a goal-conditioned form (``goal_size == 0``) has none."""
        raise NotImplementedError(f"the {type(self).__name__} task has no compute_reward")

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
        none = self.__dict__.get("_never_terminal")
        if none is None or none.size != self.num_envs:
            none = self._never_terminal = np.zeros(self.num_envs, dtype=bool)
            none.flags.writeable = False
        return none

    def info_keys(self) -> tuple[str, ...]:
        """Names of the ``info`` entries :meth:`evaluate` returns."""
        return ()

    #: Whether :meth:`set_difficulty` is implemented (a curriculum can make episodes easier).
    has_curriculum = False

    def set_difficulty(self, difficulty: float) -> None:
        """Make the episodes drawn from now on easier (``difficulty`` in (0, 1]; 1 = the task as
        configured), for a training curriculum. Tasks without one (:attr:`has_curriculum`
        False) raise ``ValueError``."""
        raise ValueError(
            f"the {type(self).__name__} task has no curriculum (set_difficulty); tasks with one: "
            f"Obstacle"
        )

    #: Whether :meth:`model_clearance` is implemented (the env's ``safety_filter`` needs it).
    has_obstacles = False

    def model_clearance(self, tensions: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Predicted clearance (M,) m to the obstacles of envs ``rows`` (M,) of the model's
        shapes held by ``tensions`` (M, C) N (negative: a collision). Tasks without obstacles
        (:attr:`has_obstacles` False) raise ``ValueError``."""
        raise ValueError(
            f"the {type(self).__name__} task has no obstacles (model_clearance); tasks with "
            f"obstacles: Obstacle"
        )

    def measured_clearance(self) -> np.ndarray:
        """Clearance (N,) m of each robot to its obstacles as measured on the backend after the
        last reset or step (negative: a collision). Tasks without obstacles raise
        ``ValueError``."""
        raise ValueError(f"the {type(self).__name__} task has no obstacles (measured_clearance)")

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        """What the renderer draws for env ``index`` besides the robot (e.g. ``goal``)."""
        return {}


class GoalTask(Task):
    """A task whose goal is a point for the tip (Reach, Pose, Obstacle; Track's moving target).

    Owns, once for every such task: the goal arrays (:attr:`goal` (N, 3) m, a view of the
    field-major rows :attr:`goal_rows` (3, N), updated in place), the position block of the
    observation (fields ``tip``, the goal (:attr:`goal_name`), ``error`` = goal − tip and
    ``error_tanh`` = tanh(error / :data:`ERROR_SCALE`): :meth:`position_fields`) and its
    filling with the robot state (:meth:`observe`, as row blocks), the distance
    (:func:`goal_distance`), the dense/sparse reward of a distance
    (:meth:`reward_from_distance`) and :meth:`compute_reward`, vectorised over the last axis so
    that HER can relabel batches, and the base of ``info`` (:meth:`evaluate`).

    Subclasses choose the field order (:meth:`fields`), write their own fields
    (:meth:`observe_extra`) and extend :meth:`evaluate`.
    """

    goal_size = 3
    #: Name and description of the goal's observation field (and ``info`` entry).
    goal_name = "goal"
    goal_description = "goal position x, y, z in R0"

    reward_type = defaults.REWARD_TYPE
    distance_threshold = defaults.DISTANCE_THRESHOLD

    def __getstate__(self) -> dict[str, Any]:
        """Pickling (env snapshots, copies) keeps :attr:`goal` a view of :attr:`goal_rows`:
        numpy pickles the two arrays separately, which would cut the link (a reset writing
        ``goal`` would then leave ``goal_rows`` stale)."""
        state = self.__dict__.copy()
        for key in ("goal", *_SCRATCH):  # (scratch: reallocated, not pickled)
            state.pop(key, None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        if "goal_rows" in state:
            self.goal = self.goal_rows.T
            self._allocate_scratch()

    def bind(self, params: RobotParams, num_envs: int) -> None:
        super().bind(params, num_envs)
        self.goal_rows = np.zeros((3, self.num_envs))
        self.goal_rows[2] = params.length
        self.goal = self.goal_rows.T  # (N, 3) view of the rows
        self._scale = RobotStateScale(params)
        self._allocate_scratch()
        self._specs = {gc: ObservationSpec(self.fields(gc)) for gc in (False, True)}
        self._slices = {gc: spec.slices for gc, spec in self._specs.items()}

    def _allocate_scratch(self) -> None:
        """Float64 scratch pairs for the per-step intermediate results (never returned): each
        ufunc writes into one not aliasing its inputs. In-place ufuncs cost ~2.5 calls each at
        N = 1; fresh temporaries cost page faults at large N."""
        n, c = self.num_envs, self.params.n_cables
        self._work = (np.empty((3, n)), np.empty((3, n)))
        self._work_points = (self._work[0].T, self._work[1].T)  # (N, 3) views
        self._work_cables = (np.empty((c, n)), np.empty((c, n)))

    # -- observation ----------------------------------------------------------------------------
    def position_fields(self) -> dict[str, Field]:
        """The position block's fields by name: ``tip``, the goal, ``error``, ``error_tanh``."""
        ell = self.params.length
        xyz = ("x", "y", "z")
        goal = self.goal_name
        return {
            "tip": Field.uniform("tip", 3, -ell, ell, "m", "tip position x, y, z in R0", xyz),
            goal: Field.uniform(goal, 3, -ell, ell, "m", self.goal_description, xyz),
            "error": Field.uniform("error", 3, -2 * ell, 2 * ell, "m", f"{goal} − tip", xyz),
            "error_tanh": Field.uniform(
                "error_tanh", 3, -1.0, 1.0, "–", f"tanh(({goal} − tip) / {ERROR_SCALE} m)", xyz
            ),
        }

    def fields(self, goal_conditioned: bool) -> list[Field]:
        """The observation's fields in order (default, reach: the position block, then the
        robot state; goal-conditioned: tip and robot state)."""
        block = self.position_fields()
        robot = robot_state_fields(self.params)
        if goal_conditioned:
            return [block["tip"], *robot]
        return [*block.values(), *robot]

    def observation_spec(self, goal_conditioned: bool) -> ObservationSpec:
        return self._specs[goal_conditioned]

    def observe(self, readings: Readings, out: np.ndarray, goal_conditioned: bool) -> None:
        s = self._slices[goal_conditioned]
        self.fill_position(out, s, readings, goal_conditioned)
        fill_robot_state(
            out, s["tensions"], s["cable_lengths"], readings, self._scale, self._work_cables
        )
        self.observe_extra(readings, out, s, goal_conditioned)

    def fill_position(
        self, out: np.ndarray, s: dict[str, slice], readings: Readings, goal_conditioned: bool
    ) -> None:
        """Write the position block of ``readings`` into the field-major buffer ``out``."""
        tip = readings.tip.T
        out[s["tip"]] = tip
        if not goal_conditioned:
            goal, (a, b) = self.goal_rows, self._work  # float64 scratch (bind), then copied
            out[s[self.goal_name]] = goal
            out[s["error"]] = error = np.subtract(goal, tip, a)
            out[s["error_tanh"]] = np.tanh(np.multiply(error, _INV_ERROR_SCALE, b), a)

    def observe_extra(
        self, readings: Readings, out: np.ndarray, s: dict[str, slice], goal_conditioned: bool
    ) -> None:
        """Write the task's own fields into the field-major buffer ``out`` (default: none)."""

    # -- reward ---------------------------------------------------------------------------------
    def achieved_goal(self, readings: Readings) -> np.ndarray:
        return readings.tip

    def desired_goal(self) -> np.ndarray:
        return self.goal

    def distance(self, readings: Readings) -> np.ndarray:
        """(N,) distance (m) from the tip to the goal (:func:`goal_distance`)."""
        return goal_distance(readings.tip, self.goal)

    def reward_from_distance(self, distance: Any) -> Any:
        """``"dense"``: −distance (m); ``"sparse"``: −1 while distance > distance_threshold,
        else 0. Elementwise on arrays."""
        if self.reward_type == "dense":
            return -distance
        return -((distance > self.distance_threshold) * 1.0)

    def check_goal(self, goal: Any, m: int) -> np.ndarray:
        """A given goal point: shape (3,) or (m, 3) m in R0, finite, each within
        :data:`GOAL_REACH` robot lengths of the base (a goal farther away is a mistake, e.g. mm
        for m, not a point to project onto the workspace). Returns (m, 3).

        Raises:
            ValueError: naming ``options['goal']``, its shape or the offending value.
        """
        return check_points(goal, "options['goal']", m, self.goal_size, self.params.length)

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        achieved_goal, desired_goal = check_goal_pair(achieved_goal, desired_goal, self.goal_size)
        return self.reward_from_distance(goal_distance(achieved_goal, desired_goal))

    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        distance = goal_distance(readings.tip, self.goal, self._work_points)
        success = distance <= self.distance_threshold
        reward = self.reward_from_distance(distance)
        info = {"distance": distance, "is_success": success, self.goal_name: self.goal.copy()}
        return reward, success, info

    def info_keys(self) -> tuple[str, ...]:
        return ("distance", "is_success", self.goal_name)

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        return {self.goal_name: self.goal[index].copy()}
