"""stable-baselines3 ``VecEnv`` over the batched env: N robots per backend call, SB3 semantics.

``BatchedVecEnv(8, seed=0, action_mode="tension_delta")`` is a drop-in replacement for
``make_vec_env("cdcr_gym/CCKAReach-v0", n_envs=8, seed=0, env_kwargs=...)`` (a ``DummyVecEnv`` of
single envs), and ``BatchedVecEnv(8, seed=0, backend="MuJoCo", gravity=True)`` for
``cdcr_gym/MuJoCoReach-v0`` (any backend of ``cdcr_gym.registration.BATCHED``): same spaces,
same episodes (same seeds give the same trajectories), SB3's conventions
— an env that terminates or truncates is reset within the same step, the returned observation is
the new episode's first, and its ``info`` carries ``terminal_observation`` and
``TimeLimit.truncated``; every ``info`` carries ``is_success`` (SB3 logs the success rate from it)
and the single env's other keys.

Unlike ``make_vec_env`` it does not add a ``Monitor``: wrap it in
``stable_baselines3.common.vec_env.VecMonitor`` for episode statistics.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from cdcr_gym import MAX_EPISODE_STEPS
from cdcr_gym.envs.vector import CDCRVectorEnv

__all__ = ["BatchedVecEnv"]


class BatchedVecEnv(VecEnv):
    """``num_envs`` envs of one batched backend as one stable-baselines3 ``VecEnv``.

    The backend (``backend=``, default ``"CCKA"``: batched in numpy; ``"MuJoCo"``: one
    ``MjModel``, N ``MjData``) and the task (``task=``, default ``"Reach"``) are those of
    ``cdcr_gym.envs.vector.CDCRVectorEnv``.

    Args:
        num_envs: number of envs (>= 1).
        seed: seeds env i with ``seed + i`` at the first reset (as ``make_vec_env(seed=...)``);
            ``None`` for random seeds.
        per_env_kwargs: per-env overrides, env i taking ``per_env_kwargs[i % len]`` (as
            ``training.run.train`` does for single envs); only ``initial_state`` may vary per env;
            any other key must have the same value in every entry and then applies to all envs
            (e.g. ``randomize`` / ``imperfections`` kept out of the evaluation's ``env.kwargs``).
        **env_kwargs: ``backend`` and ``task``, and the single env's keyword arguments
            (``gymnasium.make("cdcr_gym/CCKAReach-v0", ...)``: ``action_mode``, ``reward_type``, ``params``, ``goal_conditioned``, ...), and
            ``max_episode_steps`` (default: the registered 100).
    """

    def __init__(
        self,
        num_envs: int,
        seed: int | None = None,
        per_env_kwargs: Sequence[dict[str, Any]] | None = None,
        **env_kwargs: Any,
    ) -> None:
        env_kwargs.setdefault("max_episode_steps", MAX_EPISODE_STEPS)
        if per_env_kwargs:
            per_env_kwargs = [dict(kw) for kw in per_env_kwargs]
            keys = set().union(*per_env_kwargs) - {"initial_state"}
            varying = sorted(
                k
                for k in keys
                if any(k not in kw or kw[k] != per_env_kwargs[0][k] for kw in per_env_kwargs)
            )
            if varying:
                raise ValueError(
                    f"per_env_kwargs: only 'initial_state' can vary per env in the batched env, "
                    f"got varying {varying}"
                )
            for key in keys:  # the same in every entry: a setting of all envs
                env_kwargs[key] = per_env_kwargs[0][key]
            default = env_kwargs.get("initial_state", "straight")
            env_kwargs["initial_state"] = [
                per_env_kwargs[i % len(per_env_kwargs)].get("initial_state", default)
                for i in range(num_envs)
            ]
        self.venv = CDCRVectorEnv(num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **env_kwargs)
        self.env_kwargs = dict(env_kwargs)
        self._actions: np.ndarray | None = None
        super().__init__(
            num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )
        if seed is not None:
            self.seed(seed)

    # -- VecEnv API -----------------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        obs, info = self.venv.reset(seed=seeds, options=self._batched_options())
        self.reset_infos = self._split_info(info)
        self._reset_seeds()
        self._reset_options()
        return self._to_sb3_obs(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async()")
        actions = np.asarray(self._actions).reshape(self.num_envs, -1)
        self._actions = None
        obs, reward, terminated, truncated, info = self.venv.step(actions)
        dones = terminated | truncated
        infos = self._split_info(info)
        if "final_info" in info:  # finished envs: `info` is their reset's, `final_info` the step's
            finals = self._split_info(info["final_info"], only=dones)
            for i in np.flatnonzero(dones).tolist():
                self.reset_infos[i] = infos[i]
                infos[i] = finals[i]
                infos[i]["terminal_observation"] = info["final_obs"][i]
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return self._to_sb3_obs(obs), reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """Each env's value of an attribute of the batched env.

        Per-env values (``np_random``, ``np_random_seed``, a per-env ``initial_state``) are
        indexed; everything else is the configuration all envs share.
        """
        value = getattr(self.venv, attr_name)
        per_env = attr_name in ("np_random", "np_random_seed") or (
            attr_name == "initial_state" and isinstance(value, tuple)
        )
        return [value[i] if per_env else value for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the batched env: only for all envs at once."""
        if len(list(self._get_indices(indices))) != self.num_envs:
            raise ValueError(f"set_attr({attr_name!r}) applies to all envs of a batched env")
        setattr(self.venv, attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        """Call a method of the batched env once per index (e.g. ``compute_reward`` for HER)."""
        method = getattr(self.venv, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]

    # -- conversions ----------------------------------------------------------------------------
    def _batched_options(self) -> dict[str, Any] | None:
        """SB3's per-env options as the batched env's (values stacked per env)."""
        if not any(self._options):
            return None
        keys = set(self._options[0])
        if any(set(o) != keys for o in self._options):
            raise ValueError("set_options: every env needs the same option keys")
        return {
            k: np.stack([np.asarray(o[k], dtype=np.float64) for o in self._options]) for k in keys
        }

    @staticmethod
    def _to_sb3_obs(obs: Any) -> VecEnvObs:
        if isinstance(obs, dict):
            return {k: np.ascontiguousarray(v) for k, v in obs.items()}
        return np.ascontiguousarray(obs)

    def _split_info(
        self, info: dict[str, Any], only: np.ndarray | None = None
    ) -> list[dict[str, Any]]:
        """The vector info dict as one dict per env (empty for envs outside ``only``).

        Every entry of the batched info (the task's and the robot's, without the ``_key`` masks
        and the ``final_*`` entries) becomes the single env's: a Python scalar for (N,) arrays,
        a copied row otherwise."""
        keys = [k for k in info if not k.startswith("_") and not k.startswith("final_")]
        columns = {k: info[k].tolist() if info[k].ndim == 1 else info[k] for k in keys}
        out: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            if only is not None and not only[i]:
                out.append({})
                continue
            out.append(
                {k: (v[i] if isinstance(v, list) else v[i].copy()) for k, v in columns.items()}
            )
        return out
