"""Tip reaching for the cable-driven continuum robot, on any backend."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from cdcr_gym import kinematics, statics
from cdcr_gym.backends.base import Backend
from cdcr_gym.envs import task
from cdcr_gym.validation import three_finite_floats
from cdcr_gym.workspace import sample_arcs

__all__ = ["ReachEnv", "GoalReachEnv"]

_INITIAL_STATES = ("straight", "random")


def _check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
    return value


def _check_positive(name: str, value: Any, upper: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0.0 or (upper is not None and value > upper):
        bound = f" and <= {upper}" if upper is not None else ""
        raise ValueError(f"{name} must be finite, > 0{bound}, got {value!r}")
    return value


class ReachEnv(gym.Env):
    r"""Move the tip of a 2-DOF cable-driven continuum robot to a goal, by pulling its cables.

    ## Description
    A flexible backbone of length ℓ (0.641 m by default) stands on a fixed base disk along +Z0;
    three cables at β = 0°, 120°, 240° about +Z0 and r = 29 mm from the axis run through spacer
    disks and are anchored at the tip disk. Pulling cables bends the backbone towards them. The
    robot itself is a *backend* object (``cdcr_gym.backends``): the analytic constant-curvature
    model (``CCKAReach-v0``) or a pybullet multibody backbone (``BulletReach-v0``). Each episode
    asks the tip to reach a goal drawn uniformly (in area) on the surface the cables can reach.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``, one entry per cable (cable 1, 2, 3). Out-of-range actions are
    clipped; a non-finite action raises ``ValueError``. Meaning by ``action_mode``:

    | mode              | effect of a_i                                                        |
    |-------------------|----------------------------------------------------------------------|
    | ``tension``       | T_i = max_tension·(a_i + 1)/2 (N), absolute                          |
    | ``tension_delta`` | T_i ← clip(T_i + a_i·tension_step·max_tension, 0, max_tension) (N)   |
    | ``length_delta``  | l_i ← l_i + a_i·length_step (m), projected onto Σ Δl_i = 0 (the      |
    |                   | backbone is inextensible), then the arc's θ is clipped to the         |
    |                   | tension-reachable limit θ_lim(φ) keeping φ. Backends with length      |
    |                   | control only (the analytic one).                                      |

    ## Observation Space
    Flat (default): ``Box(float32, (18,))``; ℓ = backbone length, r = cable radius.

    | index | observation                                   | min  | max | unit |
    |-------|-----------------------------------------------|------|-----|------|
    | 0–2   | tip position x, y, z in R0                    | −ℓ   | ℓ   | m    |
    | 3–5   | goal position x, y, z in R0                   | −ℓ   | ℓ   | m    |
    | 6–8   | goal − tip                                    | −2ℓ  | 2ℓ  | m    |
    | 9–11  | tanh((goal − tip) / 0.01 m)                   | −1   | 1   | –    |
    | 12–14 | cable tensions / max_tension                  | 0    | 1   | –    |
    | 15–17 | (cable length − ℓ) / (π r)                    | −1   | 1   | –    |

    Goal-conditioned (``GoalReachEnv``, or ``goal_conditioned=True`` in ``gymnasium.make``): a
    ``Dict`` in the Gymnasium-Robotics convention, with ``observation`` = indices 0–2 and 12–17
    above (9 values), ``achieved_goal`` = tip (3, m) and ``desired_goal`` = goal (3, m), and a
    ``compute_reward`` vectorised over leading dimensions for HER.

    ## Rewards
    ``reward_type="dense"`` (default): −‖goal − tip‖ (m). ``"sparse"``: −1 while the distance
    exceeds ``distance_threshold``, 0 within it. In the goal-conditioned variant
    ``reward == compute_reward(achieved_goal, desired_goal, info)``. ``info`` holds ``distance`` (m),
    ``is_success`` (distance <= distance_threshold), ``tip`` (m), ``goal`` (m), ``tensions`` (N)
    and ``cable_lengths`` (m), each as float64 arrays.

    ## Starting State
    ``initial_state="straight"`` (default): all tensions zero, the straight robot (or, on a
    backend with gravity, its rest shape). ``"random"``: a shape drawn like the goals (area-uniform
    on the workspace) and held by its minimal tensions. ``reset(options=...)`` accepts ``goal``
    ((3,) m, projected onto the reachable surface) and ``initial_tensions`` ((3,) N in
    [0, max_tension]) to fix either.

    ## Episode End
    No termination (the agent must reach *and hold* the goal) unless
    ``terminate_on_success=True``. Truncation after ``max_episode_steps`` (100 for the registered
    ids) by Gymnasium's ``TimeLimit``.

    ## Arguments
    ``gymnasium.make("cdcr_gym/CCKAReach-v0", **kwargs)`` passes these through;
    ``goal_conditioned=True`` there selects :class:`GoalReachEnv`; robot parameters go to the
    backend (``params=RobotParams(...)``; see ``cdcr_gym.envs.factory``).

    | argument               | default           | effect                                           |
    |------------------------|-------------------|--------------------------------------------------|
    | ``backend``            | (required)        | the robot model, a ``Backend`` instance          |
    | ``action_mode``        | ``tension_delta`` | see Action Space                                 |
    | ``tension_step``       | 0.05              | max tension change per step, fraction of T_max   |
    | ``length_step``        | 0.002             | max cable displacement per step (m)              |
    | ``reward_type``        | ``dense``         | ``dense`` or ``sparse``                          |
    | ``distance_threshold`` | 0.005             | success radius (m)                               |
    | ``initial_state``      | ``straight``      | ``straight`` or ``random``                       |
    | ``terminate_on_success``| False            | end the episode once within the threshold        |
    | ``render_mode``        | None              | ``rgb_array`` or ``human``                       |
    | ``render_width``       | 480               | image width (px)                                 |
    | ``render_height``      | 480               | image height (px)                                |

    ## Version History
    * v0: initial release.
    """

    #: Whether observations are the Gymnasium-Robotics Dict (set by :class:`GoalReachEnv`).
    goal_conditioned = False

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 25}

    def __init__(
        self,
        backend: Backend,
        *,
        action_mode: str = "tension_delta",
        tension_step: float = 0.05,
        length_step: float = 0.002,
        reward_type: str = "dense",
        distance_threshold: float = 0.005,
        initial_state: str = "straight",
        terminate_on_success: bool = False,
        render_mode: str | None = None,
        render_width: int = 480,
        render_height: int = 480,
    ) -> None:
        if not isinstance(backend, Backend):
            raise ValueError(f"backend must be a cdcr_gym.backends.Backend, got {backend!r}")
        self.backend = backend
        self.params = backend.params
        self.action_mode = _check_choice("action_mode", action_mode, task.ACTION_MODES)
        if action_mode == "length_delta" and not backend.supports_length_control:
            raise ValueError(
                f"action_mode='length_delta' needs a backend with cable-length control; "
                f"{type(backend).__name__} has none (use 'tension' or 'tension_delta')"
            )
        self.tension_step = _check_positive("tension_step", tension_step, upper=1.0)
        self.length_step = _check_positive("length_step", length_step, upper=self.params.length)
        self.reward_type = _check_choice("reward_type", reward_type, task.REWARD_TYPES)
        self.distance_threshold = _check_positive("distance_threshold", distance_threshold)
        if not isinstance(terminate_on_success, (bool, np.bool_)):
            raise ValueError(f"terminate_on_success must be a bool, got {terminate_on_success!r}")
        self.terminate_on_success = bool(terminate_on_success)
        self.initial_state = _check_choice("initial_state", initial_state, _INITIAL_STATES)
        if render_mode is not None:
            _check_choice("render_mode", render_mode, tuple(self.metadata["render_modes"]))
        self.render_mode = render_mode
        for name, size in (("render_width", render_width), ("render_height", render_height)):
            if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 16:
                raise ValueError(f"{name} must be an integer >= 16 pixels, got {size!r}")
        self.render_width = int(render_width)
        self.render_height = int(render_height)

        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        ell = self.params.length
        if self.goal_conditioned:
            point = spaces.Box(-ell, ell, shape=(3,), dtype=np.float32)
            obs_low = np.array([-ell] * 3 + [0.0] * 3 + [-1.0] * 3, dtype=np.float32)
            obs_high = np.array([ell] * 3 + [1.0] * 3 + [1.0] * 3, dtype=np.float32)
            self.observation_space = spaces.Dict(
                {
                    "observation": spaces.Box(obs_low, obs_high, dtype=np.float32),
                    "achieved_goal": point,
                    "desired_goal": point,
                }
            )
        else:
            low = np.array(
                [-ell] * 6 + [-2 * ell] * 3 + [-1.0] * 3 + [0.0] * 3 + [-1.0] * 3, dtype=np.float32
            )
            high = np.array(
                [ell] * 6 + [2 * ell] * 3 + [1.0] * 3 + [1.0] * 3 + [1.0] * 3, dtype=np.float32
            )
            self.observation_space = spaces.Box(low, high, dtype=np.float32)

        # Constants and state of the hot path, as Python floats (see ``step``).
        p = self.params
        self._max_tension = float(p.max_tension)
        self._obs_constants = task._observation_constants(p)
        self._length_action_args = (
            self.length_step,
            float(ell),
            float(p.cable_radius),
            p.bending_stiffness / (p.cable_radius * ell),
            self._max_tension,
        )
        self._set_goal(np.array([0.0, 0.0, ell]))
        self._held_tensions = (0.0, 0.0, 0.0)
        self._held_lengths = (float(ell),) * 3

    def _set_goal(self, goal: np.ndarray) -> None:
        self._goal = goal
        self._goal_floats = tuple(goal.tolist())

    # -- task API -------------------------------------------------------------------------------
    @property
    def goal(self) -> np.ndarray:
        """The current goal (3,), m, in R0."""
        return self._goal.copy()

    def _reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray) -> np.ndarray | float:
        """Reward for tips ``achieved_goal`` and goals ``desired_goal`` (..., 3) m, batched."""
        distance = np.linalg.norm(
            np.asarray(achieved_goal, dtype=np.float64) - np.asarray(desired_goal, dtype=np.float64),
            axis=-1,
        )
        reward = task.reward_from_distance(distance, self.reward_type, self.distance_threshold)
        return float(reward) if np.ndim(reward) == 0 else reward

    def sample_goal(self) -> np.ndarray:
        """A goal (3,) m drawn area-uniformly on the reachable surface from ``np_random``."""
        theta, phi = sample_arcs(self.np_random, 1, self.params)
        return kinematics.tip_from_arc(theta[0], phi[0], self.params.length)

    # -- Gymnasium API --------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        options = {} if options is None else dict(options)
        unknown = set(options) - {"goal", "initial_tensions"}
        if unknown:
            raise ValueError(f"options has unknown keys {sorted(unknown)}; "
                             f"allowed: 'goal', 'initial_tensions'")
        p = self.params
        if "initial_tensions" in options:
            tensions = np.asarray(options["initial_tensions"], dtype=np.float64)
            if (tensions.shape != (3,) or not np.all(np.isfinite(tensions))
                    or np.any(tensions < 0) or np.any(tensions > p.max_tension)):
                raise ValueError(
                    f"options['initial_tensions'] must be 3 finite tensions in "
                    f"[0, {p.max_tension}] N, got {options['initial_tensions']!r}"
                )
        elif self.initial_state == "random":
            theta, phi = sample_arcs(self.np_random, 1, p)
            tensions = statics.tensions_from_arc(theta[0], phi[0], p)[0]
        else:
            tensions = np.zeros(3)
        self.backend.reset(tensions)
        self._held_tensions = tuple(self.backend.tensions.tolist())
        self._held_lengths = tuple(self.backend.cable_lengths.tolist())

        if "goal" in options:
            goal = np.asarray(options["goal"], dtype=np.float64)
            if goal.shape != (3,) or not np.all(np.isfinite(goal)):
                raise ValueError(f"options['goal'] must be a finite (3,) position in m, "
                                 f"got {options['goal']!r}")
            theta, phi, _ = kinematics.arc_from_tip(goal, p.length)
            self._set_goal(kinematics.tip_from_arc(theta, phi, p.length))
        else:
            self._set_goal(self.sample_goal())
        obs, info = self._observe()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        # The hot path of training: Python floats through the task and model kernels (the same
        # functions the batched env calls with arrays), numpy only at the API boundary.
        a1, a2, a3 = self._clipped_action(action)
        if self.action_mode == "length_delta":
            self._held_lengths = task._lengths_from_action(
                (a1, a2, a3), self._held_lengths, *self._length_action_args
            )
            self.backend.apply_cable_lengths(np.array(self._held_lengths))
        else:
            h1, h2, h3 = self._held_tensions
            mode, t_max, t_step = self.action_mode, self._max_tension, self.tension_step
            self._held_tensions = (
                task.tensions_from_action(a1, h1, mode, t_max, t_step),
                task.tensions_from_action(a2, h2, mode, t_max, t_step),
                task.tensions_from_action(a3, h3, mode, t_max, t_step),
            )
            self.backend.apply_tensions(np.array(self._held_tensions))
        obs, info = self._observe()
        reward = self._step_reward(obs, info)
        terminated = bool(self.terminate_on_success and info["is_success"])
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    @staticmethod
    def _clipped_action(action: Any) -> tuple[float, float, float]:
        """The action as three floats clipped to [−1, 1]; ValueError if misshapen or non-finite."""
        a1, a2, a3 = three_finite_floats(action, "action")
        return (
            -1.0 if a1 < -1.0 else 1.0 if a1 > 1.0 else a1,
            -1.0 if a2 < -1.0 else 1.0 if a2 > 1.0 else a2,
            -1.0 if a3 < -1.0 else 1.0 if a3 > 1.0 else a3,
        )

    def _step_reward(self, obs: Any, info: dict[str, Any]) -> float:
        """The step's reward, from the float64 tip and goal (so dense reward = −distance)."""
        return float(
            task.reward_from_distance(info["distance"], self.reward_type, self.distance_threshold)
        )

    def _observe(self) -> tuple[Any, dict[str, Any]]:
        tip = self.backend.tip
        tensions = self.backend.tensions
        lengths = self.backend.cable_lengths
        # task's observation kernels on floats (the batched env runs them on arrays)
        tip_f, tensions_f, lengths_f = tip.tolist(), tensions.tolist(), lengths.tolist()
        if self.goal_conditioned:
            entries = task._goal_entries(tip_f, tensions_f, lengths_f, self._obs_constants)
            g1, g2, g3 = self._goal_floats
            t1, t2, t3 = tip_f
            distance = task._distance((g1 - t1, g2 - t2, g3 - t3))
            obs = {
                "observation": np.array(entries, dtype=np.float32),
                "achieved_goal": tip.astype(np.float32),
                "desired_goal": self._goal.astype(np.float32),
            }
        else:
            entries, error = task._flat_entries(
                tip_f, self._goal_floats, tensions_f, lengths_f, self._obs_constants
            )
            distance = task._distance(error)
            obs = np.array(entries, dtype=np.float32)
        info = {
            "distance": distance,
            "is_success": distance <= self.distance_threshold,
            "tip": tip,
            "goal": self._goal.copy(),
            "tensions": tensions,
            "cable_lengths": lengths,
        }
        return obs, info

    def render(self) -> np.ndarray | None:
        if self.render_mode == "rgb_array":
            return self.backend.render_rgb(self._goal, self.render_width, self.render_height)
        if self.render_mode == "human":
            self.backend.render_human(self._goal)
        return None

    def close(self) -> None:
        self.backend.close()
        super().close()


