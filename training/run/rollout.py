"""Fixed-goal evaluation episodes, run in lockstep over many envs, for any policy.

Used by the periodic evaluation during training (``training.run.train``) and by
``training.evaluate``. A *policy* here is a function from a batch of observations (b, obs_dim)
to a batch of actions (b, 3): a PPO model behind its VecNormalize statistics
(:class:`SB3Policy`, any algo) or the analytic-IK controller (``cdcr_gym.controllers``), so both run on
exactly the same goals and starting shapes.

Episode specs (goal, starting tensions) are drawn by resetting a CCKA env with seeds
``seed, seed + 1, ...``: the goal and start sampling depends only on the robot parameters and the
seed, not on the backend, so the same specs serve every backend, and the IK controller and the
policy are put on them with ``reset(options={"goal": ..., "initial_tensions": ...})``.
"""

from __future__ import annotations

import pickle
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.envs.env import ReachEnv
from cdcr_gym.params import RobotParams

__all__ = [
    "parse_env_kwarg",
    "check_env_id",
    "cdcr_env_ids",
    "EpisodeSpecs",
    "Rollouts",
    "SB3Policy",
    "algo_class",
    "make_specs",
    "concat_specs",
    "make_env",
    "run_episodes",
    "error_stats",
    "summarize",
]

PolicyFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class EpisodeSpecs:
    """Goals (n, 3) m and starting tensions (n, 3) N of n evaluation episodes."""

    goals: np.ndarray
    initial_tensions: np.ndarray
    initial_state: str
    seed: int

    def __len__(self) -> int:
        return len(self.goals)


@dataclass
class Rollouts:
    """What happened in n episodes of ``horizon`` steps (arrays float64, SI units)."""

    distances: np.ndarray  # (n, horizon + 1) tip-to-goal distance after reset and each step, m
    final_tip: np.ndarray  # (n, 3) m
    final_tensions: np.ndarray  # (n, 3) N
    final_lengths: np.ndarray  # (n, 3) m
    returns: np.ndarray  # (n,) sum of rewards
    episode_length: np.ndarray  # (n,) steps actually taken (< horizon if terminated)
    goals: np.ndarray  # (n, 3) m
    trajectories: list[np.ndarray] | None = None  # tips (steps + 1, 3) per episode, if recorded

    @property
    def final_distance(self) -> np.ndarray:
        """(n,) final tip error, m."""
        return self.distances[:, -1]


def make_specs(
    n: int, seed: int, initial_state: str = "straight", params: Any = None
) -> EpisodeSpecs:
    """Goals and starting tensions of ``n`` episodes, drawn with reset seeds seed + i."""
    env = ReachEnv(AnalyticBackend(params), initial_state=initial_state)
    goals = np.empty((n, 3))
    starts = np.empty((n, 3))
    for i in range(n):
        _, info = env.reset(seed=seed + i)
        goals[i] = info["goal"]
        starts[i] = info["tensions"]
    env.close()
    return EpisodeSpecs(goals, starts, initial_state, seed)


def concat_specs(parts: list[EpisodeSpecs]) -> EpisodeSpecs:
    """One :class:`EpisodeSpecs` holding the episodes of ``parts`` in order."""
    return EpisodeSpecs(
        np.concatenate([p.goals for p in parts]),
        np.concatenate([p.initial_tensions for p in parts]),
        "+".join(p.initial_state for p in parts),
        parts[0].seed,
    )


def make_env(
    env_id: str,
    env_kwargs: dict[str, Any] | None = None,
    max_episode_steps: int | None = None,
    render_mode: str | None = None,
) -> gym.Env:
    """``gymnasium.make(env_id, **env_kwargs)`` with an optional episode length and render mode.

    A ``params`` entry given as a mapping (from YAML) becomes a ``RobotParams``.
    """
    kwargs = dict(env_kwargs or {})
    if isinstance(kwargs.get("params"), dict):
        kwargs["params"] = RobotParams(**kwargs["params"])
    if render_mode is not None:
        kwargs["render_mode"] = render_mode
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    return gym.make(env_id, **kwargs)


def cdcr_env_ids() -> list[str]:
    """The registered cdcr_gym ids."""

    return sorted(k for k in gym.registry if k.startswith("cdcr_gym/"))


