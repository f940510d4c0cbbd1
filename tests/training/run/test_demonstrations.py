"""Behaviour cloning of the task oracle before PPO (training/run/demonstrations.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from training.run.config import ConfigError, config_from_dict
from training.run.demonstrations import (
    Demonstrations,
    clone_demonstrations,
    collect_demonstrations,
)

REPO = Path(__file__).resolve().parents[3]


def _demos(rewards: list[float], ends: list[bool]) -> Demonstrations:
    n = len(rewards)
    return Demonstrations(
        obs=np.zeros((n, 1)),
        actions=np.zeros((n, 1)),
        rewards=np.array(rewards),
        episode_end=np.array(ends),
        successes=np.zeros(sum(ends), dtype=bool),
    )


def test_returns_discount_to_the_end_of_each_episode_only() -> None:
    d = _demos([1.0, 2.0, 3.0, 10.0, 20.0], [False, False, True, False, True])
    r = d.returns(0.5)
    np.testing.assert_allclose(r, [1 + 0.5 * 2 + 0.25 * 3, 2 + 0.5 * 3, 3, 10 + 0.5 * 20, 20])
    np.testing.assert_allclose(d.returns(0.5, np.ones(5)), [1.75, 1.5, 1.0, 1.5, 1.0])


def _obstacle_venv(n: int, normalize: bool):
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from training.run.sb3_vec import BatchedVecEnv

    venv = VecMonitor(
        BatchedVecEnv(
            num_envs=n,
            seed=5,
            backend="CCKA",
            task="Obstacle",
            action_mode="tension_delta",
            tension_step=0.1,
            clearance_features=True,
        )
    )
    return VecNormalize(venv) if normalize else venv


@pytest.mark.parametrize("normalize", [True, False])
def test_the_planner_demonstrations_are_complete_episodes_of_raw_data(normalize: bool) -> None:
    import gymnasium as gym

    import cdcr_gym  # noqa: F401
    from training.run.metrics import oracle_for

    venv = _obstacle_venv(3, normalize)
    probe = gym.make("cdcr_gym/CCKAObstacle-v0", tension_step=0.1, clearance_features=True)
    planner = oracle_for(probe)
    demos = collect_demonstrations(venv, planner, 4)
    # 3 envs end their 100-step episodes together: 2 rounds, the 6 complete episodes kept
    assert len(demos.successes) == 6 and len(demos.obs) == 600
    assert demos.episode_end.sum() == 6 and demos.episode_end[99::100].all()
    assert demos.actions.shape == (600, 3) and np.all(np.abs(demos.actions) <= 1.0)
    # raw observations (the planner reads them): the first of an episode is the straight robot
    spec = probe.unwrapped.observation_spec
    np.testing.assert_allclose(spec.decode(demos.obs[0], "tensions"), 0.0, atol=1e-12)
    # raw rewards: minus the distance (m) on the first step, no normalisation
    assert -0.5 < demos.rewards[0] < 0.0
    assert demos.successes.mean() >= 0.8  # the planner on its own model (100 % on evaluate's)
    probe.close()
    venv.close()


def test_collect_rejects_a_bad_episode_count() -> None:
    with pytest.raises(ValueError, match="episodes must be an integer >= 1, got 0"):
        collect_demonstrations(None, None, 0)


def _policy():
    import gymnasium as gym
    from stable_baselines3.common.policies import ActorCriticPolicy

    obs_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)
    act_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    return ActorCriticPolicy(obs_space, act_space, lambda _: 1e-3, log_std_init=-2.0)


def test_cloning_fits_the_mean_and_value_and_leaves_log_std() -> None:
    import torch as th

    th.manual_seed(0)
    policy = _policy()
    rng = np.random.default_rng(1)
    obs = rng.normal(size=(2000, 4))
    actions = np.tanh(obs[:, :2] - 0.5 * obs[:, 2:])  # a smooth target in [-1, 1]
    returns = obs.sum(axis=1)
    log_std = policy.log_std.detach().clone()
    out = clone_demonstrations(policy, obs, actions, returns, 30, 256, 3e-3, seed=0)
    assert out["action_mse_after"] < 0.1 * out["action_mse_before"]
    assert out["value_mse_after"] < 0.1 * out["value_mse_before"]
    assert th.equal(policy.log_std.detach(), log_std)
    no_value = clone_demonstrations(_policy(), obs, actions, None, 2, 256, 1e-3, seed=0)
    assert set(no_value) == {"action_mse_before", "action_mse_after"}


def _config(**demonstrations: object) -> dict:
    return {
        "env": {"id": "cdcr_gym/CCKAObstacle-v0"},
        "demonstrations": demonstrations,
    }


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"episodes": -1}, "demonstrations.episodes must be an integer >= 0, got -1"),
        ({"epochs": 0}, "demonstrations.epochs must be a positive integer, got 0"),
        ({"batch_size": 0}, "demonstrations.batch_size must be a positive integer, got 0"),
        ({"learning_rate": 0.0}, "demonstrations.learning_rate must be finite and > 0"),
    ],
)
def test_bad_demonstration_settings_are_named(changes: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")):
        config_from_dict(_config(**changes))


def test_cloning_is_for_ppo_only() -> None:
    data = {**_config(episodes=10), "algo": "sac"}
    with pytest.raises(ConfigError, match="behaviour cloning is for PPO only, got algo 'sac'"):
        config_from_dict(data)
    assert config_from_dict({**_config(episodes=0), "algo": "sac"}).demonstrations.episodes == 0


@pytest.mark.slow
def test_a_run_with_demonstrations_reports_them_and_counts_their_time(tmp_path: Path) -> None:
    data = yaml.safe_load((REPO / "configs" / "ppo_ccka_obstacle.yaml").read_text())
    data["env"]["n_envs"] = 4
    data["ppo"].update(n_steps=64, batch_size=64, n_epochs=2)
    data["eval"].update(freq=256, n_episodes=2)
    data["checkpoint"]["freq"] = 256
    data["total_timesteps"] = 256
    data["demonstrations"] = {"episodes": 4, "epochs": 3, "batch_size": 128}
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(data))
    run = tmp_path / "run"
    result = subprocess.run(
        [sys.executable, "-m", "training.run.train", str(config), "--run-dir", str(run)],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads((run / "demonstrations.json").read_text())
    assert report["episodes"] == 4 and report["transitions"] == 400
    assert report["oracle"] == "ObstaclePlanner (oracle)"
    assert report["action_mse_after"] < report["action_mse_before"]
    meta = json.loads((run / "run.json").read_text())
    assert meta["demonstrations"] == report
    # the cloned policy is evaluated before PPO changes it (step 0), then as usual
    steps = [row.split(",")[0] for row in (run / "eval_log.csv").read_text().splitlines()[1:]]
    assert steps[0] == "0" and steps[-1] == "256"
    # the cloning's wall time counts in the run's
    assert meta["total_wall_time_s"] >= report["wall_time_s"]
    assert "cloned 4 ObstaclePlanner (oracle) episodes" in result.stdout


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"candidates": 0}, "candidates must be an integer >= 1, got 0"),
        ({"no_such_option": 1}, "no_such_option"),
    ],
)
def test_bad_oracle_options_are_a_config_error_naming_them(options: dict, message: str) -> None:
    from training.run.demonstrations import pretrain

    config = config_from_dict(
        {
            "env": {"id": "cdcr_gym/CCKAObstacle-v0", "kwargs": {"tension_step": 0.1}},
            "demonstrations": {"episodes": 2, "oracle_kwargs": options},
        }
    )
    with pytest.raises(ConfigError, match=r"demonstrations.oracle_kwargs .*" + message):
        pretrain(config, None, None)  # refused before anything is collected
