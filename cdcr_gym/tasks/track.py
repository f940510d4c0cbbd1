"""Trajectory tracking: keep the tip on a target that moves along a smooth, reachable path."""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.defaults import NOMINAL_TIMESTEP
from cdcr_gym.model.workspace import sample_tensions
from cdcr_gym.tasks.base import GoalTask, robot_state_fields
from cdcr_gym.tasks.observation import Field

__all__ = ["Track", "NOMINAL_TIMESTEP", "TargetPaths"]


#: Samples of the tension loop mapped through the backend's statics (knots of the tip path).
_KNOTS = 64
#: Catmull-Rom sub-samples per knot interval, before resampling to uniform arc length.
_SUBSAMPLES = 16
#: Points of the arc-length table of a path.
_TABLE = 1024


def _periodic_bspline(control: np.ndarray, n: int) -> np.ndarray:
    """``n`` points (n, C) of the closed uniform cubic B-spline of ``control`` (K, C) points,
    at parameters k·K/n. Each point is a convex combination of four control points, so the
    curve stays in their convex hull (a tension box stays a tension box)."""
    k = len(control)
    u = np.arange(n) * (k / n)
    seg = np.floor(u).astype(int)
    t = (u - seg)[:, None]
    b0 = (1 - t) ** 3 / 6
    b1 = (3 * t**3 - 6 * t**2 + 4) / 6
    b2 = (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6
    b3 = t**3 / 6
    c = control
    return b0 * c[seg % k] + b1 * c[(seg + 1) % k] + b2 * c[(seg + 2) % k] + b3 * c[(seg + 3) % k]


def _closed_catmull_rom(knots: np.ndarray, sub: int) -> np.ndarray:
    """The closed Catmull-Rom curve through ``knots`` (K, 3), ``sub`` points per interval:
    (K·sub, 3), starting at knot 0 (it passes through every knot)."""
    k = len(knots)
    t = (np.arange(sub) / sub)[:, None]
    p0, p1 = np.roll(knots, 1, axis=0), knots
    p2, p3 = np.roll(knots, -1, axis=0), np.roll(knots, -2, axis=0)
    pts = 0.5 * (
        2 * p1[:, None]
        + (-p0 + p2)[:, None] * t
        + (2 * p0 - 5 * p1 + 4 * p2 - p3)[:, None] * t**2
        + (-p0 + 3 * p1 - 3 * p2 + p3)[:, None] * t**3
    )
    return pts.reshape(k * sub, 3)


class TargetPaths:
    """Closed target paths of N envs, tabulated at uniform arc length.

    ``table[i, j]`` (N, M, 3) m is the point at arc length j·L_i/M of env i's loop (length
    ``loop_length[i]`` = L_i m), so the point at arc length s is a linear blend of two rows.
    """

    def __init__(self, num_envs: int) -> None:
        self.table = np.zeros((num_envs, _TABLE + 1, 3))
        self.loop_length = np.ones(num_envs)

    def set(self, i: int, knots: np.ndarray) -> None:
        """Make env ``i``'s path the closed Catmull-Rom curve through ``knots`` (K, 3) m."""
        dense = _closed_catmull_rom(knots, _SUBSAMPLES)
        closed = np.concatenate([dense, dense[:1]])
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
        length = arc[-1]
        s = np.linspace(0.0, length, _TABLE + 1)
        self.table[i] = np.stack([np.interp(s, arc, closed[:, a]) for a in range(3)], axis=-1)
        self.loop_length[i] = length

    def at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(points (N, 3) m, unit tangents (N, 3)) at arc lengths ``s`` (N,) m (wrapped)."""
        u = np.mod(s / self.loop_length, 1.0) * _TABLE
        j = np.minimum(u.astype(int), _TABLE - 1)
        frac = (u - j)[:, None]
        rows = np.arange(len(s))
        a, b = self.table[rows, j], self.table[rows, j + 1]
        chord = b - a
        norm = np.linalg.norm(chord, axis=1, keepdims=True)
        return a + frac * chord, chord / np.maximum(norm, 1e-300)


class Track(GoalTask):
    """Follow a target that moves along a smooth closed path at a constant speed.

    **Target path**: drawn at every reset, in the robot's configuration space so that it is
    reachable by construction: ``n_waypoints`` tension vectors are drawn as Reach draws a goal
    shape (``model.workspace.sample_tensions``); the closed uniform cubic B-spline through them
    (a convex combination of tension vectors at every point, so within [0, max_tension]) is
    sampled at 64 knots, each knot mapped to a tip by the backend's own statics
    (``Backend.equilibrium``), and the tip path is the closed Catmull-Rom curve through those
    tips (cm-scale knot spacing: its deviation from the reachable set is far below a mm). The
    target starts at the first knot and moves along the path at ``speed`` m/s: after k steps it
    is at arc length ``speed·k·dt``, with dt the backend's control timestep (pybullet: 0.02 s by
    default) or, on the quasi-static analytic backend, the nominal ``NOMINAL_TIMESTEP`` = 0.02 s
    (so the target moves ``speed·dt`` = 1 mm per step by default on both).

    **Observation fields** (flat): ``tip`` (3, m), ``target`` (3, m), ``target_velocity``
    (3, m/s), ``error`` = target − tip (3, m), ``error_tanh`` = tanh(error / 1 cm) (3), then
    the robot state (normalised ``tensions`` and ``cable_lengths``, one per cable). Not
    goal-conditioned (the goal moves; ``goal_conditioned=True`` raises ``ValueError``).
    Paper robot, default speed (21 entries):

    | index | observation | min | max | unit |
    |-------|-------------|-----|-----|------|
    | 0–2 | tip position x, y, z in R0 | -0.641 | 0.641 | m |
    | 3–5 | target position x, y, z in R0 | -0.641 | 0.641 | m |
    | 6–8 | target velocity in R0 | -0.05 | 0.05 | m/s |
    | 9–11 | target − tip | -1.282 | 1.282 | m |
    | 12–14 | tanh((target − tip) / 0.01 m) | -1 | 1 | – |
    | 15–17 | cable tensions / max_tension | 0 | 1 | – |
    | 18–20 | (cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans | -1 | 1 | – |

    **Reward**: −‖target − tip‖ (m) per step. **Success** (per step, ``info["is_success"]``):
    distance <= ``distance_threshold``.
    **info**: ``distance`` (m), ``is_success``, ``target`` (m), ``target_velocity`` (m/s),
    ``tracking_rms`` and ``tracking_max`` (m): RMS and maximum of the distance over the steps
    after the first ``settle_steps`` of the episode (0.0 until then), and ``tracking_steps``
    (how many steps they cover). At an episode's last step they are the episode's tracking
    errors.

    **Starting state**: the env's (straight by default); the target starts at its path's first
    point, so the first ``settle_steps`` steps are the approach. **Episode end**: truncation only.

    Args:
        speed: target speed along its path (m/s), > 0.
        settle_steps: steps at the start of an episode left out of ``tracking_rms`` /
            ``tracking_max`` (>= 0).
        distance_threshold: radius (m) of ``is_success``, > 0.
        n_waypoints: tension waypoints of a closed path (>= 3).
        timestep: control timestep (s) that sets the target's step; None: the backend's, or
            ``NOMINAL_TIMESTEP`` on a quasi-static backend.
    """

    name = "Track"
    goal_size = 0
    goal_name = "target"
    goal_description = "target position x, y, z in R0"

    def __init__(
        self,
        speed: float = 0.05,
        settle_steps: int = 25,
        distance_threshold: float = defaults.DISTANCE_THRESHOLD,
        n_waypoints: int = 6,
        timestep: float | None = None,
    ) -> None:
        self.speed = validation.positive(speed, "speed")
        self.settle_steps = validation.integer(settle_steps, "settle_steps", 0)
        self.distance_threshold = validation.positive(distance_threshold, "distance_threshold")
        self.n_waypoints = validation.integer(n_waypoints, "n_waypoints", 3)
        self.timestep = None if timestep is None else validation.positive(timestep, "timestep")
        self.dt = NOMINAL_TIMESTEP if self.timestep is None else self.timestep

    def step_time(self, backend: Backend) -> float:
        """The time (s) the target moves per step on ``backend``: ``timestep`` if given, else the
        backend's control timestep, or ``NOMINAL_TIMESTEP`` on a quasi-static backend."""
        if self.timestep is not None:
            return self.timestep
        dt = float(backend.control_timestep)
        return dt if dt > 0.0 else NOMINAL_TIMESTEP

    def bind(self, params, num_envs: int) -> None:
        super().bind(params, num_envs)
        n = self.num_envs
        self.paths = TargetPaths(n)
        self.steps = np.zeros(n, dtype=np.int64)
        self.velocity = np.zeros((n, 3))
        self._sum_sq = np.zeros(n)
        self._max = np.zeros(n)
        self._count = np.zeros(n, dtype=np.int64)

    @property
    def target(self) -> np.ndarray:
        """(N, 3) target positions (m): the task's goal, moving."""
        return self.goal

    def fields(self, goal_conditioned: bool) -> list[Field]:
        block = self.position_fields()
        v = self.speed
        velocity = Field.uniform(
            "target_velocity", 3, -v, v, "m/s", "target velocity in R0", ("x", "y", "z")
        )
        return [
            block["tip"],
            block["target"],
            velocity,
            block["error"],
            block["error_tanh"],
            *robot_state_fields(self.params),
        ]

    # -- paths ----------------------------------------------------------------------------------
    def check_goal(self, goal: Any, m: int) -> np.ndarray:
        raise ValueError(
            "options['goal'] is not supported by the Track task (its target moves along "
            "a path drawn at reset)"
        )

    def reset_goals(
        self,
        idx: np.ndarray,
        rngs: list[np.random.Generator],
        backend: Backend,
        goal: np.ndarray | None = None,
    ) -> None:
        if goal is not None:
            self.check_goal(goal, idx.size)
        self.dt = self.step_time(backend)
        for i, rng in zip(idx.tolist(), rngs):
            waypoints = sample_tensions(rng, self.params, self.n_waypoints)
            loop = _periodic_bspline(waypoints, _KNOTS)
            self.paths.set(i, backend.equilibrium(loop).tip)
        self.steps[idx] = 0
        self._sum_sq[idx] = 0.0
        self._max[idx] = 0.0
        self._count[idx] = 0
        self._place(idx)

    def _place(self, idx: np.ndarray | None = None) -> None:
        point, tangent = self.paths.at(self.speed * self.dt * self.steps)
        if idx is None:
            self.goal[:], self.velocity[:] = point, self.speed * tangent
        else:
            self.goal[idx], self.velocity[idx] = point[idx], self.speed * tangent[idx]

    def advance(self, backend: Backend, readings: Readings) -> None:
        # fresh arrays, not in-place updates: an in-place ufunc costs ~2.5 calls at small N
        self.steps = self.steps + 1
        self._place()
        d = self.distance(readings)
        counted = self.steps > self.settle_steps
        self._sum_sq = self._sum_sq + np.where(counted, d * d, 0.0)
        self._max = np.where(counted, np.maximum(self._max, d), self._max)
        self._count = self._count + counted

    def path_points(self, index: int = 0, n: int = 256) -> np.ndarray:
        """``n`` points (n, 3) m of env ``index``'s closed target path (for plots)."""
        s = np.linspace(0.0, self.paths.loop_length[index], n)
        table = self.paths.table[index]
        u = s / self.paths.loop_length[index] * _TABLE
        return np.stack([np.interp(u, np.arange(_TABLE + 1), table[:, a]) for a in range(3)], -1)

    # -- per step -------------------------------------------------------------------------------
    def observe_extra(
        self, readings: Readings, out: np.ndarray, s: dict[str, slice], goal_conditioned: bool
    ) -> None:
        out[s["target_velocity"]] = self.velocity.T

    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        reward, success, info = super().evaluate(readings)
        count = self._count
        info["target_velocity"] = self.velocity.copy()
        info["tracking_rms"] = np.sqrt(self._sum_sq / np.maximum(count, 1))
        info["tracking_max"] = self._max.copy()
        info["tracking_steps"] = count.copy()
        return reward, success, info

    def info_keys(self) -> tuple[str, ...]:
        return (
            "distance",
            "is_success",
            "target",
            "target_velocity",
            "tracking_rms",
            "tracking_max",
            "tracking_steps",
        )
