"""Pre-training PPO from the task oracle's demonstrations (behaviour cloning), before ``learn``.

``demonstrations.episodes`` > 0 in a PPO config (:class:`~training.run.config.DemonstrationsConfig`)
runs, on a fresh run only, before the first PPO update:

1. **Collect**: the task's oracle (``training.run.metrics.oracle_for``: the RRT-Connect
   planner for Obstacle, the pose/tracking IK, the reach IK; closed loop on a physics backend)
   acts in the training envs themselves (the ``VecNormalize``-wrapped vec env, so the observation
   and return statistics start from the oracle's state distribution) for at least ``episodes``
   complete episodes. Kept per transition: the raw observation (O,), the oracle's action (A,) in
   the env's action units ([-1, 1]) and the raw reward.
2. **Clone**: ``epochs`` passes over the transitions in shuffled minibatches of ``batch_size``
   (Adam, ``learning_rate``) minimise the squared error between the policy's mean action on the
   *normalised* observation and the oracle's action; the policy's ``log_std`` is not trained
   (PPO's exploration starts from the config's ``log_std_init``). With ``value`` the critic is
   fitted too, to the discounted return (PPO's γ) of the normalised rewards from each transition
   to its episode's end (no bootstrap at the time limit: with γ ≤ 0.9 the omitted tail is
   < γ^k of a reward k steps before the end).

The env steps of the demonstrations are not counted in PPO's ``total_timesteps`` (they are the
oracle's, not the policy's); they are reported in ``demonstrations.json`` of the run directory
(episodes, transitions, the oracle's success rate on them, the losses before and after cloning,
wall time), and the wall time counts in the run's ``wall_time_s`` and its
``runtime.max_wall_time_s`` budget.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from training.run.config import ConfigError
from training.run.metrics import is_physics, oracle_for
from training.run.rollout import make_env

__all__ = ["Demonstrations", "collect_demonstrations", "clone_demonstrations", "pretrain"]


@dataclass
class Demonstrations:
    """Oracle transitions from complete episodes: ``obs`` (N, O) raw, ``actions`` (N, A) in
    [-1, 1], ``rewards`` (N,) raw, ``episode_end`` (N,) bool (the last step of its episode),
    ``successes`` (E,) bool per episode (the task's ``is_success`` at its last step)."""

    obs: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    episode_end: np.ndarray
    successes: np.ndarray

    def returns(self, gamma: float, rewards: np.ndarray | None = None) -> np.ndarray:
        """(N,) discounted return of ``rewards`` (default: the raw ones) from each transition
        to the end of its episode."""
        r = self.rewards if rewards is None else rewards
        out = np.zeros(len(r), dtype=np.float64)
        running = 0.0
        for i in range(len(r) - 1, -1, -1):
            if self.episode_end[i]:
                running = 0.0
            running = float(r[i]) + gamma * running
            out[i] = running
        return out


def _unwrap_normalize(venv: Any) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    return venv if isinstance(venv, VecNormalize) else None


def collect_demonstrations(venv: Any, oracle: Any, episodes: int) -> Demonstrations:
    """Run ``oracle`` (flat raw observations (n, O) -> actions (n, A)) in ``venv`` (a SB3
    VecEnv, possibly ``VecNormalize``-wrapped) until at least ``episodes`` episodes have ended;
    keep the complete episodes only (each env's trailing, unfinished one is dropped)."""
    if isinstance(episodes, bool) or int(episodes) != episodes or episodes < 1:
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    norm = _unwrap_normalize(venv)
    n = venv.num_envs
    first = venv.reset()
    raw = norm.get_original_obs() if norm is not None else first
    streams: list[list[tuple[np.ndarray, np.ndarray, float, bool]]] = [[] for _ in range(n)]
    kept: list[list[tuple[np.ndarray, np.ndarray, float, bool]]] = []
    successes: list[bool] = []
    while len(successes) < episodes:
        raw = np.asarray(raw, dtype=np.float64)
        actions = np.asarray(oracle(raw), dtype=np.float32).reshape(n, -1)
        obs, rewards, dones, infos = venv.step(actions)
        if norm is not None:
            rewards = norm.get_original_reward()
            obs = norm.get_original_obs()
        for i in range(n):
            streams[i].append((raw[i].copy(), actions[i].copy(), float(rewards[i]), bool(dones[i])))
            if dones[i]:
                kept.append(streams[i])
                successes.append(bool(infos[i].get("is_success", False)))
                streams[i] = []
        raw = obs
    rows = [t for episode in kept for t in episode]
    return Demonstrations(
        obs=np.stack([t[0] for t in rows]),
        actions=np.stack([t[1] for t in rows]),
        rewards=np.array([t[2] for t in rows]),
        episode_end=np.array([t[3] for t in rows]),
        successes=np.array(successes, dtype=bool),
    )


def clone_demonstrations(
    policy: Any,
    obs: np.ndarray,
    actions: np.ndarray,
    returns: np.ndarray | None,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: int,
) -> dict[str, float]:
    """Fit ``policy`` (a SB3 ``ActorCriticPolicy``) to the demonstrations in place: its mean
    action on ``obs`` (N, O), already normalised, to ``actions`` (N, A), and, if ``returns``
    (N,) is given, its value to them. Returns the action and value MSE before and after."""
    import torch as th

    obs_t = th.as_tensor(obs, dtype=th.float32, device=policy.device)
    act_t = th.as_tensor(actions, dtype=th.float32, device=policy.device)
    ret_t = None if returns is None else th.as_tensor(returns, dtype=th.float32).to(policy.device)
    params = [p for name, p in policy.named_parameters() if name != "log_std"]
    optimizer = th.optim.Adam(params, lr=learning_rate)
    rng = np.random.default_rng(seed)

    def losses(idx: Any) -> tuple[Any, Any]:
        dist = policy.get_distribution(obs_t[idx])
        action_loss = th.mean((dist.distribution.mean - act_t[idx]) ** 2)
        if ret_t is None:
            return action_loss, th.zeros(())
        value_loss = th.mean((policy.predict_values(obs_t[idx]).flatten() - ret_t[idx]) ** 2)
        return action_loss, value_loss

    def measure() -> tuple[float, float]:
        with th.no_grad():
            a, v = losses(slice(None))
        return float(a), float(v)

    before = measure()
    policy.set_training_mode(True)
    for _ in range(epochs):
        order = rng.permutation(len(obs))
        for start in range(0, len(order), batch_size):
            idx = th.as_tensor(order[start : start + batch_size], device=policy.device)
            action_loss, value_loss = losses(idx)
            optimizer.zero_grad()
            (action_loss + value_loss).backward()
            optimizer.step()
    policy.set_training_mode(False)
    after = measure()
    out = {"action_mse_before": before[0], "action_mse_after": after[0]}
    if returns is not None:
        out.update({"value_mse_before": before[1], "value_mse_after": after[1]})
    return out


def _make_oracle(config: Any) -> tuple[Any, str]:
    """The demonstrations' oracle for ``config`` and its kind; ConfigError names oracle_kwargs."""
    d = config.demonstrations
    probe = make_env(config.env.id, dict(config.env.kwargs), config.env.max_episode_steps)
    kind = "closed_loop" if is_physics(probe) else "oracle"
    try:
        return oracle_for(probe, kind, **d.oracle_kwargs), kind
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"demonstrations.oracle_kwargs {d.oracle_kwargs!r}: {exc}") from None
    finally:
        probe.close()


