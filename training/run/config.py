"""Experiment configuration: one YAML file per experiment, parsed strictly into dataclasses.

A config file is a mapping with the sections below; every key has a default, so a file only
states what differs from it (``configs/ppo_ccka_reach.yaml`` states everything, as the reference).
Unknown or misspelt keys are an error that names the key (with its dotted path, and the closest
valid name), wrong types and out-of-range values are errors that name the key and the value.

.. code-block:: yaml

    name: ppo_ccka_reach          # run-directory prefix
    algo: ppo                     # ppo | sac | td3 (stable-baselines3) | tqc (sb3-contrib)
    seed: 0                       # in [0, 2**32 - 1]; seeds the algorithm, torch, numpy and the
                                  # training envs (seed + i); evaluation goals have their own seeds
    total_timesteps: 1000000      # environment steps (summed over all envs)
    env:
      id: cdcr_gym/CCKAReach-v0   # any registered id
      kwargs: {}                  # passed to gymnasium.make (env / task / backend arguments)
      per_env_kwargs: []          # cycled over the training envs, each updates kwargs, e.g.
                                  # [{initial_state: straight}, {initial_state: random}]
      max_episode_steps: null     # null: the registered value (100)
      n_envs: 8                   # parallel training envs
      vec_env: dummy              # dummy | subproc | batched (training/run/sb3_vec.py: CCKA, MuJoCo)
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
    sac:                          # only with algo: sac (a section of another algo is an error)
      learning_rate: 3.0e-4
      lr_schedule: constant
      buffer_size: 1000000        # transitions kept in the replay buffer
      learning_starts: 1000       # env steps of uniform random actions before updates start
      batch_size: 256
      tau: 0.005
      gamma: 0.98
      train_freq: 1               # env steps per env between updates (collection rounds)
      gradient_steps: 1           # gradient steps after each collection round
      ent_coef: null              # null: learned ("auto"); a number: fixed
      her:                        # HER's replay buffer (needs env.kwargs.goal_conditioned: true)
        enabled: false
        n_sampled_goal: 4
        goal_selection_strategy: future   # future | final | episode
      policy:
        net_arch: [256, 256]      # same layers for the actor and the critics
        activation: relu
    td3:                          # as sac, without ent_coef, plus:
      action_noise_std: 0.1       # Gaussian exploration noise, in units of the action range/2
      policy_delay: 2
      target_policy_noise: 0.2
      target_noise_clip: 0.5
    tqc:                          # as sac, plus:
      n_quantiles: 25
      n_critics: 2
      top_quantiles_to_drop_per_net: 2
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
      model: best                 # best (best_model/) | final (final_model/): evaluate's --model
    curriculum:                   # easier episodes early in training (tasks with one: Obstacle)
      steps: 0                    # env steps over which the difficulty rises to 1; 0: off
      start: 1.0                  # difficulty at step 0, in (0, 1] (Task.set_difficulty)
    demonstrations:               # PPO only: clone the task oracle before training
      episodes: 0                 # oracle episodes in the training envs; 0: off
      epochs: 20                  # passes over them (policy mean -> oracle action)
      batch_size: 1024
      learning_rate: 1.0e-3
      value: true                 # fit the critic to their discounted returns too
      oracle_kwargs: {}           # options of the oracle, e.g. {candidates: 4} (the planner)
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
import os
import re
import tempfile
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from cdcr_gym import MAX_EPISODE_STEPS

__all__ = [
    "ConfigError",
    "EnvConfig",
    "NormalizeConfig",
    "PolicyConfig",
    "PPOConfig",
    "HerConfig",
    "OffPolicyNetConfig",
    "SACConfig",
    "TD3Config",
    "TQCConfig",
    "ALGOS",
    "EVALUATE_MODELS",
    "EvalConfig",
    "CheckpointConfig",
    "EvaluateConfig",
    "RuntimeConfig",
    "CurriculumConfig",
    "DemonstrationsConfig",
    "ExperimentConfig",
    "load_config",
    "load_yaml",
    "config_from_dict",
    "config_to_dict",
    "save_config",
]

VEC_ENVS = ("dummy", "subproc", "batched")
LR_SCHEDULES = ("constant", "linear")
EVALUATE_MODELS = ("best", "final")
ACTIVATIONS = ("tanh", "relu", "elu")
BEST_METRICS = ("mean_error", "median_error", "success_rate", "mean_reward")
INITIAL_STATES = ("straight", "random")
ALGOS = ("ppo", "sac", "td3", "tqc")
OFF_POLICY = ("sac", "td3", "tqc")
GOAL_STRATEGIES = ("future", "final", "episode")
MAX_SEED = 2**32 - 1


class ConfigError(ValueError):
    """A config file that cannot be used; the message names the offending key."""


def check_writable_directory(path: Path, what: str) -> None:
    """Raise :class:`ConfigError` unless ``path`` is (or can be created as) a writable directory.

    Nothing is created: the nearest existing ancestor must be a directory this process may write
    into (a read-only mount, a path below a regular file, a permission error). An existing
    directory is also probed with a temporary file, since ``os.access`` may pass for root.
    ``what`` names the argument in the message, e.g. ``"--run-dir"``.
    """

    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise ConfigError(
            f"{what} {str(path)!r} is a dangling symbolic link (to {os.readlink(path)!r}); "
            f"remove it or choose another directory"
        )
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise ConfigError(f"{what} {str(path)!r}: {str(probe)!r} is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ConfigError(f"{what} {str(path)!r}: {str(probe)!r} is not writable")
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise ConfigError(
            f"{what} {str(path)!r}: cannot write into {str(probe)!r}: {exc.strerror}"
        ) from None


@dataclass
class EnvConfig:
    """The environment: a registered id, its kwargs, and how many copies train in parallel."""

    id: str = "cdcr_gym/CCKAReach-v0"
    kwargs: dict[str, Any] = field(default_factory=dict)
    per_env_kwargs: list[dict[str, Any]] = field(default_factory=list)
    max_episode_steps: int | None = None
    n_envs: int = 8
    vec_env: str = "dummy"

    @property
    def max_episode_steps_or_default(self) -> int:
        """``max_episode_steps``, or cdcr_gym's registered episode length
        (``cdcr_gym.MAX_EPISODE_STEPS``, 100) when it is None."""

        return self.max_episode_steps or MAX_EPISODE_STEPS


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
class HerConfig:
    """Hindsight experience replay (``stable_baselines3.HerReplayBuffer``) for off-policy algos."""

    enabled: bool = False
    n_sampled_goal: int = 4
    goal_selection_strategy: str = "future"


@dataclass
class OffPolicyNetConfig:
    """The actor and critic MLPs of SAC/TD3/TQC (``policy_kwargs``)."""

    net_arch: list[int] = field(default_factory=lambda: [256, 256])
    activation: str = "relu"


@dataclass
class OffPolicyConfig:
    """Hyperparameters shared by the off-policy algorithms (stable-baselines3 names)."""

    learning_rate: float = 3.0e-4
    lr_schedule: str = "constant"
    buffer_size: int = 1_000_000
    learning_starts: int = 1000
    batch_size: int = 256
    tau: float = 0.005
    gamma: float = 0.98
    train_freq: int = 1
    gradient_steps: int = 1
    her: HerConfig = field(default_factory=HerConfig)
    policy: OffPolicyNetConfig = field(default_factory=OffPolicyNetConfig)


@dataclass
class SACConfig(OffPolicyConfig):
    """stable-baselines3 SAC."""

    ent_coef: float | None = None


@dataclass
class TD3Config(OffPolicyConfig):
    """stable-baselines3 TD3 (Gaussian action noise of std ``action_noise_std``)."""

    learning_rate: float = 1.0e-3
    action_noise_std: float = 0.1
    policy_delay: int = 2
    target_policy_noise: float = 0.2
    target_noise_clip: float = 0.5


@dataclass
class TQCConfig(OffPolicyConfig):
    """sb3-contrib TQC (truncated quantile critics)."""

    ent_coef: float | None = None
    n_quantiles: int = 25
    n_critics: int = 2
    top_quantiles_to_drop_per_net: int = 2


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
    #: which saved model ``evaluate`` loads by default: "best" (``best_model/``, chosen by the
    #: periodic evaluation) or "final" (``final_model/``, the last step)
    model: str = "best"


@dataclass
class RuntimeConfig:
    """Where and how torch runs."""

    device: str = "cpu"
    torch_threads: int = 1
    max_wall_time_s: float | None = None


@dataclass
class CurriculumConfig:
    """A training curriculum: the task's difficulty rises linearly from ``start`` at step 0 to 1
    at ``steps`` env steps (then stays 1), set before every rollout (``Task.set_difficulty``);
    evaluations always run the task as configured. ``steps`` 0: off."""

    steps: int = 0
    start: float = 1.0

    def difficulty(self, timesteps: int) -> float:
        """The difficulty at ``timesteps`` env steps."""
        if self.steps <= 0:
            return 1.0
        return self.start + (1.0 - self.start) * min(1.0, timesteps / self.steps)


@dataclass
class DemonstrationsConfig:
    """Behaviour cloning of the task's oracle before PPO trains (training/run/demonstrations.py):
    ``episodes`` oracle episodes in the training envs (0: off), then ``epochs`` passes in
    minibatches of ``batch_size`` at ``learning_rate``; ``value``: fit the critic too;
    ``oracle_kwargs``: options of the oracle (e.g. ``{candidates: 4}`` for the planner)."""

    episodes: int = 0
    epochs: int = 20
    batch_size: int = 1024
    learning_rate: float = 1.0e-3
    value: bool = True
    oracle_kwargs: dict[str, Any] = field(default_factory=dict)


@dataclass
class ExperimentConfig:
    """One experiment: everything ``python -m training.run.train`` needs."""

    name: str = "experiment"
    algo: str = "ppo"
    seed: int = 0
    total_timesteps: int = 1_000_000
    env: EnvConfig = field(default_factory=EnvConfig)
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    sac: SACConfig = field(default_factory=SACConfig)
    td3: TD3Config = field(default_factory=TD3Config)
    tqc: TQCConfig = field(default_factory=TQCConfig)
    eval: EvalConfig = field(default_factory=EvalConfig)
    checkpoint: CheckpointConfig = field(default_factory=CheckpointConfig)
    evaluate: EvaluateConfig = field(default_factory=EvaluateConfig)
    runtime: RuntimeConfig = field(default_factory=RuntimeConfig)
    curriculum: CurriculumConfig = field(default_factory=CurriculumConfig)
    demonstrations: DemonstrationsConfig = field(default_factory=DemonstrationsConfig)

    def validate(self) -> ExperimentConfig:
        """Check values (types are checked on parsing); raise :class:`ConfigError` naming the key."""
        _positive_int("total_timesteps", self.total_timesteps)
        _choice("algo", self.algo, ALGOS)
        if (
            isinstance(self.seed, bool)
            or not isinstance(self.seed, int)
            or not 0 <= self.seed <= MAX_SEED
        ):
            raise ConfigError(
                f"seed must be an integer in [0, 2**32 - 1 = {MAX_SEED}] (numpy's seed range), "
                f"got {self.seed!r}"
            )
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
        goal_conditioned = bool(e.kwargs.get("goal_conditioned"))
        if any(kw.get("goal_conditioned") for kw in e.per_env_kwargs):
            raise ConfigError(
                "env.per_env_kwargs[].goal_conditioned: set it for all envs in env.kwargs"
            )
        if goal_conditioned and self.algo not in OFF_POLICY:
            raise ConfigError(
                f"env.kwargs.goal_conditioned: the Dict (goal-conditioned) observation is for the "
                f"off-policy algos {list(OFF_POLICY)} (with her.enabled), not algo: {self.algo}"
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
        if self.algo == "ppo":
            self._validate_ppo()
        else:
            self._validate_off_policy(goal_conditioned)
        self._validate_rest()
        return self

    @property
    def algo_config(self) -> PPOConfig | SACConfig | TD3Config | TQCConfig:
        """The section of the selected algorithm (``self.ppo``, ``self.sac``, ...)."""
        section: PPOConfig | SACConfig | TD3Config | TQCConfig = getattr(self, self.algo)
        return section

    def _validate_off_policy(self, goal_conditioned: bool) -> None:
        a = self.algo
        c = typing.cast(OffPolicyConfig, self.algo_config)
        _positive_float(f"{a}.learning_rate", c.learning_rate)
        _choice(f"{a}.lr_schedule", c.lr_schedule, LR_SCHEDULES)
        _positive_int(f"{a}.buffer_size", c.buffer_size)
        if isinstance(c.learning_starts, bool) or c.learning_starts < 0:
            raise ConfigError(f"{a}.learning_starts must be >= 0, got {c.learning_starts!r}")
        _positive_int(f"{a}.batch_size", c.batch_size)
        if not 0.0 < c.tau <= 1.0:
            raise ConfigError(f"{a}.tau must be in (0, 1], got {c.tau!r}")
        if not 0.0 < c.gamma <= 1.0:
            raise ConfigError(f"{a}.gamma must be in (0, 1], got {c.gamma!r}")
        _positive_int(f"{a}.train_freq", c.train_freq)
        _positive_int(f"{a}.gradient_steps", c.gradient_steps)
        _net_arch(f"{a}.policy.net_arch", c.policy.net_arch)
        _choice(f"{a}.policy.activation", c.policy.activation, ACTIVATIONS)
        h = c.her
        _positive_int(f"{a}.her.n_sampled_goal", h.n_sampled_goal)
        _choice(f"{a}.her.goal_selection_strategy", h.goal_selection_strategy, GOAL_STRATEGIES)
        if h.enabled and not goal_conditioned:
            raise ConfigError(
                f"{a}.her.enabled: HER needs the goal-conditioned observation; "
                f"set env.kwargs.goal_conditioned: true"
            )
        horizon = self.env.max_episode_steps_or_default
        if h.enabled and c.learning_starts < horizon * self.env.n_envs:
            raise ConfigError(
                f"{a}.learning_starts ({c.learning_starts}) must be >= env.max_episode_steps * "
                f"env.n_envs ({horizon} * {self.env.n_envs}) with HER: it samples finished "
                f"episodes only"
            )
        if h.enabled and c.buffer_size < self.env.max_episode_steps_or_default:
            raise ConfigError(
                f"{a}.buffer_size ({c.buffer_size}) must hold at least one episode "
                f"({self.env.max_episode_steps_or_default} steps) with HER"
            )
        if isinstance(c, (SACConfig, TQCConfig)) and c.ent_coef is not None:
            _positive_float(f"{a}.ent_coef", c.ent_coef)
        if isinstance(c, TD3Config):
            if not math.isfinite(c.action_noise_std) or c.action_noise_std < 0:
                raise ConfigError(
                    f"td3.action_noise_std must be finite and >= 0, got {c.action_noise_std!r}"
                )
            _positive_int("td3.policy_delay", c.policy_delay)
            for key in ("target_policy_noise", "target_noise_clip"):
                value = getattr(c, key)
                if not math.isfinite(value) or value < 0:
                    raise ConfigError(f"td3.{key} must be finite and >= 0, got {value!r}")
        if isinstance(c, TQCConfig):
            _positive_int("tqc.n_quantiles", c.n_quantiles)
            _positive_int("tqc.n_critics", c.n_critics)
            drop = c.top_quantiles_to_drop_per_net
            if isinstance(drop, bool) or not 0 <= drop < c.n_quantiles:
                raise ConfigError(
                    f"tqc.top_quantiles_to_drop_per_net must be in [0, tqc.n_quantiles), "
                    f"got {drop!r}"
                )

    def _validate_ppo(self) -> None:
        e = self.env
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
        _net_arch("ppo.policy.net_arch", p.policy.net_arch)
        _choice("ppo.policy.activation", p.policy.activation, ACTIVATIONS)
        if not math.isfinite(p.policy.log_std_init):
            raise ConfigError(
                f"ppo.policy.log_std_init must be finite, got {p.policy.log_std_init}"
            )

    def _validate_rest(self) -> None:
        c = self.curriculum
        if isinstance(c.steps, bool) or c.steps < 0:
            raise ConfigError(f"curriculum.steps must be an integer >= 0, got {c.steps!r}")
        if not 0.0 < c.start <= 1.0:
            raise ConfigError(f"curriculum.start must be in (0, 1], got {c.start!r}")
        d = self.demonstrations
        if isinstance(d.episodes, bool) or d.episodes < 0:
            raise ConfigError(
                f"demonstrations.episodes must be an integer >= 0, got {d.episodes!r}"
            )
        if d.episodes and self.algo != "ppo":
            raise ConfigError(
                f"demonstrations.episodes: behaviour cloning is for PPO only, got algo {self.algo!r}"
            )
        _positive_int("demonstrations.epochs", d.epochs)
        _positive_int("demonstrations.batch_size", d.batch_size)
        _positive_float("demonstrations.learning_rate", d.learning_rate)
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
        _choice("evaluate.model", v.model, EVALUATE_MODELS)
        if self.runtime.device not in ("cpu", "auto") and not re.fullmatch(
            r"cuda(:\d+)?", str(self.runtime.device)
        ):
            raise ConfigError(
                f"runtime.device must be 'cpu', 'cuda', 'cuda:N' or 'auto', "
                f"got {self.runtime.device!r}"
            )
        _positive_int("runtime.torch_threads", self.runtime.torch_threads)
        if self.runtime.max_wall_time_s is not None:
            _positive_float("runtime.max_wall_time_s", self.runtime.max_wall_time_s)


def _net_arch(key: str, widths: Any) -> None:
    if not widths or not all(
        isinstance(w, int) and not isinstance(w, bool) and w > 0 for w in widths
    ):
        raise ConfigError(
            f"{key} must be a non-empty list of positive layer widths, got {widths!r}"
        )


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
    """An :class:`ExperimentConfig` from a parsed YAML mapping; strict (see module docstring).

    Only the section of the selected ``algo`` may be given (``sac:`` with ``algo: ppo`` is an
    error naming the section)."""
    config = _build(ExperimentConfig, data)
    if isinstance(data, dict) and config.algo in ALGOS:
        for other in ALGOS:
            if other != config.algo and other in data:
                raise ConfigError(
                    f"config section '{other}' is for algo: {other}, but algo is "
                    f"{config.algo!r}; remove the section or set algo: {other}"
                )
    return config.validate()


class _StrictLoader(yaml.SafeLoader):
    """A YAML SafeLoader that rejects duplicate keys in a mapping (PyYAML keeps the last)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)  # type: ignore[no-untyped-call]
            line = key_node.start_mark.line + 1
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: let PyYAML report it
                break
            if first is not None:
                raise ConfigError(
                    f"duplicate key {key!r} on line {line} (first given on line {first}); "
                    f"YAML would silently keep the last value"
                )
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


