"""The task configs train and evaluate (tiny budgets), and the oracle script runs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[3]
ENV = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"}


def _run(module: str, *args: object, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *map(str, args)],
        cwd=REPO,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _small(tmp_path: Path, name: str) -> Path:
    data = yaml.safe_load((REPO / "configs" / f"{name}.yaml").read_text())
    data["env"]["n_envs"] = 4
    data["ppo"]["n_steps"] = 64
    data["ppo"]["batch_size"] = 64
    data["eval"].update(freq=256, n_episodes=2)
    data["checkpoint"]["freq"] = 256
    data["evaluate"].update(initial_states=["straight"], horizons=[20])
    if data.get("demonstrations", {}).get("episodes"):  # cloning the oracle: a few episodes
        data["demonstrations"].update(episodes=4, epochs=2)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        "ppo_ccka_track",
        "ppo_ccka_pose",
        "ppo_ccka_obstacle",
        "ppo_bullet_track",
        "ppo_mujoco_track",
        "ppo_mujoco_pose",
        "ppo_mujoco_obstacle",
    ],
)
def test_task_config_trains_and_evaluates_beside_its_oracle(tmp_path: Path, name: str) -> None:
    run = tmp_path / "run"
    result = _run(
        "training.run.train", _small(tmp_path, name), "--total-timesteps", 512, "--run-dir", run
    )
    assert result.returncode == 0, result.stderr[-3000:]
    if yaml.safe_load(_small(tmp_path, name).read_text()).get("demonstrations", {}).get("episodes"):
        cloned = json.loads((run / "demonstrations.json").read_text())
        assert cloned["episodes"] >= 4 and cloned["action_mse_after"] < cloned["action_mse_before"]
    rows = (run / "eval_log.csv").read_text().splitlines()
    assert len(rows) >= 2 and rows[0].startswith("timesteps,success_rate")
    result = _run("training.evaluate", run, "--episodes", 2)
    assert result.returncode == 0, result.stderr[-3000:]
    data = json.loads((run / "eval.json").read_text())
    assert set(data["conditions"]) == {"straight_20steps"}
    assert "policy" in data and "oracle" in data
    # the floor: the uniform random policy on the same episodes
    assert data["random"]["episodes"] == data["policy"]["episodes"] == 2
    task = data["task"]
    # on a physics backend the oracle also runs closed loop, on the same episodes
    physics = "CCKA" not in data["env_id"]
    assert ("oracle_closed_loop" in data) == physics
    if physics:
        assert data["oracle_closed_loop"]["episodes"] == data["oracle"]["episodes"] == 2
    if task == "Track" and "CCKA" in data["env_id"]:  # on bullet the oracle runs open loop
        assert data["oracle"]["tracking_rms_mm"]["max"] < 1.0
        assert (run / "eval" / "straight_20steps_paths.png").stat().st_size > 0
    if task == "Obstacle":
        assert data["reach_ik"]["collision_rate"] > 0.0
        assert data["oracle"]["collisions_in_successful_episodes"] == 0
        replay = _run("training.evaluate.obstacle_failures", run, "--episodes", 3)
        assert replay.returncode == 0, replay.stderr[-3000:]
        counts = replay.stdout.splitlines()[0]
        assert "success" in counts and "collided" in counts and "waited" in counts
    assert task in result.stdout


def test_oracle_script_writes_the_numbers_and_figures(tmp_path: Path) -> None:
    result = _run(
        "training.evaluate.oracles",
        "--task",
        "track",
        "--episodes",
        2,
        "--figures",
        1,
        "--out",
        tmp_path,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    data = json.loads((tmp_path / "oracle_track_CCKA_paper.json").read_text())
    assert data["oracle"]["episodes"] == 2 and data["oracle"]["tracking_rms_mm"]["max"] < 1.0
    assert (tmp_path / "oracle_track_CCKA_paper.png").stat().st_size > 0


def test_oracle_script_rejects_bad_arguments(tmp_path: Path) -> None:
    result = _run(
        "training.evaluate.oracles", "--task", "track", "--episodes", 0, "--out", tmp_path
    )
    assert result.returncode == 2 and "--episodes" in result.stderr
    result = _run(
        "training.evaluate.oracles", "--task", "track", "--env-kwarg", "speed=-1", "--out", tmp_path
    )
    assert result.returncode == 2 and "speed" in result.stderr


def test_obstacle_failures_without_a_model_is_exit_2(tmp_path: Path) -> None:
    result = _run("training.evaluate.obstacle_failures", tmp_path)
    assert result.returncode == 2 and "best_model/model.zip" in result.stderr


OFF_POLICY_TASK_CONFIGS = [
    f"{algo}_{task}"
    for task in (
        "ccka_track",
        "ccka_pose",
        "ccka_obstacle",
        "mujoco_reach",
        "mujoco_track",
        "mujoco_pose",
        "mujoco_obstacle",
    )
    for algo in ("sac", "td3", "tqc")
] + ["sac_ccka_obstacle_600k"]  # the Obstacle target's config (evaluates its final model)


@pytest.mark.slow  # 10-30 s each: a few hundred steps, then the evaluation beside the baselines
@pytest.mark.parametrize("name", OFF_POLICY_TASK_CONFIGS)
def test_off_policy_config_trains_and_evaluates_beside_the_baselines(
    tmp_path: Path, name: str
) -> None:
    """The benchmark's SAC/TD3/TQC configs of the tasks train (a few gradient steps past
    ``learning_starts``) and evaluate beside the oracle(s) and the random-policy floor."""
    data = yaml.safe_load((REPO / "configs" / f"{name}.yaml").read_text())
    algo = data["algo"]
    data["env"]["n_envs"] = 2
    data[algo].update(learning_starts=100, batch_size=32, buffer_size=2000)
    data["eval"].update(freq=200, n_episodes=2)
    data["checkpoint"]["freq"] = 200
    data["evaluate"].update(initial_states=["straight"], horizons=[20])
    cfg = tmp_path / f"{name}.yaml"
    cfg.write_text(yaml.safe_dump(data))
    run = tmp_path / "run"
    result = _run("training.run.train", cfg, "--total-timesteps", 400, "--run-dir", run)
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads((run / "run.json").read_text())["status"] == "complete"
    result = _run("training.evaluate", run, "--episodes", 2)
    assert result.returncode == 0, result.stderr[-3000:]
    out = json.loads((run / "eval.json").read_text())
    head = out["conditions"]["straight_20steps"]
    # every task: its metrics beside the oracle and the random floor, on the same episodes
    assert {"policy", "oracle", "random"} <= set(head) and out["task"] in name.title()
    assert head["random"]["episodes"] == head["policy"]["episodes"] == 2
    assert ("oracle_closed_loop" in head) == ("mujoco" in name)  # physics: also closed loop
    if out.get("task") == "Obstacle":  # its failures sorted: the config's model, any algorithm
        replay = _run("training.evaluate.obstacle_failures", run, "--episodes", 2)
        assert replay.returncode == 0, replay.stderr[-3000:]
        model = data["evaluate"].get("model", "best")
        assert f"({model} model)" in replay.stdout.splitlines()[0]