class GoalReachEnv(ReachEnv):
    """:class:`ReachEnv` with a Gymnasium-Robotics ``Dict`` observation, for HER.

    ``observation`` (9,): tip (m), tensions/max_tension, (cable length − ℓ)/(π r);
    ``achieved_goal`` (3,): tip (m); ``desired_goal`` (3,): goal (m). The reward of every step
    equals ``compute_reward(obs["achieved_goal"], obs["desired_goal"], info)`` (up to float32
    rounding of the goal vectors). Same arguments as :class:`ReachEnv`.
    """

    goal_conditioned = True

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray | float:
        """Reward for tips ``achieved_goal`` and goals ``desired_goal``, shape (..., 3) m.

        Vectorised over leading dimensions (HER relabels batches): returns shape (...), or a
        float for single points. ``info`` is unused (kept for the HER signature).
        """
        return self._reward(achieved_goal, desired_goal)

    def _step_reward(self, obs: Any, info: dict[str, Any]) -> float:
        # From the observed (float32) goals, so that the step reward equals compute_reward exactly
        # (same operations in the same order as its norm over the last axis, in float64).
        a1, a2, a3 = obs["achieved_goal"].tolist()
        d1, d2, d3 = obs["desired_goal"].tolist()
        distance = task._distance((a1 - d1, a2 - d2, a3 - d3))
        return float(task.reward_from_distance(distance, self.reward_type, self.distance_threshold))
