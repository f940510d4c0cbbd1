"""Experiment configuration: one YAML file per experiment, parsed strictly into dataclasses.

A config file is a mapping with the sections below; every key has a default, so a file only
states what differs from it (``configs/ppo_ccka_reach.yaml`` states everything, as the reference).
Unknown or misspelt keys are an error that names the key (with its dotted path, and the closest
valid name), wrong types and out-of-range values are errors that name the key and the value.

.. code-block:: yaml

    name: ppo_ccka_reach          # run-directory prefix
    seed: 0                       # seeds PPO, torch, the training envs and the evaluation envs
    total_timesteps: 1000000      # environment steps (summed over all envs)
    env:
      id: cdcr_gym/CCKAReach-v0   # any registered id
      kwargs: {}                  # passed to gymnasium.make (ReachEnv / backend arguments)
      per_env_kwargs: []          # cycled over the training envs, each updates kwargs, e.g.
                                  # [{initial_state: straight}, {initial_state: random}]
      max_episode_steps: null     # null: the registered value (100)
      n_envs: 8                   # parallel training envs
      vec_env: dummy              # dummy | subproc | batched (training/sb3_vec.py, CCKA only)
    normalize:                    # stable-baselines3 VecNormalize
      enabled: true
      norm_obs: true
      norm_reward: true
      clip_obs: 10.0
      clip_reward: 10.0
    ppo:                          # stable-baselines3 PPO
      learning_rate: 3.0e-4
      lr_schedule: linear         # constant | linear (decays linearly to 0 at total_timesteps)
      n_steps: 512                # per env, per rollout
      batch_size: 256
      n_epochs: 10
      gamma: 0.98
      gae_lambda: 0.95
      clip_range: 0.2
      ent_coef: 0.0
      vf_coef: 0.5
      max_grad_norm: 0.5
      target_kl: null
      policy:
        net_arch: [256, 256]      # same layers for policy and value networks
        activation: tanh          # tanh | relu | elu
        log_std_init: -1.0
        ortho_init: true
    eval:                         # periodic evaluation during training (best-model selection)
      freq: 25000                 # environment steps between evaluations
      n_episodes: 50
      seed: 100000                # fixed goals: episode i resets with seed + i
      initial_states: [straight, random]  # n_episodes from each starting state
      best_metric: mean_error     # mean_error | median_error | success_rate | mean_reward
    checkpoint:
      freq: 50000                 # environment steps between checkpoints
    evaluate:                     # defaults of ``python -m training.evaluate``
      episodes: 200
      seed: 1000000
      initial_states: [straight, random]
      horizons: [100, 200]        # episode lengths; the first is the headline condition
      video_episodes: 3
    runtime:
      device: cpu
      torch_threads: 1            # torch.set_num_threads (tiny MLPs are fastest single-threaded)
      max_wall_time_s: null       # stop training after this many seconds of training wall time
                                  # (periodic evaluations included); null: run to total_timesteps
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

__all__ = [
    "ConfigError",
    "EnvConfig",
    "NormalizeConfig",
    "PolicyConfig",
    "PPOConfig",
    "EvalConfig",
    "CheckpointConfig",
    "EvaluateConfig",
    "RuntimeConfig",
    "ExperimentConfig",
    "load_config",
    "config_from_dict",
    "config_to_dict",
    "save_config",
]

VEC_ENVS = ("dummy", "subproc", "batched")
LR_SCHEDULES = ("constant", "linear")
ACTIVATIONS = ("tanh", "relu", "elu")
BEST_METRICS = ("mean_error", "median_error", "success_rate", "mean_reward")
INITIAL_STATES = ("straight", "random")


class ConfigError(ValueError):
    """A config file that cannot be used; the message names the offending key."""


@dataclass
class EnvConfig:
    """The environment: a registered id, its kwargs, and how many copies train in parallel."""

    id: str = "cdcr_gym/CCKAReach-v0"
    kwargs: dict[str, Any] = field(default_factory=dict)
    per_env_kwargs: list[dict[str, Any]] = field(default_factory=list)
    max_episode_steps: int | None = None
    n_envs: int = 8
    vec_env: str = "dummy"


@dataclass
class NormalizeConfig:
    """stable-baselines3 ``VecNormalize`` (running mean/std of observations and returns)."""

    enabled: bool = True
    norm_obs: bool = True
    norm_reward: bool = True
    clip_obs: float = 10.0
    clip_reward: float = 10.0


@dataclass
class PolicyConfig:
    """The actor-critic MLP (``policy_kwargs`` of PPO)."""

    net_arch: list[int] = field(default_factory=lambda: [256, 256])
    activation: str = "tanh"
    log_std_init: float = -1.0
    ortho_init: bool = True


@dataclass
class PPOConfig:
    """stable-baselines3 PPO hyperparameters (same names and meanings)."""

    learning_rate: float = 3.0e-4
    lr_schedule: str = "linear"
    n_steps: int = 512
    batch_size: int = 256
    n_epochs: int = 10
    gamma: float = 0.98
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = None
    policy: PolicyConfig = field(default_factory=PolicyConfig)


@dataclass
class EvalConfig:
    """Periodic evaluation during training; the best model is kept by ``best_metric``."""

    freq: int = 25_000
    n_episodes: int = 50
    seed: int = 100_000
    initial_states: list[str] = field(default_factory=lambda: ["straight", "random"])
    best_metric: str = "mean_error"


@dataclass
class CheckpointConfig:
    """Periodic checkpoints (model + VecNormalize statistics), for ``--resume``."""

    freq: int = 50_000


@dataclass
class EvaluateConfig:
    """Defaults of ``python -m training.evaluate`` for runs of this config."""

    episodes: int = 200
    seed: int = 1_000_000
    initial_states: list[str] = field(default_factory=lambda: ["straight", "random"])
    horizons: list[int] = field(default_factory=lambda: [100, 200])
    video_episodes: int = 3


@dataclass
class RuntimeConfig:
    """Where and how torch runs."""

    device: str = "cpu"
    torch_threads: int = 1
    max_wall_time_s: float | None = None


@dataclass
class ExperimentConfig:
    """One experiment: everything ``python -m training.train`` needs."""

    name: str = "experiment"
    seed: int = 0
    total_timesteps: int = 1_000_000
    env: EnvConfig = field(default_factory=EnvConfig)
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    eval: EvalConfig = field(default_factory=EvalConfig)
    checkpoint: CheckpointConfig = field(default_factory=CheckpointConfig)
    evaluate: EvaluateConfig = field(default_factory=EvaluateConfig)
    runtime: RuntimeConfig = field(default_factory=RuntimeConfig)

    def validate(self) -> ExperimentConfig:
        """Check values (types are checked on parsing); raise :class:`ConfigError` naming the key."""
        _positive_int("total_timesteps", self.total_timesteps)
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError(f"seed must be an integer >= 0, got {self.seed!r}")
        if not self.name or "/" in self.name:
            raise ConfigError(f"name must be a non-empty string without '/', got {self.name!r}")
        e = self.env
        if not e.id:
            raise ConfigError("env.id must be a registered environment id, got an empty string")
        if e.max_episode_steps is not None:
            _positive_int("env.max_episode_steps", e.max_episode_steps)
        _positive_int("env.n_envs", e.n_envs)
        _choice("env.vec_env", e.vec_env, VEC_ENVS)
        if not all(isinstance(k, str) for k in e.kwargs):
            raise ConfigError(f"env.kwargs keys must be strings, got {list(e.kwargs)!r}")
        for i, extra in enumerate(e.per_env_kwargs):
            if not all(isinstance(k, str) for k in extra):
                raise ConfigError(f"env.per_env_kwargs[{i}] keys must be strings, got {extra!r}")
        if any(kw.get("goal_conditioned") for kw in (e.kwargs, *e.per_env_kwargs)):
            raise ConfigError(
                "env.kwargs.goal_conditioned: the Dict (HER) observation is not supported by "
                "training.train (PPO with an MLP on the flat observation); remove the key"
            )
        for key in ("max_episode_steps", "render_mode"):
            if any(key in kw for kw in (e.kwargs, *e.per_env_kwargs)):
                hint = (
                    "env.max_episode_steps" if key == "max_episode_steps" else "(set by evaluate)"
                )
                raise ConfigError(f"env.kwargs.{key} is not allowed here; use {hint}")
        n = self.normalize
        _positive_float("normalize.clip_obs", n.clip_obs)
        _positive_float("normalize.clip_reward", n.clip_reward)
        p = self.ppo
        _positive_float("ppo.learning_rate", p.learning_rate)
        _choice("ppo.lr_schedule", p.lr_schedule, LR_SCHEDULES)
        _positive_int("ppo.n_steps", p.n_steps)
        _positive_int("ppo.batch_size", p.batch_size)
        _positive_int("ppo.n_epochs", p.n_epochs)
        rollout = p.n_steps * e.n_envs
        if p.batch_size > rollout:
            raise ConfigError(
                f"ppo.batch_size ({p.batch_size}) must be <= ppo.n_steps * env.n_envs ({rollout})"
            )
        if rollout == 1:
            raise ConfigError("ppo.n_steps * env.n_envs must be > 1 (advantage normalisation)")
        for key in ("gamma", "gae_lambda"):
            value = getattr(p, key)
            if not 0.0 < value <= 1.0:
                raise ConfigError(f"ppo.{key} must be in (0, 1], got {value!r}")
        _positive_float("ppo.clip_range", p.clip_range)
        for key in ("ent_coef", "vf_coef"):
            if not math.isfinite(getattr(p, key)) or getattr(p, key) < 0:
                raise ConfigError(f"ppo.{key} must be finite and >= 0, got {getattr(p, key)!r}")
        _positive_float("ppo.max_grad_norm", p.max_grad_norm)
        if p.target_kl is not None:
            _positive_float("ppo.target_kl", p.target_kl)
        if not p.policy.net_arch or not all(
            isinstance(w, int) and not isinstance(w, bool) and w > 0 for w in p.policy.net_arch
        ):
            raise ConfigError(
                f"ppo.policy.net_arch must be a non-empty list of positive layer widths, "
                f"got {p.policy.net_arch!r}"
            )
        _choice("ppo.policy.activation", p.policy.activation, ACTIVATIONS)
        if not math.isfinite(p.policy.log_std_init):
            raise ConfigError(
                f"ppo.policy.log_std_init must be finite, got {p.policy.log_std_init}"
            )
        _positive_int("eval.freq", self.eval.freq)
        _positive_int("eval.n_episodes", self.eval.n_episodes)
        if self.eval.seed < 0:
            raise ConfigError(f"eval.seed must be >= 0, got {self.eval.seed!r}")
        _choice("eval.best_metric", self.eval.best_metric, BEST_METRICS)
        if not self.eval.initial_states:
            raise ConfigError("eval.initial_states must list at least one starting state")
        for s in self.eval.initial_states:
            _choice("eval.initial_states[]", s, INITIAL_STATES)
        _positive_int("checkpoint.freq", self.checkpoint.freq)
        v = self.evaluate
        _positive_int("evaluate.episodes", v.episodes)
        if v.seed < 0:
            raise ConfigError(f"evaluate.seed must be >= 0, got {v.seed!r}")
        if not v.initial_states:
            raise ConfigError("evaluate.initial_states must list at least one starting state")
        for s in v.initial_states:
            _choice("evaluate.initial_states[]", s, INITIAL_STATES)
        if not v.horizons:
            raise ConfigError("evaluate.horizons must list at least one episode length")
        for h in v.horizons:
            _positive_int("evaluate.horizons[]", h)
        if v.video_episodes < 0:
            raise ConfigError(f"evaluate.video_episodes must be >= 0, got {v.video_episodes!r}")
        if self.runtime.device not in ("cpu", "cuda", "auto") and not str(
            self.runtime.device
        ).startswith("cuda:"):
            raise ConfigError(
                f"runtime.device must be 'cpu', 'cuda', 'cuda:N' or 'auto', "
                f"got {self.runtime.device!r}"
            )
        _positive_int("runtime.torch_threads", self.runtime.torch_threads)
        if self.runtime.max_wall_time_s is not None:
            _positive_float("runtime.max_wall_time_s", self.runtime.max_wall_time_s)
        return self


def _positive_int(key: str, value: Any) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ConfigError(f"{key} must be a positive integer, got {value!r}")


def _positive_float(key: str, value: Any) -> None:
    if not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{key} must be finite and > 0, got {value!r}")


def _choice(key: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ConfigError(f"{key} must be one of {list(choices)}, got {value!r}")


# -- parsing ------------------------------------------------------------------------------------
def _coerce(key: str, value: Any, annotation: Any) -> Any:
    """``value`` checked against (and lightly coerced to) the type ``annotation``."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return _coerce(key, value, inner)
    if dataclasses.is_dataclass(annotation):
        return _build(annotation, value, key)
    if annotation is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {value!r}")
        return value
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            # YAML reads 1e6 as a string and 1.0e6 as a float; accept integral floats.
            if isinstance(value, float) and value.is_integer():
                return int(value)
            raise ConfigError(f"{key} must be an integer, got {value!r}")
        return value
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            try:
                return float(value)  # YAML 1.1 reads "3e-4" (no dot) as a string
            except (TypeError, ValueError):
                raise ConfigError(f"{key} must be a number, got {value!r}") from None
        return float(value)
    if annotation is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {value!r}")
        return value
    if origin is list:
        if not isinstance(value, list):
            raise ConfigError(f"{key} must be a list, got {value!r}")
        return [_coerce(f"{key}[{i}]", v, args[0]) for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a mapping, got {value!r}")
        return dict(value)
    raise TypeError(f"unsupported config annotation {annotation!r} for {key}")  # pragma: no cover


def _build(cls: type, data: Any, prefix: str = "") -> Any:
    where = prefix or "the config file"
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where} must be a mapping of keys to values, got {data!r}")
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = [k for k in data if k not in names]
    if unknown:
        key = unknown[0]
        dotted = f"{prefix}.{key}" if prefix else str(key)
        close = difflib.get_close_matches(str(key), names, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        valid = ", ".join(names)
        raise ConfigError(f"unknown config key '{dotted}'{hint} (valid keys here: {valid})")
    kwargs = {}
    for name in names:
        if name in data:
            dotted = f"{prefix}.{name}" if prefix else name
            kwargs[name] = _coerce(dotted, data[name], hints[name])
    return cls(**kwargs)


def config_from_dict(data: dict[str, Any]) -> ExperimentConfig:
    """An :class:`ExperimentConfig` from a parsed YAML mapping; strict (see module docstring)."""
    return _build(ExperimentConfig, data).validate()


def load_config(path: str | Path) -> ExperimentConfig:
    """Read and validate a YAML config file. Raises :class:`ConfigError` naming the bad key."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file {str(path)!r} does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file {str(path)!r} is not valid YAML: {exc}") from None
    try:
        return config_from_dict(data if data is not None else {})
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def config_to_dict(config: ExperimentConfig) -> dict[str, Any]:
    """The resolved config as plain data (every key, defaults filled in)."""
    return dataclasses.asdict(config)


def save_config(config: ExperimentConfig, path: str | Path) -> None:
    """Write the resolved config as YAML (loadable by :func:`load_config`)."""
    Path(path).write_text(yaml.safe_dump(config_to_dict(config), sort_keys=False))
