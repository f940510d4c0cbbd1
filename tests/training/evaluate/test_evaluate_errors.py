"""Clear errors of ``cdcr-gym evaluate`` and ``cdcr-gym demo`` before any work or output
(issue 23.4): a policy on an env of other spaces, another package's env, bad seeds."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from training.evaluate import agent, ik_demo

TINY = {
    "name": "tiny",
    "seed": 3,
    "total_timesteps": 256,
    "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 1},
    "ppo": {"n_steps": 64, "batch_size": 64, "policy": {"net_arch": [8]}},
}


@pytest.fixture
def untrained_run(tmp_path: Path) -> Path:
    """A run directory whose best model is an untrained PPO policy of the 3-cable robot."""
    import gymnasium as gym
    from stable_baselines3 import PPO

    import cdcr_gym  # noqa: F401

    run = tmp_path / "run"
    (run / "best_model").mkdir(parents=True)
    (run / "config.yaml").write_text(yaml.safe_dump(TINY))
    env = gym.make("cdcr_gym/CCKAReach-v0")
    PPO("MlpPolicy", env, n_steps=64, batch_size=64, policy_kwargs={"net_arch": [8]}).save(
        run / "best_model" / "model.zip"
    )
    env.close()
    return run


def test_a_policy_on_a_robot_of_other_spaces_is_exit_2_and_writes_nothing(
    untrained_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--env-kwarg robot=tdcr2`` (six cables) on a 3-cable run once failed deep in the
    rollout with a broadcast error, leaving an empty evaluation folder."""
    before = sorted(p.name for p in untrained_run.iterdir())
    assert agent.main([str(untrained_run), "--env-kwarg", "robot=tdcr2", "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "robot=tdcr2" in err and "space" in err and "trained" in err
    assert sorted(p.name for p in untrained_run.iterdir()) == before  # no eval folder, no json


@pytest.mark.parametrize(
    "args, message",
    [
        (["--seed", "-5"], "argument --seed: must be an integer"),
        (["--env-id", "CartPole-v1"], "'CartPole-v1' is not a cdcr_gym env"),
        (["--env-id", "cdcr_gym/Nope-v0"], "is not registered"),
    ],
)
def test_demo_arguments_are_usage_errors(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        ik_demo.main([*args, "--episodes", "1"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "usage: cdcr-gym demo" in err and message in err
