"""Batched CCKA reach env: all envs of a ``gymnasium.vector.VectorEnv`` in one array operation.

``gymnasium.make_vec("cdcr_gym/CCKAReach-v0", num_envs=N, vectorization_mode="vector_entry_point")``
builds :class:`CCKAReachVectorEnv`. It is :class:`~cdcr_gym.envs.reach.ReachEnv` on the analytic
backend, N times, with the math done once per step for all N robots: the state is kept as
components (three (N,) arrays per 3-vector) and pushed through the same kernels the single env
runs on Python floats (``cdcr_gym.envs.task``, ``cdcr_gym.backends.analytic``), so the two
cannot drift apart; a test checks that both give the same trajectories, including across
autoresets.
"""

from __future__ import annotations

import platform
import sys
from typing import Any

import numpy as np
from gymnasium import error as gym_error
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from cdcr_gym import MAX_EPISODE_STEPS, kinematics, statics
from cdcr_gym.backends.analytic import (
    ModelConstants,
    Shape,
    shape_from_lengths,
    shape_from_tensions,
)
from cdcr_gym.envs import task
from cdcr_gym.envs.factory import make_ccka_reach
from cdcr_gym.workspace import sample_arcs_each

__all__ = ["CCKAReachVectorEnv"]

_INFO_KEYS = ("distance", "is_success", "tip", "goal", "tensions", "cable_lengths")


