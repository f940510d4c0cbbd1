"""The Obstacle task's oracle: a collision-free plan in tension space, then tracking of the plan.

**Plan** (once per episode, on the CCKA/PCC model): RRT-Connect (Kuffner & LaValle 2000) in
the tension box [0, max_tension]^C, scaled to the unit box, from the current tensions to the IK
tensions of the goal (``model.ik.solve_ik``). A configuration is free when every part of the
model's robot (``cdcr_gym.tasks.collision``) keeps ``margin`` from every sphere; an edge is
free when its points every ``resolution`` (unit-box L∞ step) are. Trees grow by ``step``
towards a random configuration (towards the other tree's root with probability 0.1) and the
other tree tries the straight connection; the path is then shortened by random shortcuts. The
generator of a plan is seeded from the scene, so the controller is deterministic per episode.
With ``candidates`` > 1 that many plans are made (independent generator streams) and the
shortest is kept (sum of the segments' L∞ lengths: the number of control steps it takes): a
random plan may go round a sphere on either side, the shortest of several mostly takes the same
side for similar scenes (tried for cloning the planner, ``training/run/demonstrations.py``:
a closer clone, not a better policy; docs/tasks.md, BC11).

**Tracking**: in ``tension_delta`` mode the action moves the held tensions straight towards the
next waypoint (scaled so the largest entry is ±1, as the reach IK controller does), so the
robot follows exactly the checked segments on the model. On another backend this is open loop.

**Closed loop** (``feedback=True``): the plan is followed as above up to its last waypoint (the
model's IK tensions of the goal); from there the reach IK controller's closed-loop law
(:mod:`cdcr_gym.controllers.ik`: resolved-rate correction from the measured tip) takes the tip
onto the goal. The correction is not collision-checked: it moves the tip from where the open-loop
plan ends (centimetres off on the physics robot) to the goal, whose shape the scenes keep
clear of every sphere.
"""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.controllers.ik import FEEDBACK_GAIN, AnalyticIKController
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import cached_model
from cdcr_gym.tasks.collision import clearance, model_geometry
from cdcr_gym.tasks.observation import ObservationSpec

__all__ = ["ObstaclePlanner", "rrt_connect"]


def _edge_points(a: np.ndarray, b: np.ndarray, resolution: float) -> np.ndarray:
    n = max(1, int(np.ceil(np.max(np.abs(b - a)) / resolution)))
    return a + np.linspace(0.0, 1.0, n + 1)[:, None] * (b - a)


def rrt_connect(
    start: np.ndarray,
    goal: np.ndarray,
    free: Any,
    rng: np.random.Generator,
    step: float = 0.1,
    resolution: float = 0.005,
    iterations: int = 2000,
    shortcuts: int = 60,
) -> list[np.ndarray] | None:
    """RRT-Connect in the unit box [0, 1]^C.

    Args:
        start, goal: (C,) configurations.
        free: callable, configurations (M, C) -> (M,) bool.
        rng: the generator of the random samples.
        step: tree extension length (L∞).
        resolution: edge check spacing (L∞).
        iterations: most extension rounds.
        shortcuts: random shortcut attempts on the path found.

    Returns:
        The waypoints from ``start`` to ``goal`` (collision-free edges), or None.
    """

    def edge_free(a: np.ndarray, b: np.ndarray) -> bool:
        return bool(np.all(free(_edge_points(a, b, resolution))))

    if edge_free(start, goal):
        return [start, goal]
    trees = [([start], [-1]), ([goal], [-1])]
    dim = len(start)
    for _ in range(iterations):
        nodes_a, parents_a = trees[0]
        nodes_b, parents_b = trees[1]
        target = nodes_b[0] if rng.random() < 0.1 else rng.random(dim)
        arr = np.asarray(nodes_a)
        near = int(np.argmin(np.max(np.abs(arr - target), axis=1)))
        delta = target - arr[near]
        length = np.max(np.abs(delta))
        new = target if length <= step else arr[near] + delta * (step / length)
        if not edge_free(arr[near], new):
            trees.reverse()
            continue
        nodes_a.append(new)
        parents_a.append(near)
        arr_b = np.asarray(nodes_b)
        near_b = int(np.argmin(np.max(np.abs(arr_b - new), axis=1)))
        if edge_free(arr_b[near_b], new):
            path_a = _trace(nodes_a, parents_a, len(nodes_a) - 1)
            path_b = _trace(nodes_b, parents_b, near_b)
            path = path_a[::-1] + path_b
            if not np.array_equal(path[0], start):
                path = path[::-1]
            return _shortcut(path, edge_free, rng, shortcuts)
        trees.reverse()
    return None


