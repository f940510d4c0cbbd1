"""Batched env: all envs of a ``gymnasium.vector.VectorEnv`` in one array operation.

``gymnasium.make_vec("cdcr_gym/CCKAReach-v0", num_envs=N, vectorization_mode="vector_entry_point")``
builds :class:`CDCRVectorEnv`: the env core (``cdcr_gym.envs.core``) on the analytic backend
with N robots, the same code the single env runs with N = 1, so the two cannot drift apart; a
test checks that both give the same trajectories, including across autoresets.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import error as gym_error
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from cdcr_gym import defaults, validation
from cdcr_gym.envs import factory
from cdcr_gym.envs.core import CoreAttributes, EnvCore
from cdcr_gym.envs.env import RENDER_KEYS

__all__ = ["CDCRVectorEnv"]


class CDCRVectorEnv(CoreAttributes, VectorEnv):
    r"""``num_envs`` copies of a ``CCKA*-v0`` env stepped together with numpy (no Python loop).

    Same robot, task, spaces, rewards, goals and seeding as ``gymnasium.make(id, **kwargs)``
    (see :class:`~cdcr_gym.envs.env.CDCREnv`); what differs is only how the N envs are run:

    * **Autoreset** (``autoreset_mode``, as ``SyncVectorEnv``'s): ``NEXT_STEP`` (default) — the
      step after an env terminates or truncates resets it and returns its reset observation,
      reward 0 and ``terminated = truncated = False``; its action is ignored. ``SAME_STEP`` — the
      env is reset within the step that ended its episode: the returned observation and info
      are the reset's, the episode's last ones are in ``info["final_obs"]`` (object array, None
      for the others) and ``info["final_info"]`` (dict of arrays), each with its ``_key`` mask.
    * **Truncation** after ``max_episode_steps`` steps (per-env counters; ``make_vec`` passes the
      registered 100). ``None`` disables it.
    * **Seeding**: each env owns a generator; ``reset(seed=s)`` seeds env i with ``s + i`` exactly
      as ``SyncVectorEnv`` seeds its i-th env, and draws from it as the single env does, draw
      for draw. Same seeds and actions give the same trajectories as a ``SyncVectorEnv``.
    * **Observations** are an (num_envs, size) float32 array (or the Dict of (num_envs, ·)
      arrays with ``goal_conditioned=True``).
    * **info** is a dict of arrays in the Gymnasium vector convention (the single env's entries
      stacked), each with its ``_key`` mask.
    * ``reset(options=...)`` takes the single env's ``goal`` and ``initial_tensions``, either one
      for all envs or one per env, and Gymnasium's ``reset_mask`` ((num_envs,) bool).

    Not supported: rendering (use a single env).

    Args:
        num_envs: number of envs (>= 1).
        max_episode_steps: episode length (>= 1) or ``None`` for no truncation.
        backend: a batched backend, ``"CCKA"`` or ``"MuJoCo"`` (N robots in one backend).
        task: task name (``"Reach"``, ...; see ``cdcr_gym.envs.factory.TASKS``).
        goal_conditioned: Dict observations (Gymnasium-Robotics convention).
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default) or ``SAME_STEP`` (or their
            values ``"NextStep"``, ``"SameStep"``).
        **kwargs: the single env's arguments (robot/params, task and env arguments), validated
            as ``gymnasium.make`` validates them. ``initial_state`` may also be a sequence of
            ``num_envs`` values, one per env.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        *,
        max_episode_steps: int | None = defaults.MAX_EPISODE_STEPS,
        backend: str = "CCKA",
        task: str = "Reach",
        goal_conditioned: bool = False,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        n = validation.integer(num_envs, "num_envs", 1)
        if max_episode_steps is not None:
            max_episode_steps = validation.integer(max_episode_steps, "max_episode_steps", 1)
        mode: AutoresetMode | None
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                "autoreset_mode must be AutoresetMode.NEXT_STEP or AutoresetMode.SAME_STEP"
            )
        if render_mode is not None:
            raise ValueError(
                f"render_mode={render_mode!r}: the batched env does not render; use "
                f"gymnasium.make_vec(..., vectorization_mode='sync') or a single env to render"
            )
        self.autoreset_mode = mode
        self.num_envs = n
        self.max_episode_steps = max_episode_steps
        self.render_mode = None
        self.goal_conditioned = validation.flag(goal_conditioned, "goal_conditioned")
        robots, task_object, env_kw = factory.assemble(
            backend,
            task,
            kwargs,
            robot=kwargs.pop("robot", None),
            params=kwargs.pop("params", None),
            num_robots=n,
        )
        for key in RENDER_KEYS:  # accepted (as gymnasium.make accepts them), nothing to render
            env_kw.pop(key, None)
        try:
            self.core = EnvCore(
                robots, task_object, goal_conditioned=self.goal_conditioned, **env_kw
            )
        except Exception:
            robots.close()
            raise
        self.single_action_space = self.core.action_space
        self.single_observation_space = self.core.observation_space
        self.action_space = batch_space(self.single_action_space, n)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.metadata = dict(self.metadata)
        self.metadata["autoreset_mode"] = self.autoreset_mode
        self._action_shape = (n, self.core.n_cables)
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._rng_seeds: list[int | None] = [None] * n
        self._steps = np.zeros(n, dtype=np.int64)
        self._autoreset = np.zeros(n, dtype=np.bool_)
        self._all = np.arange(n)
        self._all_true = np.ones(n, dtype=np.bool_)
        self._all_true.flags.writeable = False  # shared by every info's "_key" masks
        self._needs_reset = True

    # -- seeding --------------------------------------------------------------------------------
    # one generator (seed) per env, as SyncVectorEnv's: not the base class's single one
    @property  # type: ignore[misc]
    def np_random(self) -> tuple[np.random.Generator, ...]:  # type: ignore[override]
        """The envs' random generators (seeded by ``reset(seed=...)``), like ``SyncVectorEnv``."""
        return tuple(self._rng(i) for i in range(self.num_envs))

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:  # type: ignore[override]
        """The seeds the envs' generators were made from (-1 where none was made yet)."""
        return tuple(-1 if s is None else s for s in self._rng_seeds)

    def _rng(self, i: int) -> np.random.Generator:
        rng = self._rngs[i]
        if rng is None:
            rng, self._rng_seeds[i] = seeding.np_random(None)
            self._rngs[i] = rng
        return rng

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
            seeds = list(seed)  # type: ignore[arg-type]  # a sequence of per-env seeds
            if len(seeds) != n:
                raise ValueError(
                    f"seed must be None, an int or a list of num_envs={n} seeds, got {len(seeds)}"
                )
        idx, initial_tensions, goal = self.core.reset_options(options, allow_mask=True)
        mask = None if idx is None else options["reset_mask"]  # type: ignore[index]
        if idx is None:
            idx = self._all
        fresh = {i: seeding.np_random(seeds[i]) for i in idx.tolist() if seeds[i] is not None}
        for i, (rng, used_seed) in fresh.items():  # every seed checked before any is set
            self._rngs[i], self._rng_seeds[i] = rng, used_seed
        self._reset_envs(idx, initial_tensions, goal)
        self._autoreset[idx] = False
        self._needs_reset = False
        obs, _, _, info = self.core.observe()
        info = self._with_masks(info)
        if mask is not None:
            for key in list(info):
                if key.startswith("_"):
                    info[key] = mask.copy()
        return obs, info

    def step(
        self, actions: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._needs_reset:
            raise gym_error.ResetNeeded("Cannot call step() before reset()")
        resetting = self._autoreset
        any_reset = bool(resetting.any())
        if any_reset:  # resetting envs ignore their actions (even non-finite ones)
            raw = np.asarray(actions)
            if raw.dtype.kind not in "fiu" or raw.shape != self._action_shape:
                validation.real_array(actions, "actions", self._action_shape, allow_bool=False)
            a = validation.real_array(np.where(resetting[:, None], 0.0, raw), "actions")
        else:
            a = validation.action_array(actions, self._action_shape)
        np.clip(a, -1.0, 1.0, out=a)
        self.core.step(a, ~resetting if any_reset else None)
        self._steps += 1
        if any_reset:  # NEXT_STEP autoreset: these envs return their reset state instead
            self._reset_envs(np.flatnonzero(resetting))
        obs, reward, success, info = self.core.observe()
        n = self.num_envs
        terminated = self.core.terminated(success)
        if self.max_episode_steps is None:
            truncated = np.zeros(n, dtype=np.bool_)
        else:
            truncated = self._steps >= self.max_episode_steps
        if any_reset:
            reward = np.where(resetting, 0.0, reward)
            terminated[resetting] = False
            truncated[resetting] = False
        done = terminated | truncated
        info = self._with_masks(info)
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._autoreset = done
        elif done.any():  # SAME_STEP: reset now, keep the episode's last obs and info aside
            obs, info = self._reset_within_step(done, obs, info)
        return obs, reward, terminated, truncated, info

    def _with_masks(self, info: dict[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            out[f"_{key}"] = self._all_true
        return out

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
        for key, value in info.items():
            if key.startswith("_"):
                continue
            kept = np.zeros_like(value)
            kept[idx] = value[idx]
            final_info[key] = kept
            final_info[f"_{key}"] = done.copy()
        self._reset_envs(idx)
        obs, _, _, info = self.core.observe()
        info = self._with_masks(info)
        info["final_obs"] = final_obs
        info["_final_obs"] = done.copy()
        info["final_info"] = final_info
        info["_final_info"] = done.copy()
        return obs, info

    def _reset_envs(self, idx: np.ndarray, initial_tensions: Any = None, goal: Any = None) -> None:
        rngs = self._rngs
        if None in rngs:
            for i in idx.tolist():
                self._rng(i)
        self.core.reset(idx, [rngs[i] for i in idx.tolist()], initial_tensions, goal)
        self._steps[idx] = 0

    def render(self) -> None:
        return None

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """Goal-conditioned reward, vectorised over leading dimensions (as the single env's)."""
        return self.task.compute_reward(achieved_goal, desired_goal, info)

    def close_extras(self, **kwargs: Any) -> None:
        self.core.backend.close()
