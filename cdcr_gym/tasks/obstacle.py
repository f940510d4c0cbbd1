"""Reaching around obstacles: bring the tip to a goal without touching any sphere on the way."""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.model.statics import cached_model
from cdcr_gym.model.workspace import sample_tensions
from cdcr_gym.tasks.base import (
    REWARD_TYPES,
    GoalTask,
    check_goal_pair,
    goal_distance,
    robot_state_fields,
)
from cdcr_gym.tasks.collision import (
    RobotGeometry,
    backend_geometry,
    clearance,
    directions_out,
    model_geometry,
    nearest_backbone_points,
    route_clearance,
)
from cdcr_gym.tasks.observation import Field

__all__ = ["Obstacle", "ObstacleSceneError"]

#: Attempts to place a blocking sphere before an episode's scene is given up (then an error).
_ATTEMPTS = 400
#: Tensions sampled along the direct route for ``route_features`` (both ends included).
ROUTE_SAMPLES = 9


class ObstacleSceneError(RuntimeError):
    """No scene satisfying the Obstacle task's rules was found (arguments too demanding)."""


class Obstacle(GoalTask):
    """Reach a goal point with the tip without touching spheres placed in the way.

    **Scene** (drawn at every reset from the env's generator, on the CCKA/PCC model of the
    robot): a goal shape is drawn like Reach's (``model.workspace.sample_tensions``) and the goal
    is its tip on the backend (``Backend.equilibrium``). The *direct route* is the straight line
    in tension space from the start tensions to the IK tensions of the goal
    (``model.ik.solve_ik``) — exactly what the reach IK controller commands in ``tension_delta``
    mode. The first sphere blocks it: a shape of the route at a fraction drawn in [0.3, 0.8] is
    taken, a backbone point in its distal half, and a sphere of radius drawn in
    ``radius_range`` is centred within half a radius of that point (so the route passes through
    it). Up to ``max_obstacles − 1`` more spheres (the count is drawn in [``min_obstacles``,
    ``max_obstacles``]) are centred within a radius of the tips of random shapes. Every sphere
    keeps at least ``clearance_margin`` from the start shape, the drawn goal shape and the IK
    goal shape, so the goal has a collision-free configuration and the start is free; a sphere
    that cannot be placed is redrawn (up to 400 times, then ``ObstacleSceneError``).

    **Collision**: any part of the backbone (a rod of radius d/2) or of a disk (a disc of
    radius ``params.disk_radius``, base disk included) inside a sphere
    (``cdcr_gym.tasks.collision``), measured on the backend's own geometry after every step.

    **Observation fields** (flat): ``tip`` (3, m), ``goal`` (3, m), ``error`` = goal − tip
    (3, m), ``error_tanh`` = tanh(error / 1 cm) (3), ``obstacle_centres`` (3 per sphere, m,
    sphere by sphere), ``obstacle_radii`` (m), ``obstacle_mask`` (1 for a sphere, 0 for
    padding: absent spheres have centre 0 and radius 0), ``min_clearance`` (m, clipped to
    [−ℓ, 2ℓ]), then the robot state (normalised ``tensions`` and ``cable_lengths``). Not
    goal-conditioned (the reward depends on collisions, not only on the achieved goal).
    Paper robot, 3 spheres (40 entries):

    | index | observation | min | max | unit |
    |-------|-------------|-----|-----|------|
    | 0–2 | tip position x, y, z in R0 | -0.641 | 0.641 | m |
    | 3–5 | goal position x, y, z in R0 | -0.641 | 0.641 | m |
    | 6–8 | goal − tip | -1.282 | 1.282 | m |
    | 9–11 | tanh((goal − tip) / 0.01 m) | -1 | 1 | – |
    | 12–20 | sphere centres | -1.282 | 1.282 | m |
    | 21–23 | sphere radii (0: none) | 0 | 0.641 | m |
    | 24–26 | 1: sphere, 0: padding | 0 | 1 | – |
    | 27 | smallest robot–sphere clearance | -0.641 | 1.282 | m |
    | 28–30 | cable tensions / max_tension | 0 | 1 | – |
    | 31–33 | (cable length − L_i) / (π r_i m_i), L_i: backbone length the cable spans | -1 | 1 | – |

    With ``clearance_features=True`` three more fields follow ``min_clearance`` (before the
    robot state): ``obstacle_clearances`` (one per sphere, m, clipped to [−ℓ, 2ℓ]; padding 2ℓ),
    ``obstacle_directions`` (3 per sphere: the unit vector from the sphere's centre to the
    nearest point of the backbone, the way out of the sphere; padding 0) and ``collided`` (1
    once the robot has touched a sphere in this episode, else 0) — measured geometrically on the
    backend's backbone and disks (``cdcr_gym.tasks.collision``) on every backend. They tell the
    policy where each sphere is *relative to the robot* and whether the episode can still
    succeed, which the sphere centres alone leave it to learn (docs/tasks.md measures the
    effect).

    With ``route_features=True`` three more fields follow (before the robot state): they look
    *ahead* along the direct route from the tensions now to the goal's IK tensions (the route
    the reach IK would command from here; sampled at 9 tensions, shaped on the CCKA/PCC model,
    ``cdcr_gym.tasks.collision.route_clearance``): ``route_clearances`` (one per sphere, m,
    clipped to [−ℓ, 2ℓ]; negative: going straight on runs through that sphere; padding 2ℓ),
    ``route_fractions`` (one per sphere, in [0, 1]: where along the route it comes closest; 0
    now, 1 at the goal; padding 0) and ``route_directions`` (3 per sphere: the unit vector from
    the sphere's centre to the route's backbone where it comes closest — the side on which the
    straight way passes, i.e. which way is out; padding 0). Recomputed after every step.

    **Reward**: ``"dense"``: −‖goal − tip‖ (m) − ``collision_penalty`` on every step in
    collision − ``penetration_weight``·(penetration depth, m: −min_clearance when negative);
    ``"sparse"``: −1 until success, then 0, minus the same penalties. Both can add a shaping
    that is off by default: ``proximity_weight``·max(0, ``proximity_margin`` − min_clearance)
    (a graded cost of coming closer than the margin to a sphere, before touching it; it keeps
    growing inside) and ``success_bonus`` on every step that counts as a success (within the
    threshold and no collision so far: a collision forfeits the bonus for the rest of the
    episode).
    **Success**: distance <= ``distance_threshold`` and no collision so far in the episode.
    **info**: ``distance`` (m), ``is_success``, ``goal`` (m), ``collision`` (in collision now),
    ``collided`` (at any step of the episode so far), ``min_clearance`` (m, unclipped; negative
    = penetration), ``obstacles`` ((max_obstacles, 4) rows x, y, z, radius m; zero rows pad),
    ``contact_force`` (N: the spheres' total normal force on the robot; 0 unless the backend
    makes them solid, ``MuJoCoObstacle-v0(solid_obstacles=True)``).

    **Collisions**: on a backend that simulates obstacles (``Backend.supports_obstacles``:
    MuJoCo) the spheres are placed into its scene at reset and the clearance is the simulator's
    own (MuJoCo's geom distances of the link capsules and disk cylinders); elsewhere it is
    measured geometrically on the backend's backbone and disks (``cdcr_gym.tasks.collision``).

    **Starting state**: the env's (straight by default). **Episode end**: truncation; a
    collision ends the episode with ``terminate_on_collision=True``; success with the env's
    ``terminate_on_success``.

    Args:
        reward_type: ``"dense"`` or ``"sparse"``.
        distance_threshold: success radius (m), > 0.
        collision_penalty: reward subtracted on every step in collision (>= 0).
        penetration_weight: reward subtracted per metre of penetration (1/m·m, >= 0): a
            graded penalty (grazing costs little, running through a sphere much), 0 = off.
        terminate_on_collision: end the episode at the first collision.
        min_obstacles: fewest spheres per episode (>= 1).
        max_obstacles: most spheres per episode, and the padded count in the observation
            (>= min_obstacles).
        radius_range: (low, high) sphere radii (m), 0 < low <= high; None: (0.06, 0.12)·ℓ (ℓ
            the robot's length: 38–77 mm on the paper robot).
        clearance_margin: smallest distance (m) between a sphere and the start and goal shapes
            when a scene is made (>= 0).
        clearance_features: add the per-sphere clearances, the directions out of the spheres
            and the ``collided`` flag to the observation (see above).
        route_features: add the per-sphere clearances, positions and sides of the direct route
            from the tensions now to the goal's to the observation (see above).
        proximity_margin: distance (m, >= 0) to a sphere below which the proximity cost
            starts.
        proximity_weight: reward subtracted per metre closer than ``proximity_margin`` (1/m·m,
            >= 0), 0 = off.
        success_bonus: reward added on every step that counts as a success (>= 0), 0 = off.
        difficulty: in (0, 1]; scenes drawn at difficulty d < 1 are easier: sphere radii × d
            and at most ``min_obstacles`` + ⌊d·(``max_obstacles`` − ``min_obstacles``)⌋
            spheres (the observation keeps ``max_obstacles`` slots). 1: the task as configured.
            A training curriculum raises it during training (:meth:`set_difficulty`;
            ``curriculum`` in the training config).
    """

    has_curriculum = True
    has_obstacles = True

    name = "Obstacle"
    goal_size = 0

    def __init__(
        self,
        reward_type: str = defaults.REWARD_TYPE,
        distance_threshold: float = defaults.DISTANCE_THRESHOLD,
        collision_penalty: float = 0.5,
        penetration_weight: float = 0.0,
        terminate_on_collision: bool = False,
        min_obstacles: int = 1,
        max_obstacles: int = 3,
        radius_range: tuple[float, float] | None = None,
        clearance_margin: float = 0.01,
        clearance_features: bool = False,
        route_features: bool = False,
        proximity_margin: float = 0.0,
        proximity_weight: float = 0.0,
        success_bonus: float = 0.0,
        difficulty: float = 1.0,
    ) -> None:
        self.reward_type = validation.choice(reward_type, "reward_type", REWARD_TYPES)
        self.distance_threshold = validation.positive(distance_threshold, "distance_threshold")
        self.collision_penalty = validation.positive(
            collision_penalty, "collision_penalty", allow_zero=True
        )
        self.penetration_weight = validation.positive(
            penetration_weight, "penetration_weight", allow_zero=True
        )
        self.terminate_on_collision = validation.flag(
            terminate_on_collision, "terminate_on_collision"
        )
        self.min_obstacles = validation.integer(min_obstacles, "min_obstacles", 1)
        self.max_obstacles = validation.integer(max_obstacles, "max_obstacles", self.min_obstacles)
        if radius_range is not None:
            pair = validation.real_array(radius_range, "radius_range")
            if pair.shape != (2,) or not 0.0 < pair[0] <= pair[1]:
                raise ValueError(
                    f"radius_range must be (low, high) m with 0 < low <= high, got {radius_range!r}"
                )
            radius_range = (float(pair[0]), float(pair[1]))
        self.radius_range = radius_range
        self.clearance_margin = validation.positive(
            clearance_margin, "clearance_margin", allow_zero=True
        )
        self.clearance_features = validation.flag(clearance_features, "clearance_features")
        self.route_features = validation.flag(route_features, "route_features")
        self.proximity_margin = validation.positive(
            proximity_margin, "proximity_margin", allow_zero=True
        )
        self.proximity_weight = validation.positive(
            proximity_weight, "proximity_weight", allow_zero=True
        )
        self.success_bonus = validation.positive(success_bonus, "success_bonus", allow_zero=True)
        self.set_difficulty(difficulty)
        self._dense = reward_type == "dense"

    def bind(self, params, num_envs: int) -> None:
        super().bind(params, num_envs)
        n, k = self.num_envs, self.max_obstacles
        self.obstacles = np.zeros((n, k, 4))
        self.min_clearance = np.full(n, np.inf)
        self.collision = np.zeros(n, dtype=bool)
        self.collided = np.zeros(n, dtype=bool)
        self.contact_force = np.zeros(n)
        self.clearances = np.full((n, k), np.inf)  # per sphere (clearance_features)
        self.directions = np.zeros((n, k, 3))  # unit vectors out of each sphere
        self.goal_tensions = np.zeros((n, params.n_cables))  # the goal's IK tensions, N
        self.route_clearances = np.full((n, k), np.inf)  # route_features
        self.route_fractions = np.zeros((n, k))
        self.route_directions = np.zeros((n, k, 3))
        ell = params.length
        self.radii = self.radius_range or (0.06 * ell, 0.12 * ell)
        self._rod = 0.5 * params.backbone_diameter
        self._disk = params.disk_radius
        self._model = cached_model(params)

    def fields(self, goal_conditioned: bool) -> list[Field]:
        ell, k = self.params.length, self.max_obstacles
        labels = tuple(f"{i}{a}" for i in range(k) for a in ("x", "y", "z"))
        return [
            *self.position_fields().values(),
            Field.uniform(
                "obstacle_centres", 3 * k, -2 * ell, 2 * ell, "m", "sphere centres", labels
            ),
            Field.uniform("obstacle_radii", k, 0.0, ell, "m", "sphere radii (0: none)"),
            Field.uniform("obstacle_mask", k, 0.0, 1.0, "–", "1: sphere, 0: padding"),
            Field.uniform(
                "min_clearance", 1, -ell, 2 * ell, "m", "smallest robot–sphere clearance"
            ),
            *(self.clearance_fields() if self.clearance_features else []),
            *(self.route_fields() if self.route_features else []),
            *robot_state_fields(self.params),
        ]

    def clearance_fields(self) -> list[Field]:
        """The fields ``clearance_features`` adds (see the class docstring)."""
        ell, k = self.params.length, self.max_obstacles
        labels = tuple(f"{i}{a}" for i in range(k) for a in ("x", "y", "z"))
        return [
            Field.uniform(
                "obstacle_clearances", k, -ell, 2 * ell, "m", "robot–sphere clearance per sphere"
            ),
            Field.uniform(
                "obstacle_directions",
                3 * k,
                -1.0,
                1.0,
                "–",
                "unit vector from each sphere's centre to the nearest backbone point",
                labels,
            ),
            Field.uniform("collided", 1, 0.0, 1.0, "–", "1: a sphere was touched this episode"),
        ]

    def route_fields(self) -> list[Field]:
        """The fields ``route_features`` adds (see the class docstring)."""
        ell, k = self.params.length, self.max_obstacles
        labels = tuple(f"{i}{a}" for i in range(k) for a in ("x", "y", "z"))
        return [
            Field.uniform(
                "route_clearances",
                k,
                -ell,
                2 * ell,
                "m",
                "per sphere: smallest clearance along the direct route to the goal",
            ),
            Field.uniform(
                "route_fractions",
                k,
                0.0,
                1.0,
                "–",
                "per sphere: where along the direct route it comes closest (0 now, 1 goal)",
            ),
            Field.uniform(
                "route_directions",
                3 * k,
                -1.0,
                1.0,
                "–",
                "per sphere: unit vector from its centre to the route's backbone there",
                labels,
            ),
        ]

    def set_difficulty(self, difficulty: float) -> None:
        """Draw the scenes of the next resets at ``difficulty`` in (0, 1] (see the class
        docstring); a scene already drawn is kept."""
        self.difficulty = validation.positive(difficulty, "difficulty", upper=1.0)

    # -- scenes ---------------------------------------------------------------------------------
    def _free(self, geometry: RobotGeometry, sphere: np.ndarray) -> bool:
        """Whether ``sphere`` (4,) keeps more than ``clearance_margin`` from every shape."""
        gap = clearance(geometry, sphere[None, :], self._rod, self._disk)
        return bool(np.all(gap > self.clearance_margin))

    def make_scene(
        self, rng: np.random.Generator, start_tensions: np.ndarray, backend: Backend
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A goal (3,) m, spheres (max_obstacles, 4) and the goal's IK tensions (C,) N for one
        env (see the class docstring)."""
        model, params = self._model, self.params
        t_max = params.max_tension
        start_w = model.bending_from_tensions(start_tensions[None])
        d = self.difficulty
        lo, hi = self.radii if d == 1.0 else (d * self.radii[0], d * self.radii[1])
        most = self.min_obstacles + int(d * (self.max_obstacles - self.min_obstacles) + 1e-9)
        for attempt in range(_ATTEMPTS):
            if attempt % 8 == 0:
                goal_t = sample_tensions(rng, params, 1)
                goal = backend.equilibrium(goal_t).tip[0]
                ik = solve_ik(goal, params).tensions
                keep = np.concatenate([start_w, model.bending_from_tensions(goal_t)[:1]])
                keep = np.concatenate([keep, model.bending_from_tensions(ik[None])])
                keep_geometry = model_geometry(model, keep)  # once per goal, not per sphere
            lam = rng.uniform(0.3, 0.8)
            shape = model.bending_from_tensions(
                np.clip(start_tensions + lam * (ik - start_tensions), 0.0, t_max)[None]
            )
            points = model.backbone_points(shape, points_per_section=8)[0]
            distal = points[len(points) // 2 :]
            anchor = distal[rng.integers(len(distal))]
            radius = rng.uniform(lo, hi)
            offset = rng.normal(size=3)
            offset *= rng.uniform(0.0, 0.5 * radius) / np.linalg.norm(offset)
            sphere = np.array([*(anchor + offset), radius])
            if self._free(keep_geometry, sphere):
                break
        else:
            raise ObstacleSceneError(
                f"no blocking sphere found in {_ATTEMPTS} attempts (radius_range={self.radii}, "
                f"clearance_margin={self.clearance_margin})"
            )
        spheres = np.zeros((self.max_obstacles, 4))
        spheres[0] = sphere
        count = int(rng.integers(self.min_obstacles, most + 1))
        placed = 1
        for _ in range(_ATTEMPTS):
            if placed >= count:
                break
            tip = model.tip_from_bending(
                model.bending_from_tensions(sample_tensions(rng, params, 1))
            )[0]
            radius = rng.uniform(lo, hi)
            offset = rng.normal(size=3)
            offset *= rng.uniform(0.0, radius) / np.linalg.norm(offset)
            extra = np.array([*(tip + offset), radius])
            if self._free(keep_geometry, extra):
                spheres[placed] = extra
                placed += 1
        if placed < count:
            raise ObstacleSceneError(
                f"could place only {placed} of {count} spheres (min_obstacles="
                f"{self.min_obstacles}, radius_range={self.radii})"
            )
        return goal, spheres, ik

    def check_goal(self, goal: Any, m: int) -> np.ndarray:
        raise ValueError(
            "options['goal'] is not supported by the Obstacle task (goal and spheres are "
            "drawn together at reset)"
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
        start = backend.read().tensions
        for i, rng in zip(idx.tolist(), rngs):
            self.goal[i], self.obstacles[i], self.goal_tensions[i] = self.make_scene(
                rng, start[i], backend
            )
        if self.route_features:  # the goal's IK from the scene, not solved again
            self._route(start, idx)
        if backend.supports_obstacles:  # the spheres become the simulator's own geometry
            backend.set_obstacles(idx, self.obstacles[idx])
        self.collided[idx] = False
        self._check(backend, idx)

    def _check(self, backend: Backend, idx: np.ndarray | None = None) -> None:
        if not backend.supports_obstacles or self.clearance_features:
            geometry = backend_geometry(backend)
            per_sphere = clearance(geometry, self.obstacles, self._rod, self._disk)
            gap = per_sphere.min(1)
            if self.clearance_features:
                self._features(geometry, per_sphere, idx)
        if backend.supports_obstacles:  # the simulator's collision detection
            gap = np.asarray(backend.obstacle_clearance, dtype=np.float64)
            self.contact_force = np.asarray(backend.contact_forces, dtype=np.float64)
        hit = gap < 0.0
        if idx is None:
            self.min_clearance, self.collision = gap, hit
            self.collided |= hit
        else:
            self.min_clearance[idx], self.collision[idx] = gap[idx], hit[idx]
            self.collided[idx] |= hit[idx]

    def _features(
        self, geometry: RobotGeometry, per_sphere: np.ndarray, idx: np.ndarray | None
    ) -> None:
        """Store the per-sphere clearances (N, K) m and unit directions (N, K, 3) out of each
        sphere for envs ``idx`` (all if None)."""
        rows = slice(None) if idx is None else idx
        nearest = nearest_backbone_points(geometry, self.obstacles)[rows]
        self.directions[rows] = directions_out(nearest, self.obstacles[rows])
        self.clearances[rows] = per_sphere[rows]

    def _route(self, tensions: np.ndarray, idx: np.ndarray | None = None) -> None:
        """Store the direct-route features (``route_features``) from ``tensions`` (N, C) N, the
        tensions now, for envs ``idx`` (all if None)."""
        rows = slice(None) if idx is None else idx
        clear, where, side = route_clearance(
            self._model,
            tensions[rows],
            self.goal_tensions[rows],
            self.obstacles[rows],
            self._rod,
            self._disk,
            ROUTE_SAMPLES,
        )
        self.route_clearances[rows] = clear
        self.route_fractions[rows] = where
        self.route_directions[rows] = side

    def advance(self, backend: Backend, readings: Readings) -> None:
        self._check(backend)
        if self.route_features:
            self._route(readings.tensions)

    def terminal(self) -> np.ndarray:
        if self.terminate_on_collision:
            return self.collision.copy()
        return np.zeros(self.num_envs, dtype=bool)

    def model_clearance(self, tensions: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Clearance (M,) m of the PCC/CCKA shapes held by ``tensions`` (M, C) N to the spheres
        of envs ``rows`` (M,) (the env's ``safety_filter`` predicts with it)."""
        geometry = model_geometry(self._model, self._model.bending_from_tensions(tensions))
        return clearance(geometry, self.obstacles[rows], self._rod, self._disk).min(1)

    def measured_clearance(self) -> np.ndarray:
        """The smallest robot–sphere clearance (N,) m after the last step (``info``'s
        ``min_clearance``: the backend's geometry, or the simulator's own on MuJoCo)."""
        return self.min_clearance

    # -- per step -------------------------------------------------------------------------------
    def observe_extra(
        self, readings: Readings, out: np.ndarray, s: dict[str, slice], goal_conditioned: bool
    ) -> None:
        n, k, ell = self.num_envs, self.max_obstacles, self.params.length
        out[s["obstacle_centres"]] = self.obstacles[:, :, :3].reshape(n, 3 * k).T
        out[s["obstacle_radii"]] = self.obstacles[:, :, 3].T
        out[s["obstacle_mask"]] = (self.obstacles[:, :, 3] > 0.0).T
        out[s["min_clearance"]] = np.clip(self.min_clearance, -ell, 2 * ell)[None]
        if self.clearance_features:
            out[s["obstacle_clearances"]] = np.clip(self.clearances, -ell, 2 * ell).T
            out[s["obstacle_directions"]] = self.directions.reshape(n, 3 * k).T
            out[s["collided"]] = self.collided[None]
        if self.route_features:
            out[s["route_clearances"]] = np.clip(self.route_clearances, -ell, 2 * ell).T
            out[s["route_fractions"]] = self.route_fractions.T
            out[s["route_directions"]] = self.route_directions.reshape(n, 3 * k).T

    def evaluate(self, readings: Readings) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        distance = self.distance(readings)
        success = (distance <= self.distance_threshold) & ~self.collided
        info = {
            "distance": distance,
            "is_success": success,
            "goal": self.goal.copy(),
            "collision": self.collision.copy(),
            "collided": self.collided.copy(),
            "min_clearance": self.min_clearance.copy(),
            "obstacles": self.obstacles.copy(),
            "contact_force": self.contact_force.copy(),
        }
        return self.penalised(self.reward_from_success(distance, success), info), success, info

    def reward_from_success(self, distance: np.ndarray, success: np.ndarray) -> np.ndarray:
        """The goal part of the reward: ``"dense"`` −distance (m), ``"sparse"`` −1 until
        success, then 0; plus ``success_bonus`` on success."""
        reward = -distance if self.reward_type == "dense" else success - 1.0
        if self.success_bonus:
            reward = reward + self.success_bonus * success
        return reward

    def penalised(self, reward: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        """``reward`` minus the collision penalties of ``info`` (``collision``,
        ``min_clearance``): per step in collision, per metre of penetration, per metre closer
        than ``proximity_margin``."""
        reward = reward - self.collision_penalty * np.asarray(info["collision"])
        if self.penetration_weight or self.proximity_weight:
            gap = np.asarray(info["min_clearance"], dtype=np.float64)
            if self.penetration_weight:
                reward = reward - self.penetration_weight * np.maximum(0.0, -gap)
            if self.proximity_weight:
                reward = reward - self.proximity_weight * np.maximum(
                    0.0, self.proximity_margin - gap
                )
        return reward

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """The reward :meth:`evaluate` gives, from achieved and desired goals (..., 3) and the
        ``info`` entries ``collided``, ``collision`` and ``min_clearance`` (shape (...)), which
        it needs: a collision costs whatever the goals."""
        if info is None or not {"collided", "collision", "min_clearance"} <= set(info):
            raise ValueError(
                "the Obstacle reward needs info with 'collided', 'collision' and "
                "'min_clearance' (its collision penalties)"
            )
        achieved_goal, desired_goal = check_goal_pair(achieved_goal, desired_goal, 3)
        distance = goal_distance(achieved_goal, desired_goal)
        success = (distance <= self.distance_threshold) & ~np.asarray(info["collided"], bool)
        return self.penalised(self.reward_from_success(distance, success), info)

    def info_keys(self) -> tuple[str, ...]:
        return (
            "distance",
            "is_success",
            "goal",
            "collision",
            "collided",
            "min_clearance",
            "obstacles",
            "contact_force",
        )

    def render_markers(self, index: int = 0) -> dict[str, Any]:
        spheres = self.obstacles[index]
        return {"goal": self.goal[index].copy(), "obstacles": spheres[spheres[:, 3] > 0].copy()}