def load_yaml(path: str | Path) -> Any:
    """Parse a YAML file strictly: UTF-8, no duplicate keys. Raises :class:`ConfigError`."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"config file {str(path)!r} is a directory, not a YAML file")
    if not path.is_file():
        raise ConfigError(f"config file {str(path)!r} does not exist")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"config file {str(path)!r} is not UTF-8 text (byte {exc.start}: "
            f"{exc.object[exc.start : exc.start + 1]!r})"
        ) from None
    except OSError as exc:
        raise ConfigError(f"config file {str(path)!r} cannot be read: {exc.strerror}") from None
    try:
        return yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - a SafeLoader subclass
    except ConfigError as exc:
        raise ConfigError(f"config file {str(path)!r}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file {str(path)!r} is not valid YAML: {exc}") from None


def load_config(path: str | Path) -> ExperimentConfig:
    """Read and validate a YAML config file. Raises :class:`ConfigError` naming the bad key."""
    data = load_yaml(path)
    if data is None:  # a 0-byte file, or only comments: not "every default" (a 1 M-step run)
        raise ConfigError(
            f"config file {str(path)!r} is empty (no keys, only comments or nothing): a config "
            f"states its experiment, e.g. start from configs/ppo_ccka_reach.yaml (or write {{}} "
            f"for every default)"
        )
    try:
        return config_from_dict(data)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def config_to_dict(config: ExperimentConfig) -> dict[str, Any]:
    """The resolved config as plain data (every key, defaults filled in; only the selected
    algorithm's section)."""
    data = dataclasses.asdict(config)
    for other in ALGOS:
        if other != config.algo:
            data.pop(other, None)
    return data


def save_config(config: ExperimentConfig, path: str | Path) -> None:
    """Write the resolved config as YAML (loadable by :func:`load_config`)."""
    Path(path).write_text(yaml.safe_dump(config_to_dict(config), sort_keys=False))
