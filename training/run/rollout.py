"""The one rollout of the pipeline: episodes of any task, for any policy, run in lockstep over
a few envs.

Used by the periodic evaluation during training (:mod:`training.run.callbacks`), by
``cdcr-gym evaluate``, ``oracles`` and the demonstrations. A *policy* here is a function from a
batch of observations (b, obs_dim) (or a dict of batches) to a batch of actions (b, n_cables): a
trained model behind its VecNormalize statistics (:class:`SB3Policy`, any algo) or a task's
oracle (``cdcr_gym.controllers``), so every policy runs on exactly the same episodes.

An episode is given by :class:`EpisodeSpecs`: a reset seed (``reset(seed=seed + i)``: the task
draws its own scene and starting shape; every evaluation uses these), or an explicit goal and
starting tensions put on the env with ``reset(options={"goal": ..., "initial_tensions": ...})``.
The numbers of the episodes are computed by :func:`training.run.metrics.summarize`.
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
from cdcr_gym.params import RobotParams

__all__ = [
    "parse_env_kwarg",
    "check_env_id",
    "cdcr_env_ids",
    "EpisodeSpecs",
    "Rollouts",
    "SB3Policy",
    "algo_class",
    "make_env",
    "run_episodes",
]

PolicyFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class EpisodeSpecs:
    """n evaluation episodes: goals (n, 3) m and starting tensions (n, n_cables) N put on the env
    with reset options, or (``goals`` None) reset seeds ``seed + i`` with which the task draws
    its own scene."""

    goals: np.ndarray | None
    initial_tensions: np.ndarray | None
    initial_state: str
    seed: int
    n: int = 0

    def __post_init__(self) -> None:
        if self.goals is not None:
            self.n = len(self.goals)

    def __len__(self) -> int:
        return self.n

    @classmethod
    def from_seeds(cls, n: int, seed: int) -> EpisodeSpecs:
        """``n`` episodes reset with seeds ``seed + i`` (the env's own initial state)."""
        return cls(None, None, "", seed, n)

    def reset_kwargs(self, i: int) -> dict[str, Any]:
        """The keyword arguments of ``env.reset`` for episode ``i``."""
        if self.goals is None or self.initial_tensions is None:
            return {"seed": self.seed + i}
        return {"options": {"goal": self.goals[i], "initial_tensions": self.initial_tensions[i]}}


@dataclass
class Rollouts:
    """What happened in n episodes of up to ``horizon`` steps (arrays float64, SI units).

    An episode that terminates (or is truncated before ``horizon``) keeps its last state: its
    ``distances`` stay at their last value."""

    distances: np.ndarray  # (n, horizon + 1) tip-to-goal distance after reset and each step, m
    final_tip: np.ndarray  # (n, 3) m
    final_tensions: np.ndarray  # (n, n_cables) N
    final_lengths: np.ndarray  # (n, n_cables) m
    returns: np.ndarray  # (n,) sum of rewards
    episode_length: np.ndarray  # (n,) steps actually taken
    goals: np.ndarray  # (n, 3) m (Track: the last target)
    final_infos: list[dict[str, Any]]  # the last ``info`` of each episode
    min_clearance: np.ndarray  # (n,) smallest ``info["min_clearance"]`` over the steps, m (inf)
    collided: np.ndarray  # (n,) bool: any step with ``info["collision"]``
    filtered_steps: np.ndarray  # (n,) steps with ``info["safety_filtered"]``
    #: the first ``record`` episodes: ``tip`` (steps + 1, 3) m and ``target`` (steps + 1, 3) m
    #: (the moving target of Track, else the goal), and for Obstacle ``obstacles``, ``goal``
    paths: list[dict[str, Any]]

    @property
    def final_distance(self) -> np.ndarray:
        """(n,) final tip error, m."""
        return self.distances[:, -1]


def robot_of(params: Any) -> Any:
    """The robot of an ``env.kwargs.params`` entry: a mapping of RobotParams fields, or the
    path of a YAML file (a ``cdcr-gym calibrate`` params.yaml), or None (the env's default)."""
    if isinstance(params, dict):
        return RobotParams(**params)
    if isinstance(params, str):
        return RobotParams.from_yaml(params)
    return params


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
    horizon: int | None = None,
    batch_size: int = 50,
    record: int = 0,
) -> Rollouts:
    """Run one episode per spec, ``horizon`` steps at most (None: the env's own episode length),
    ``batch_size`` envs in lockstep; keep the paths of the first ``record`` episodes.

    ``env_fn`` makes one env (its own TimeLimit must not be shorter than ``horizon``). An
    episode ends when it terminates (e.g. ``terminate_on_success``) or is truncated.
    """
    n = len(specs)
    envs = [env_fn() for _ in range(max(1, min(batch_size, n)))]
    if horizon is None:
        spec = envs[0].spec
        if spec is None or spec.max_episode_steps is None:
            for env in envs:
                env.close()
            raise ValueError("horizon: None needs an env with a TimeLimit (max_episode_steps)")
        horizon = int(spec.max_episode_steps)
    distances = np.empty((n, horizon + 1))
    returns = np.zeros(n)
    lengths = np.full(n, horizon)
    min_clearance = np.full(n, np.inf)
    collided = np.zeros(n, dtype=bool)
    filtered = np.zeros(n, dtype=int)
    final_infos: list[dict[str, Any]] = [{} for _ in range(n)]
    paths: list[dict[str, Any]] = []
    try:
        for start in range(0, n, len(envs)):
            idx = np.arange(start, min(start + len(envs), n))
            obs_list, infos = [], []
            for env, i in zip(envs, idx, strict=False):
                obs, info = env.reset(**specs.reset_kwargs(int(i)))
                obs_list.append(obs)
                infos.append(info)
            obs = _stack_obs(obs_list)
            alive = np.ones(len(idx), dtype=bool)
            tips = [[info["tip"]] for info in infos]
            targets = [[info.get("target", info.get("goal"))] for info in infos]
            distances[idx, 0] = [info["distance"] for info in infos]
            for t in range(1, horizon + 1):
                if not alive.any():
                    distances[idx, t] = distances[idx, t - 1]
                    continue
                actions = np.asarray(policy(obs))
                for k, (env, i) in enumerate(zip(envs, idx, strict=False)):
                    if alive[k]:
                        o, reward, terminated, truncated, info = env.step(actions[k])
                        _set_obs_row(obs, k, o)
                        infos[k] = info
                        returns[i] += reward
                        if "min_clearance" in info:
                            min_clearance[i] = min(min_clearance[i], info["min_clearance"])
                        collided[i] |= bool(info.get("collision", False))
                        filtered[i] += bool(info.get("safety_filtered", False))
                        if i < record:
                            tips[k].append(info["tip"])
                            targets[k].append(info.get("target", info.get("goal")))
                        if terminated or truncated:
                            alive[k] = False
                            lengths[i] = t
                    distances[i, t] = infos[k]["distance"]
            for k, i in enumerate(idx):
                final_infos[i] = infos[k]
                if i < record:
                    entry = {"tip": np.array(tips[k]), "target": np.array(targets[k])}
                    if "obstacles" in infos[k]:
                        entry["obstacles"] = infos[k]["obstacles"]
                        entry["goal"] = infos[k]["goal"]
                    paths.append(entry)
    finally:
        for env in envs:
            env.close()
    return Rollouts(
        distances=distances,
        final_tip=np.array([info["tip"] for info in final_infos]),
        final_tensions=np.array([info["tensions"] for info in final_infos]),
        final_lengths=np.array([info["cable_lengths"] for info in final_infos]),
        returns=returns,
        episode_length=lengths,
        goals=(
            specs.goals.copy()
            if specs.goals is not None
            else np.array([info.get("goal", info.get("target")) for info in final_infos])
        ),
        final_infos=final_infos,
        min_clearance=min_clearance,
        collided=collided,
        filtered_steps=filtered,
        paths=paths,
    )