def _trace(nodes: list[np.ndarray], parents: list[int], i: int) -> list[np.ndarray]:
    out = []
    while i >= 0:
        out.append(nodes[i])
        i = parents[i]
    return out


def _shortcut(path: list[np.ndarray], edge_free: Any, rng: np.random.Generator, tries: int):
    path = list(path)
    for _ in range(tries):
        if len(path) <= 2:
            break
        i, j = sorted(rng.choice(len(path), size=2, replace=False).tolist())
        if j - i > 1 and edge_free(path[i], path[j]):
            path = path[: i + 1] + path[j:]
    return path


class ObstaclePlanner:
    """RRT-Connect plan plus plan tracking, as a policy for the Obstacle task (module docstring).

    Args:
        params: the robot the model assumes.
        spec: the env's observation layout (reads ``goal``, ``obstacle_centres``,
            ``obstacle_radii``, ``tensions``).
        tension_step: the env's ``tension_step`` (fraction of max_tension per step).
        margin: clearance (m) every planned configuration keeps from every sphere, >= 0.
        step: RRT-Connect tree extension (unit tension box, L∞).
        resolution: spacing of the edge checks (unit tension box, L∞).
        iterations: most RRT-Connect extension rounds.
        seed: base seed of the plans' generators.
        feedback: False: open loop; True: closed loop on the measured tip once the plan's last
            waypoint is commanded (module docstring).
        gain: integrator gain per control step of the closed loop, in (0, 1].
        candidates: plans made per scene, the shortest kept (>= 1; 1: the first found).
    """

    def __init__(
        self,
        params: RobotParams,
        spec: ObservationSpec,
        tension_step: float = 0.05,
        margin: float = 0.004,
        step: float = 0.1,
        resolution: float = 0.005,
        iterations: int = 2000,
        seed: int = 0,
        feedback: bool = False,
        gain: float = FEEDBACK_GAIN,
        candidates: int = 1,
    ) -> None:
        self.params = params
        self.spec = spec
        self.tension_step = validation.positive(tension_step, "tension_step", upper=1.0)
        self.margin = validation.positive(margin, "margin", allow_zero=True)
        self.step = validation.positive(step, "step")
        self.resolution = validation.positive(resolution, "resolution")
        self.iterations = validation.integer(iterations, "iterations", 1)
        self.seed = validation.integer(seed, "seed", 0)
        self.feedback = validation.flag(feedback, "feedback")
        self.gain = validation.positive(gain, "gain", upper=1.0)
        self.candidates = validation.integer(candidates, "candidates", 1)
        #: the closed-loop reach law used after the plan (feedback mode)
        self.reach = AnalyticIKController(
            params, spec, "tension_delta", self.tension_step, feedback=True, gain=self.gain
        )
        self._model = cached_model(params)
        self._plans: dict[bytes, list[np.ndarray]] = {}
        self._progress: dict[bytes, int] = {}
        self._closing: dict[bytes, bool] = {}
        #: whether the last plan made was found (False: the direct route is commanded)
        self.last_plan_found = True

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> ObstaclePlanner:
        """A planner matched to an Obstacle ``env`` (single or batched, possibly wrapped)."""
        env = env.unwrapped
        if env.action_mode != "tension_delta":
            raise ValueError(
                f"ObstaclePlanner needs action_mode='tension_delta', got {env.action_mode!r}"
            )
        return cls(env.params, env.observation_spec, env.tension_step, **kwargs)

    @property
    def mode(self) -> str:
        """``"closed_loop"`` or ``"open_loop"`` (the label of this planner's results)."""
        return "closed_loop" if self.feedback else "open_loop"

    def free(self, unit: np.ndarray, spheres: np.ndarray) -> np.ndarray:
        """(M,) bool: configurations ``unit`` (M, C) (tensions / max_tension) keep ``margin``
        from ``spheres`` (K, 4) on the model."""
        w = self._model.bending_from_tensions(unit * self.params.max_tension)
        gap = clearance(
            model_geometry(self._model, w),
            spheres,
            0.5 * self.params.backbone_diameter,
            self.params.disk_radius,
        )
        return np.all(gap > self.margin, axis=1)

    def plan(self, start: np.ndarray, goal: np.ndarray, spheres: np.ndarray) -> list[np.ndarray]:
        """Waypoints (unit tensions) from ``start`` (C,) N to the IK tensions of ``goal`` (3,) m
        around ``spheres`` (K, 4); the direct route if no plan is found."""
        t_max = self.params.max_tension
        target = solve_ik(goal, self.params).tensions / t_max
        s = np.clip(start / t_max, 0.0, 1.0)
        key = np.concatenate([goal, spheres.ravel()]).tobytes()
        best, best_length = None, np.inf
        for c in range(self.candidates):
            stream = [self.seed, zlib.crc32(key)] + ([c] if c else [])
            path = rrt_connect(
                s,
                target,
                lambda q: self.free(q, spheres),
                np.random.default_rng(stream),
                self.step,
                self.resolution,
                self.iterations,
            )
            if path is not None:
                length = float(np.sum(np.max(np.abs(np.diff(path, axis=0)), axis=1)))
                if length < best_length:
                    best, best_length = path, length
                if len(path) == 2:  # the straight edge is free: nothing is shorter
                    break
        self.last_plan_found = best is not None
        return [s, target] if best is None else best

    def _row_action(self, obs: np.ndarray) -> np.ndarray:
        spec = self.spec
        goal = spec.decode(obs, "goal")
        centres = spec.decode(obs, "obstacle_centres").reshape(-1, 3)
        radii = spec.decode(obs, "obstacle_radii")
        spheres = np.concatenate([centres, radii[:, None]], axis=1)[radii > 0]
        unit = spec.decode(obs, "tensions")
        key = np.concatenate([goal, spheres.ravel()]).tobytes()
        if key not in self._plans:
            if len(self._plans) > 1024:
                self._plans.clear()
                self._progress.clear()
                self._closing.clear()
            self._plans[key] = self.plan(unit * self.params.max_tension, goal, spheres)
            self._progress[key] = 1
        path = self._plans[key]
        k = self._progress[key]
        if np.max(np.abs(path[0] - unit)) < 1e-5:  # at the start: a (new) episode on this scene
            k = 1
            self._closing[key] = False
        while k < len(path) - 1 and np.max(np.abs(path[k] - unit)) < 1e-5:
            k += 1
        self._progress[key] = k
        if self.feedback:
            if k == len(path) - 1 and np.max(np.abs(path[k] - unit)) < 1e-5:
                self._closing[key] = True
            if self._closing.get(key, False):
                return self.reach.action(obs[None])[0].astype(np.float64)
        action = (path[k] - unit) / self.tension_step
        return action / max(1.0, float(np.max(np.abs(action))))

    def action(self, obs: Any) -> np.ndarray:
        """Action(s) (..., C) float32 for flat observations (..., size)."""
        obs = np.asarray(obs)
        rows = obs.reshape(-1, obs.shape[-1])
        out = np.stack([self._row_action(row) for row in rows])
        return np.clip(out.reshape(obs.shape[:-1] + (-1,)), -1.0, 1.0).astype(np.float32)

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
