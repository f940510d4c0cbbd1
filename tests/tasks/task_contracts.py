"""Contracts every task id must keep (shared by tests/test_task_*.py): Gymnasium and SB3
checks, observations inside their space, determinism, batched env = single envs."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import cdcr_gym  # noqa: F401  (registers the ids)

#: robots per backend (each models n sections)
ROBOTS = {"CCKA": ["paper", "tdcr2"], "Bullet": ["paper", "tdcr2"], "MuJoCo": ["paper", "tdcr2"]}
#: backends with a batched vector entry point (``gym.make_vec(..., "vector_entry_point")``)
BATCHED = ["CCKA", "MuJoCo"]


def combos(task: str) -> list[tuple[str, str]]:
    """(env id, robot) pairs of a task."""
    return [(f"cdcr_gym/{b}{task}-v0", r) for b, robots in ROBOTS.items() for r in robots]


def batched_ids(task: str) -> list[str]:
    """The ids of a task whose backend steps N robots in one batched env."""
    return [f"cdcr_gym/{b}{task}-v0" for b in BATCHED]


def make(env_id: str, robot: str, **kwargs):
    if env_id.startswith("cdcr_gym/Bullet"):
        kwargs.setdefault("gravity", False)
    return gym.make(env_id, robot=robot, **kwargs)


def check_env_both(env) -> None:
    """Gymnasium's and SB3's env checkers, with every warning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)


def rollout(env_id: str, robot: str, seed: int = 5, steps: int = 12, **kwargs) -> np.ndarray:
    """Observations, rewards and info numbers of a seeded random-action rollout, flattened;
    also asserts every observation is inside the observation space."""
    env = make(env_id, robot, **kwargs)
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(steps):
        assert env.observation_space.contains(obs), obs
        rows.append(_flat(obs))
        obs, reward, terminated, truncated, info = env.step(
            rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        )
        rows.append(np.array([reward, terminated, truncated], dtype=np.float64))
        rows.extend(np.ravel(np.asarray(v, dtype=np.float64)) for v in info.values())
        if terminated:
            obs, info = env.reset()
    env.close()
    return np.concatenate(rows)


def _flat(obs) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate([np.ravel(obs[k]) for k in sorted(obs)]).astype(np.float64)
    return np.asarray(obs, dtype=np.float64)


def batched_matches_single(env_id: str, robot: str, n: int = 3, steps: int = 25, **kwargs):
    """The batched vector env and n single envs give the same rollouts (across autoresets)."""
    venv = gym.make_vec(
        env_id,
        num_envs=n,
        robot=robot,
        vectorization_mode="vector_entry_point",
        max_episode_steps=10,
        **kwargs,
    )
    envs = [gym.make(env_id, robot=robot, max_episode_steps=10, **kwargs) for _ in range(n)]
    obs_v, _ = venv.reset(seed=9)
    obs_s = [e.reset(seed=9 + i)[0] for i, e in enumerate(envs)]
    np.testing.assert_allclose(obs_v, np.stack(obs_s), rtol=0, atol=1e-6)
    rng = np.random.default_rng(0)
    done = np.zeros(n, dtype=bool)
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (n, venv.single_action_space.shape[0])).astype(np.float32)
        obs_v, r_v, term_v, trunc_v, _ = venv.step(actions)
        for i, e in enumerate(envs):
            if done[i]:
                o, _ = e.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, _ = e.step(actions[i])
            np.testing.assert_allclose(obs_v[i], o, rtol=0, atol=1e-6)
            assert abs(r_v[i] - r) < 1e-9 and term_v[i] == te and trunc_v[i] == tr
            done[i] = te or tr
    venv.close()