def _rows(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three components of (N, 3) values as contiguous (N,) float64 arrays."""
    x = np.asarray(x, dtype=np.float64)
    return x[:, 0].copy(), x[:, 1].copy(), x[:, 2].copy()


class _Recycler:
    """Output arrays reused once the caller holds no reference to them any more.

    Every step returns fresh-looking arrays (observations, info) of ~3 MB at 16 384 envs.
    Allocating them anew each step costs more than the step's arithmetic: glibc returns freed
    blocks of that size to the OS and the next allocation page-faults them back in (measured:
    7.7 M vs 16 M env-steps/s). So each output slot keeps a few arrays and hands out one that
    nobody else references (CPython reference count: any array, view or tensor made from it keeps
    it alive, so a buffer the caller still sees is never overwritten). On other interpreters it
    always allocates.
    """

    _POOL = 3  # per slot: the array being returned, the one the caller still holds, a spare

    def __init__(self) -> None:
        self._pools: dict[str, list[np.ndarray]] = {}
        probe = [np.empty(1)]
        self._idle = sys.getrefcount(probe[0])  # refs of an array held only by its pool list
        self._enabled = platform.python_implementation() == "CPython"

    def take(self, slot: str, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        """An array of ``shape``/``dtype`` that no caller references (contents undefined)."""
        if not self._enabled:
            return np.empty(shape, dtype)
        pool = self._pools.setdefault(slot, [])
        for k in range(len(pool)):
            if sys.getrefcount(pool[k]) <= self._idle:
                return pool[k]
        out = np.empty(shape, dtype)
        if len(pool) < self._POOL:
            pool.append(out)
        return out


def _per_env(value: Any, name: str, n: int) -> np.ndarray:
    """A reset option given once, shape (3,), or per env, shape (n, 3), as (n, 3) float64."""
    value = np.asarray(value, dtype=np.float64)
    if value.shape == (3,):
        return np.broadcast_to(value, (n, 3))
    if value.shape == (n, 3):
        return value
    raise ValueError(f"options[{name!r}] must have shape (3,) or ({n}, 3), got shape {value.shape}")


class CCKAReachVectorEnv(VectorEnv):
    r"""``num_envs`` copies of ``CCKAReach-v0`` stepped together with numpy (no Python loop).

    Same robot, task, spaces, rewards, goals and seeding as ``gymnasium.make("cdcr_gym/
    CCKAReach-v0", **kwargs)`` (see :class:`~cdcr_gym.envs.reach.ReachEnv` for the env itself);
    what differs is only how the N envs are run:

    * **Autoreset** (``autoreset_mode``, as ``SyncVectorEnv``'s): ``NEXT_STEP`` (default) — the
      step after an env terminates or truncates resets it and returns its reset observation,
      reward 0 and ``terminated = truncated = False``; its action is ignored. ``SAME_STEP`` — the
      env is reset within the step that ended its episode: the returned observation and info
      are the reset's, the episode's last ones are in ``info["final_obs"]`` (object array, None
      for the others) and ``info["final_info"]`` (dict of arrays), each with its ``_key`` mask.
    * **Truncation** after ``max_episode_steps`` steps (per-env counters; ``make_vec`` passes the
      registered 100). ``None`` disables it.
    * **Seeding**: each env owns a generator; ``reset(seed=s)`` seeds env i with ``s + i`` exactly
      as ``SyncVectorEnv`` seeds its i-th env, and goals (and ``initial_state="random"`` shapes)
      are drawn from it with the single env's sampler, draw for draw. Same seeds and actions
      give the same trajectories as a ``SyncVectorEnv`` of single envs (to float rounding).
    * **Observations** are a (num_envs, 18) float32 array (or the Dict of (num_envs, ·) arrays
      with ``goal_conditioned=True``). For speed they are the transpose of a (18, num_envs)
      buffer: Fortran-ordered, like Gymnasium's own ``CartPoleVectorEnv``
      (``np.ascontiguousarray`` if C order matters).
    * **info** is a dict of arrays in the Gymnasium vector convention: ``distance`` (N,) m,
      ``is_success`` (N,) bool, ``tip``, ``goal``, ``tensions`` (N), ``cable_lengths`` (N, 3) m,
      each with its ``_key`` mask (all True).
    * ``reset(options=...)`` takes the single env's ``goal`` and ``initial_tensions``, either (3,)
      for all envs or (num_envs, 3), and Gymnasium's ``reset_mask`` ((num_envs,) bool) to reset
      only some envs.

    Supported: all ``action_mode`` values, both reward types, both initial states,
    ``terminate_on_success``, ``goal_conditioned``, ``params``. Not supported: rendering.

    Args:
        num_envs: number of envs (>= 1).
        max_episode_steps: episode length (>= 1) or ``None`` for no truncation.
        params: the robot (``cdcr_gym.params.RobotParams``; default: the paper's).
        goal_conditioned: Dict observations (Gymnasium-Robotics convention) as in
            :class:`~cdcr_gym.envs.reach.GoalReachEnv`.
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default) or ``SAME_STEP`` (or their
            values ``"NextStep"``, ``"SameStep"``).
        **env_kwargs: the :class:`~cdcr_gym.envs.reach.ReachEnv` arguments (``action_mode``,
            ``tension_step``, ``length_step``, ``reward_type``, ``distance_threshold``,
            ``initial_state``, ``terminate_on_success``), validated by the single env.
            ``initial_state`` may also be a sequence of ``num_envs`` values, one per env (e.g.
            half the envs starting straight, half from a random shape).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        *,
        max_episode_steps: int | None = MAX_EPISODE_STEPS,
        params: Any = None,
        goal_conditioned: bool = False,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **env_kwargs: Any,
    ) -> None:
        if (isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer))
                or num_envs < 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if max_episode_steps is not None and (
            isinstance(max_episode_steps, bool)
            or not isinstance(max_episode_steps, (int, np.integer))
            or max_episode_steps < 1
        ):
            raise ValueError(
                f"max_episode_steps must be an integer >= 1 or None, got {max_episode_steps!r}"
            )
        try:
            autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            autoreset_mode = None
        if autoreset_mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                "autoreset_mode must be AutoresetMode.NEXT_STEP or AutoresetMode.SAME_STEP"
            )
        self.autoreset_mode = autoreset_mode
        if render_mode is not None:
            raise ValueError(
                f"render_mode={render_mode!r}: the batched env does not render; use "
                f"gymnasium.make_vec(..., vectorization_mode='sync') or a single env to render"
            )
        initial_states = env_kwargs.pop("initial_state", "straight")
        if isinstance(initial_states, str):
            initial_states = [initial_states] * int(num_envs)
        else:
            initial_states = list(initial_states)
            if len(initial_states) != num_envs:
                raise ValueError(
                    f"initial_state must be one value or a sequence of num_envs={num_envs} "
                    f"values, got {len(initial_states)}"
                )
        # Single envs validate every argument and define the spaces: nothing is re-derived.
        for state in sorted(set(initial_states), key=str):
            template = make_ccka_reach(
                params=params, goal_conditioned=goal_conditioned, initial_state=state, **env_kwargs
            )
        self.num_envs = int(num_envs)
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.render_mode = None
        self.params = template.params
        self.goal_conditioned = template.goal_conditioned
        for name in (
            "action_mode",
            "tension_step",
            "length_step",
            "reward_type",
            "distance_threshold",
            "terminate_on_success",
        ):
            setattr(self, name, getattr(template, name))
        uniform = len(set(initial_states)) == 1
        self.initial_state = initial_states[0] if uniform else tuple(initial_states)
        self._random_start = np.array([state == "random" for state in initial_states])
        self.single_action_space = template.action_space
        self.single_observation_space = template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.metadata = dict(self.metadata)
        self.metadata["autoreset_mode"] = self.autoreset_mode
        template.close()

        p = self.params
        self._model = ModelConstants.from_params(p)
        self._obs_constants = task._observation_constants(p)
        self._length_action_args = (
            self.length_step,
            self._model.length,
            self._model.cable_radius,
            self._model.stiffness,
            self._model.max_tension,
        )
        n = self.num_envs
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._rng_seeds: list[int | None] = [None] * n
        self._steps = np.zeros(n, dtype=np.int64)
        self._autoreset = np.zeros(n, dtype=np.bool_)
        self._all_true = np.ones(n, dtype=np.bool_)
        self._all_true.flags.writeable = False  # shared by every info's "_key" masks
        self._recycler = _Recycler()
        self._needs_reset = True
        zeros = np.zeros(n)
        self._held_tensions = (zeros, zeros.copy(), zeros.copy())
        self._shape: Shape = shape_from_tensions(self._held_tensions, self._model)
        self._held_lengths = tuple(c.copy() for c in self._shape.lengths)
        self._goal = tuple(c.copy() for c in self._shape.tip)

    # -- seeding --------------------------------------------------------------------------------
    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """The envs' random generators (seeded by ``reset(seed=...)``), like ``SyncVectorEnv``."""
        return tuple(self._rng(i) for i in range(self.num_envs))

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:
        """The seeds the envs' generators were made from (-1 where none was made yet)."""
        return tuple(-1 if s is None else s for s in self._rng_seeds)

    def _rng(self, i: int) -> np.random.Generator:
        if self._rngs[i] is None:
            self._rngs[i], self._rng_seeds[i] = seeding.np_random(None)
        return self._rngs[i]

    # -- Gymnasium API --------------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(
                    f"seed must be None, an int or a list of num_envs={n} seeds, got {len(seeds)}"
                )
        options = {} if options is None else dict(options)
        mask = options.pop("reset_mask", None)
        unknown = set(options) - {"goal", "initial_tensions"}
        if unknown:
            raise ValueError(f"options has unknown keys {sorted(unknown)}; "
                             f"allowed: 'goal', 'initial_tensions', 'reset_mask'")
        if mask is None:
            mask = self._all_true
        else:
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
                raise ValueError(
                    f"options['reset_mask'] must be a bool numpy array of shape ({n},), "
                    f"got {mask!r}"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must select at least one env")
        idx = np.flatnonzero(mask)
        for i in idx.tolist():
            if seeds[i] is not None:
                self._rngs[i], self._rng_seeds[i] = seeding.np_random(seeds[i])
        self._reset_envs(
            idx,
            initial_tensions=options.get("initial_tensions"),
            goal=options.get("goal"),
        )
        self._autoreset[idx] = False
        self._needs_reset = False
        obs, info = self._observe()
        if mask is not self._all_true:
            for key in _INFO_KEYS:
                info[f"_{key}"] = mask.copy()
        return obs, info

    def step(
        self, actions: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._needs_reset:
            raise gym_error.ResetNeeded("Cannot call step() before reset()")
        actions = np.asarray(actions, dtype=np.float64)
        n = self.num_envs
        if actions.shape != (n, 3):
            raise ValueError(f"actions must have shape ({n}, 3), got shape {actions.shape}")
        resetting = self._autoreset
        any_reset = bool(resetting.any())
        if not np.isfinite(actions).all():
            bad = ~np.isfinite(actions).all(axis=1) & ~resetting  # resetting envs ignore theirs
            if bad.any():
                raise ValueError(
                    f"actions must be finite; envs {np.flatnonzero(bad).tolist()} got "
                    f"{actions[bad]!r}"
                )
            actions = np.where(resetting[:, None], 0.0, actions)
        clipped = np.clip(actions, -1.0, 1.0)
        a = (clipped[:, 0], clipped[:, 1], clipped[:, 2])

        # the same kernels as ReachEnv.step, on (N,) arrays instead of floats
        if self.action_mode == "length_delta":
            self._held_lengths = task._lengths_from_action(
                a, self._held_lengths, *self._length_action_args
            )
            self._shape = shape_from_lengths(self._held_lengths, self._model)
        else:
            mode, t_max, t_step = self.action_mode, self._model.max_tension, self.tension_step
            self._held_tensions = tuple(
                task.tensions_from_action(a[i], self._held_tensions[i], mode, t_max, t_step)
                for i in range(3)
            )
            self._shape = shape_from_tensions(self._held_tensions, self._model)
        self._steps += 1

        if any_reset:  # NEXT_STEP autoreset: these envs return their reset state instead
            self._reset_envs(np.flatnonzero(resetting))
        obs, info = self._observe()
        reward = self._reward(obs, info)
        if self.terminate_on_success:
            terminated = info["is_success"].copy()
        else:
            terminated = np.zeros(n, dtype=np.bool_)
        if self.max_episode_steps is None:
            truncated = np.zeros(n, dtype=np.bool_)
        else:
            truncated = self._steps >= self.max_episode_steps
        if any_reset:
            reward[resetting] = 0.0
            terminated[resetting] = False
            truncated[resetting] = False
        done = terminated | truncated
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._autoreset = done
        elif done.any():  # SAME_STEP: reset now, keep the episode's last obs and info aside
            obs, info = self._reset_within_step(done, obs, info)
        return obs, reward, terminated, truncated, info

    def _reset_within_step(
        self, done: np.ndarray, obs: Any, info: dict[str, Any]
    ) -> tuple[Any, dict[str, Any]]:
        """SAME_STEP autoreset of the ``done`` envs, with SyncVectorEnv's ``final_*`` infos."""
        idx = np.flatnonzero(done)
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in idx.tolist():
            if self.goal_conditioned:
                final_obs[i] = {key: value[i].copy() for key, value in obs.items()}
            else:
                final_obs[i] = obs[i].copy()
        final_info = {}
        for key in _INFO_KEYS:
            value = info[key]
            kept = np.zeros_like(value)
            kept[idx] = value[idx]
            final_info[key] = kept
            final_info[f"_{key}"] = done.copy()
        self._reset_envs(idx)
        obs, info = self._observe()
        info["final_obs"] = final_obs
        info["_final_obs"] = done.copy()
        info["final_info"] = final_info
        info["_final_info"] = done.copy()
        return obs, info

    def render(self) -> None:
        return None

    # -- internals ------------------------------------------------------------------------------
    def _reset_envs(
        self, idx: np.ndarray, initial_tensions: Any = None, goal: Any = None
    ) -> None:
        """Reset envs ``idx`` as ``ReachEnv.reset`` does, each from its own generator."""
        m = idx.size
        p = self.params
        rngs = [self._rng(i) for i in idx.tolist()]
        if initial_tensions is not None:
            tensions = _per_env(initial_tensions, "initial_tensions", m)
            if (not np.all(np.isfinite(tensions)) or np.any(tensions < 0)
                    or np.any(tensions > p.max_tension)):
                raise ValueError(
                    f"options['initial_tensions'] must be finite tensions in "
                    f"[0, {p.max_tension}] N, got {initial_tensions!r}"
                )
        else:
            tensions = np.zeros((m, 3))
            random = self._random_start[idx]
            if random.any():
                theta, phi = sample_arcs_each([r for r, k in zip(rngs, random) if k], p)
                tensions[random] = statics.tensions_from_arc(theta, phi, p)[0]
        shape = shape_from_tensions(_rows(tensions), self._model)

        if goal is not None:
            goal = _per_env(goal, "goal", m)
            if not np.all(np.isfinite(goal)):
                raise ValueError(f"options['goal'] must be finite positions in m, got {goal!r}")
            theta, phi, _ = kinematics.arc_from_tip(goal, p.length)
        else:
            theta, phi = sample_arcs_each(rngs, p)
        goals = _rows(kinematics.tip_from_arc(theta, phi, p.length))

        # scatter into the state (fresh arrays every step, so in-place writes are safe)
        s = self._shape
        for i in range(3):
            s.tip[i][idx] = shape.tip[i]
            s.lengths[i][idx] = shape.lengths[i]
            s.tensions[i][idx] = shape.tensions[i]
            self._held_tensions[i][idx] = shape.tensions[i]
            self._held_lengths[i][idx] = shape.lengths[i]
            self._goal[i][idx] = goals[i]
        self._steps[idx] = 0

    def _stacked(self, slot: str, rows: list, dtype: Any) -> np.ndarray:
        """``rows`` (each (N,)) as an (N, len(rows)) array (the transpose of a recycled buffer)."""
        out = self._recycler.take(slot, (len(rows), self.num_envs), dtype)
        np.concatenate(rows, out=out.reshape(-1))  # one call; casts to the buffer's dtype
        return out.T

    def _observe(self) -> tuple[Any, dict[str, Any]]:
        s = self._shape
        f32 = np.float32
        if self.goal_conditioned:
            entries = task._goal_entries(s.tip, s.tensions, s.lengths, self._obs_constants)
            t1, t2, t3 = s.tip
            g1, g2, g3 = self._goal
            distance = task._distance((g1 - t1, g2 - t2, g3 - t3))
            obs = {
                "observation": self._stacked("observation", entries, f32),
                "achieved_goal": self._stacked("achieved_goal", list(s.tip), f32),
                "desired_goal": self._stacked("desired_goal", list(self._goal), f32),
            }
        else:
            entries, error = task._flat_entries(
                s.tip, self._goal, s.tensions, s.lengths, self._obs_constants
            )
            distance = task._distance(error)
            obs = self._stacked("obs", entries, f32)
        mask = self._all_true
        f64 = np.float64
        info = {
            "distance": distance,
            "_distance": mask,
            "is_success": distance <= self.distance_threshold,
            "_is_success": mask,
            "tip": self._stacked("tip", list(s.tip), f64),
            "_tip": mask,
            "goal": self._stacked("goal", list(self._goal), f64),
            "_goal": mask,
            "tensions": self._stacked("tensions", list(s.tensions), f64),
            "_tensions": mask,
            "cable_lengths": self._stacked("cable_lengths", list(s.lengths), f64),
            "_cable_lengths": mask,
        }
        return obs, info

    def _reward(self, obs: Any, info: dict[str, Any]) -> np.ndarray:
        if self.goal_conditioned:
            # from the observed float32 goals, as GoalReachEnv (= its compute_reward)
            achieved = obs["achieved_goal"].astype(np.float64)
            desired = obs["desired_goal"].astype(np.float64)
            distance = task._distance(
                tuple(achieved[:, i] - desired[:, i] for i in range(3))
            )
        else:
            distance = info["distance"]
        return task.reward_from_distance(distance, self.reward_type, self.distance_threshold)

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """Goal-conditioned reward, vectorised over leading dimensions (as GoalReachEnv's)."""
        distance = np.linalg.norm(
            np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64), axis=-1
        )
        return task.reward_from_distance(distance, self.reward_type, self.distance_threshold)
