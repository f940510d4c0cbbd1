"""Constructor arguments of PPO, SAC, TD3 and TQC from a config, and the VecNormalize wrapper."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from training.run.config import (
    ConfigError,
    ExperimentConfig,
    OffPolicyConfig,
    SACConfig,
    TD3Config,
    TQCConfig,
)
from training.run.rollout import algo_class

# -- algorithms ---------------------------------------------------------------------------------
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU"}


def ppo_kwargs(config: ExperimentConfig) -> dict[str, Any]:
    import torch
    from stable_baselines3.common.utils import LinearSchedule

    p = config.ppo
    lr: Any = p.learning_rate
    if p.lr_schedule == "linear":
        lr = LinearSchedule(p.learning_rate, 0.0, 1.0)
    return {
        "learning_rate": lr,
        "n_steps": p.n_steps,
        "batch_size": p.batch_size,
        "n_epochs": p.n_epochs,
        "gamma": p.gamma,
        "gae_lambda": p.gae_lambda,
        "clip_range": p.clip_range,
        "ent_coef": p.ent_coef,
        "vf_coef": p.vf_coef,
        "max_grad_norm": p.max_grad_norm,
        "target_kl": p.target_kl,
        "policy_kwargs": {
            "net_arch": {"pi": list(p.policy.net_arch), "vf": list(p.policy.net_arch)},
            "activation_fn": getattr(torch.nn, ACTIVATIONS[p.policy.activation]),
            "log_std_init": p.policy.log_std_init,
            "ortho_init": p.policy.ortho_init,
        },
    }


def off_policy_kwargs(config: ExperimentConfig, action_dim: int) -> dict[str, Any]:
    """SAC/TD3/TQC constructor arguments from the config's section of ``config.algo``."""
    import torch
    from stable_baselines3 import HerReplayBuffer
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.utils import LinearSchedule

    c = config.algo_config
    if not isinstance(c, OffPolicyConfig):  # pragma: no cover - validate() guarantees it
        raise ConfigError(f"algo: {config.algo} is not an off-policy algorithm")
    lr: Any = c.learning_rate
    if c.lr_schedule == "linear":
        lr = LinearSchedule(c.learning_rate, 0.0, 1.0)
    policy_kwargs: dict[str, Any] = {
        "net_arch": list(c.policy.net_arch),
        "activation_fn": getattr(torch.nn, ACTIVATIONS[c.policy.activation]),
    }
    kwargs: dict[str, Any] = {
        "learning_rate": lr,
        "buffer_size": c.buffer_size,
        "learning_starts": c.learning_starts,
        "batch_size": c.batch_size,
        "tau": c.tau,
        "gamma": c.gamma,
        "train_freq": c.train_freq,
        "gradient_steps": c.gradient_steps,
        "policy_kwargs": policy_kwargs,
    }
    if c.her.enabled:
        kwargs["replay_buffer_class"] = HerReplayBuffer
        kwargs["replay_buffer_kwargs"] = {
            "n_sampled_goal": c.her.n_sampled_goal,
            "goal_selection_strategy": c.her.goal_selection_strategy,
        }
    if isinstance(c, (SACConfig, TQCConfig)):
        kwargs["ent_coef"] = "auto" if c.ent_coef is None else c.ent_coef
    if isinstance(c, TD3Config):
        kwargs["action_noise"] = NormalActionNoise(
            np.zeros(action_dim), np.full(action_dim, c.action_noise_std)
        )
        kwargs["policy_delay"] = c.policy_delay
        kwargs["target_policy_noise"] = c.target_policy_noise
        kwargs["target_noise_clip"] = c.target_noise_clip
    if isinstance(c, TQCConfig):
        kwargs["top_quantiles_to_drop_per_net"] = c.top_quantiles_to_drop_per_net
        policy_kwargs["n_quantiles"] = c.n_quantiles
        policy_kwargs["n_critics"] = c.n_critics
    return kwargs


def make_model(config: ExperimentConfig, venv: Any, device: str) -> Any:
    """A new model of ``config.algo`` on ``venv`` (seeded with ``config.seed``)."""

    cls = algo_class(config.algo)
    goal_conditioned = bool(config.env.kwargs.get("goal_conditioned"))
    policy = "MultiInputPolicy" if goal_conditioned else "MlpPolicy"
    if config.algo == "ppo":
        kwargs = ppo_kwargs(config)
    else:
        kwargs = off_policy_kwargs(config, int(np.prod(venv.action_space.shape)))
    return cls(policy, venv, seed=config.seed, device=device, verbose=0, **kwargs)


def _gamma(config: ExperimentConfig) -> float:
    return float(config.algo_config.gamma)


def wrap_normalize(config: ExperimentConfig, venv: Any, stats_path: Path | None) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    n = config.normalize
    if not n.enabled:
        return venv
    if stats_path is not None and stats_path.stat().st_size > 0:
        venv = VecNormalize.load(str(stats_path), venv)
        venv.training = True
        return venv
    return VecNormalize(
        venv,
        norm_obs=n.norm_obs,
        norm_reward=n.norm_reward,
        clip_obs=n.clip_obs,
        clip_reward=n.clip_reward,
        gamma=_gamma(config),
    )