def check_env_id(env_id: str, what: str = "--env-id") -> None:
    """Raise ValueError naming ``what`` unless ``env_id`` is a registered cdcr_gym env (another
    package's env, e.g. ``CartPole-v1``, has none of the robot's observations, goals or oracle)."""
    known = cdcr_env_ids()
    if env_id not in gym.registry:
        raise ValueError(f"{what} {env_id!r} is not registered; known ids: {known}")
    entry = gym.registry[env_id].entry_point
    if not (isinstance(entry, str) and entry.startswith("cdcr_gym.")):
        raise ValueError(
            f"{what} {env_id!r} is not a cdcr_gym env (entry point {entry!r}); "
            f"the cdcr_gym ids are {known}"
        )


def parse_env_kwarg(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of an ``--env-kwarg`` argument: the key and the value read as YAML
    (``gravity=false`` -> ``("gravity", False)``). Raises ValueError naming ``--env-kwarg``."""
    import yaml

    key, sep, value = text.partition("=")
    if not sep:
        raise ValueError(f"--env-kwarg must look like KEY=VALUE, got {text!r}")
    if not key.isidentifier():
        raise ValueError(f"--env-kwarg key must be an identifier, got {key!r}")
    return key, yaml.safe_load(value)


class ModelFileError(ValueError):
    """A saved model or normalisation file that cannot be read (the message names the file)."""


def algo_class(algo: str) -> Any:
    """The stable-baselines3 (or sb3-contrib) class of ``algo`` (ppo | sac | td3 | tqc).

    Raises ValueError naming ``algo`` for an unknown name, ImportError naming the missing
    package (sb3-contrib for tqc)."""
    if algo == "tqc":
        try:
            from sb3_contrib import TQC
        except ImportError:
            raise ImportError(
                "algo: tqc needs sb3-contrib; pip install 'cdcr-gym[train]' (or sb3-contrib)"
            ) from None
        return TQC
    import stable_baselines3

    classes = {"ppo": "PPO", "sac": "SAC", "td3": "TD3"}
    if algo not in classes:
        raise ValueError(f"algo must be one of ['ppo', 'sac', 'td3', 'tqc'], got {algo!r}")
    return getattr(stable_baselines3, classes[algo])


class SB3Policy:
    """A saved model of any algo and its VecNormalize statistics as a batched, deterministic
    policy.

    Args:
        model_path: the ``.zip`` saved by stable-baselines3.
        vecnormalize_path: the pickled ``VecNormalize`` of the run (None: no normalisation).
        device: torch device.
        algo: the algorithm that saved it (ppo | sac | td3 | tqc; the run's ``config.yaml``).
    """

    def __init__(
        self,
        model_path: str | Path,
        vecnormalize_path: str | Path | None,
        device: str = "cpu",
        algo: str = "ppo",
    ) -> None:
        # The schedules are not needed to act; replacing them avoids unpickling closures. An
        # off-policy model gets a one-transition plain buffer (HER's needs the training env).
        custom: dict[str, Any] = {
            "learning_rate": 0.0,
            "lr_schedule": lambda _: 0.0,
            "clip_range": lambda _: 0.0,
        }
        if algo != "ppo":
            custom.update({"replay_buffer_class": None, "replay_buffer_kwargs": {}})
            custom["buffer_size"] = 1
        cls = algo_class(algo)
        try:
            self.model = cls.load(str(model_path), device=device, custom_objects=custom)
        except Exception as exc:  # a truncated/empty/foreign zip fails in many ways
            raise ModelFileError(
                f"{str(model_path)!r} is not a readable stable-baselines3 model "
                f"({type(exc).__name__}: {exc})"
            ) from None
        self.obs_normalizer = None
        if vecnormalize_path is not None:
            try:
                with open(vecnormalize_path, "rb") as f:
                    vecnorm = pickle.load(f)
                vecnorm.training = False
            except Exception as exc:
                raise ModelFileError(
                    f"{str(vecnormalize_path)!r} is not a readable VecNormalize file "
                    f"({type(exc).__name__}: {exc})"
                ) from None
            self.obs_normalizer = vecnorm

    @classmethod
    def from_model(cls, model: Any, vecnorm: Any | None) -> SB3Policy:
        """Wrap a live model (and its live VecNormalize, whose current statistics are used)."""
        self = cls.__new__(cls)
        self.model = model
        self.obs_normalizer = vecnorm
        return self

    def __call__(self, obs: Any) -> np.ndarray:
        """Actions (b, 3) for a batch of observations: an array (b, obs_dim), or a dict of
        arrays (b, ...) for a goal-conditioned env."""
        if self.obs_normalizer is not None:
            obs = self.obs_normalizer.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=True)
        return action


def _stack_obs(obs_list: list[Any]) -> Any:
    """Single-env observations stacked into a batch (a dict of batches for Dict observations)."""
    if isinstance(obs_list[0], dict):
        return {k: np.stack([o[k] for o in obs_list]) for k in obs_list[0]}
    return np.stack(obs_list)


def _set_obs_row(batch: Any, k: int, obs: Any) -> None:
    if isinstance(batch, dict):
        for key, value in obs.items():
            batch[key][k] = value
    else:
        batch[k] = obs


def run_episodes(
    env_fn: Callable[[], gym.Env],
    policy: PolicyFn,
    specs: EpisodeSpecs,
    horizon: int,
    batch_size: int = 50,
    record_trajectories: bool = False,
) -> Rollouts:
    """Run one episode per spec, ``horizon`` steps each, ``batch_size`` envs in lockstep.

    ``env_fn`` makes one env (its own TimeLimit must not be shorter than ``horizon``). An
    episode that terminates (``terminate_on_success``) keeps its terminal state from then on.
    """
    n = len(specs)
    distances = np.empty((n, horizon + 1))
    final_tip = np.empty((n, 3))
    final_tensions = np.empty((n, 3))
    final_lengths = np.empty((n, 3))
    returns = np.zeros(n)
    lengths = np.full(n, horizon)
    trajectories: list[np.ndarray] | None = [] if record_trajectories else None
    envs = [env_fn() for _ in range(min(batch_size, n))]
    try:
        for start in range(0, n, len(envs)):
            idx = np.arange(start, min(start + len(envs), n))
            obs_list, infos = [], []
            for env, i in zip(envs, idx, strict=False):
                obs, info = env.reset(
                    options={"goal": specs.goals[i], "initial_tensions": specs.initial_tensions[i]}
                )
                obs_list.append(obs)
                infos.append(info)
            obs = _stack_obs(obs_list)
            alive = np.ones(len(idx), dtype=bool)
            tips = [[info["tip"]] for info in infos]
            distances[idx, 0] = [info["distance"] for info in infos]
            for t in range(1, horizon + 1):
                actions = np.asarray(policy(obs))
                for k, (env, i) in enumerate(zip(envs, idx, strict=False)):
                    if alive[k]:
                        o, reward, terminated, truncated, info = env.step(actions[k])
                        _set_obs_row(obs, k, o)
                        infos[k] = info
                        returns[i] += reward
                        if terminated or (truncated and t < horizon):
                            alive[k] = False
                            lengths[i] = t
                    distances[i, t] = infos[k]["distance"]
                    if record_trajectories and alive[k]:
                        tips[k].append(infos[k]["tip"])
            for k, i in enumerate(idx):
                final_tip[i] = infos[k]["tip"]
                final_tensions[i] = infos[k]["tensions"]
                final_lengths[i] = infos[k]["cable_lengths"]
                if trajectories is not None:
                    trajectories.append(np.asarray(tips[k]))
    finally:
        for env in envs:
            env.close()
    return Rollouts(
        distances,
        final_tip,
        final_tensions,
        final_lengths,
        returns,
        lengths,
        specs.goals.copy(),
        trajectories,
    )


def error_stats(values: np.ndarray, scale: float = 1.0) -> dict[str, float]:
    """``mean``, ``median``, ``p95``, ``max`` of ``values`` × ``scale``."""
    v = np.asarray(values, dtype=np.float64) * scale
    return {
        "mean": float(np.mean(v)),
        "median": float(np.median(v)),
        "p95": float(np.percentile(v, 95)),
        "max": float(np.max(v)),
    }


def summarize(final_distance: np.ndarray, threshold: float) -> dict[str, Any]:
    """Success rate (at ``threshold`` m), fraction within 1 mm and error statistics in mm."""
    d = np.asarray(final_distance, dtype=np.float64)
    return {
        "success_rate": float(np.mean(d <= threshold)),
        "within_1mm": float(np.mean(d <= 0.001)),
        "error_mm": error_stats(d, 1000.0),
    }