def check_demonstrations(config: Any) -> None:
    """Make the oracle once, before the run directory exists: a bad
    ``demonstrations.oracle_kwargs`` is a ConfigError (exit 2) with nothing written."""
    if config.demonstrations.episodes:
        _make_oracle(config)


def pretrain(config: Any, model: Any, venv: Any) -> dict[str, Any]:
    """Collect the oracle's demonstrations in ``venv`` and clone them into ``model`` (a PPO)
    as ``config.demonstrations`` says; returns the report written to ``demonstrations.json``."""

    d = config.demonstrations
    t0 = time.perf_counter()
    oracle, kind = _make_oracle(config)
    demos = collect_demonstrations(venv, oracle, d.episodes)
    collected = time.perf_counter() - t0
    norm = _unwrap_normalize(venv)
    obs = norm.normalize_obs(demos.obs) if norm is not None else demos.obs
    returns = None
    if d.value:
        rewards = norm.normalize_reward(demos.rewards) if norm is not None else demos.rewards
        returns = demos.returns(config.ppo.gamma, rewards)
    losses = clone_demonstrations(
        model.policy,
        obs,
        demos.actions,
        returns,
        d.epochs,
        d.batch_size,
        d.learning_rate,
        config.seed,
    )
    return {
        "oracle": f"{type(oracle).__name__} ({kind.replace('_', ' ')})",
        "episodes": int(len(demos.successes)),
        "transitions": int(len(demos.obs)),
        "oracle_success_rate": float(np.mean(demos.successes)),
        **{k: round(v, 6) for k, v in losses.items()},
        "collect_wall_time_s": round(collected, 2),
        "wall_time_s": round(time.perf_counter() - t0, 2),
    }
