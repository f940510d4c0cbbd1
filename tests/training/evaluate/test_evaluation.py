"""One evaluation for every task: ``cdcr-gym evaluate`` runs the agent and the task's oracle on the
same episodes through the same code for Reach, Track, Pose and Obstacle, and writes one report
shape (no training: an untrained model saved as the run's best model)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from cdcr_gym import controllers
from training.evaluate import agent, results
from training.run.rollout import make_env

REPO = Path(__file__).resolve().parents[3]
TASKS = [task.__name__ for task in controllers.ORACLES]  # every task that names an oracle
SUMMARY = {"task", "episodes", "success_rate", "within_1mm", "mean_return", "final_distance_mm"}
#: what the task's env reports -> the metric its summary must hold
OWN = {"tracking_rms": "tracking_rms_mm", "angle": "final_angle_deg", "collision": "collision_rate"}


def _run_dir(tmp_path: Path, task: str) -> Path:
    """A run directory of ``ppo_ccka_<task>`` (two conditions, 2 short horizons) whose best model
    is an untrained PPO."""
    from stable_baselines3 import PPO

    data = yaml.safe_load((REPO / "configs" / f"ppo_ccka_{task.lower()}.yaml").read_text())
    data["evaluate"].update(initial_states=["straight", "random"], horizons=[6, 12], seed=5)
    data["env"]["max_episode_steps"] = 8
    run = tmp_path / task
    (run / "best_model").mkdir(parents=True)
    (run / "config.yaml").write_text(yaml.safe_dump(data))
    env = make_env(data["env"]["id"], data["env"]["kwargs"])
    policy = "MultiInputPolicy" if hasattr(env.observation_space, "spaces") else "MlpPolicy"
    PPO(policy, env, n_steps=16, batch_size=16, seed=0, device="cpu").save(
        run / "best_model" / "model.zip"
    )
    env.close()
    return run


@pytest.mark.parametrize("task", TASKS)
def test_every_task_is_evaluated_by_the_one_pipeline_into_one_report_shape(tmp_path, task, capsys):
    run = _run_dir(tmp_path, task)
    assert agent.main([str(run), "--episodes", "2"]) == 0
    out = capsys.readouterr().out
    data = json.loads((run / "eval.json").read_text())
    assert data["task"] == task and data["env_id"] == f"cdcr_gym/CCKA{task}-v0"
    assert data["headline_condition"] == "straight_6steps" and data["train_horizon"] == 8
    names = ["straight_6steps", "straight_12steps", "random_6steps", "random_12steps"]
    assert list(data["conditions"]) == names
    env = make_env(data["env_id"])
    info_keys = set(env.unwrapped.task.info_keys())
    env.close()
    for name, cond in data["conditions"].items():
        assert (cond["initial_state"], cond["horizon"]) == tuple(name[:-5].split("_")[:1]) + (
            int(name.split("_")[1][:-5]),
        )
        # the agent beside the oracle and the floor, on the same episodes
        assert {"policy", "oracle", "random"} <= set(cond)
        assert ("reach_ik" in cond) == ("collision" in info_keys)
        for who in ("policy", "oracle", "random"):
            s = cond[who]
            assert SUMMARY <= set(s) and s["task"] == task and s["episodes"] == 2
            assert 0.0 <= s["success_rate"] <= 1.0 and s["final_distance_mm"]["max"] >= 0.0
            for key, metric in OWN.items():
                assert (metric in s) == (key in info_keys), (who, metric)
        assert "to_oracle" in cond["policy"] and "to_oracle" not in cond["oracle"]
        # longer than the training episodes: does the policy hold the goal
        assert ("max_distance_after_train_horizon_mm" in cond["policy"]) == (cond["horizon"] > 8)
    assert data["policy"] == data["conditions"]["straight_6steps"]["policy"]
    assert Path(data["figures"]["histogram"]).stat().st_size > 0
    assert task in out and "oracle" in out
    assert max(len(line) for line in out.splitlines()) <= 100
    # the same report reads back as one table of the task, every run alike
    (run / "run.json").write_text(json.dumps({"total_wall_time_s": 60.0, "total_steps": 16}))
    assert results.main([str(run), "--out", str(tmp_path / "collected.json")]) == 0
    table = capsys.readouterr().out
    assert table.startswith(f"{task}:") and table.count(f"| {task} straight_6steps |") >= 3
    collected = json.loads((tmp_path / "collected.json").read_text())["runs"][0]
    assert collected["task"] == task and collected["conditions"] == data["conditions"]


def test_the_same_seed_gives_the_same_numbers(tmp_path, capsys):
    run = _run_dir(tmp_path, "Reach")
    assert agent.main([str(run), "--episodes", "2"]) == 0
    first = json.loads((run / "eval.json").read_text())["conditions"]
    assert agent.main([str(run), "--episodes", "2"]) == 0
    again = json.loads((run / "eval.json").read_text())["conditions"]
    assert first == again
    assert agent.main([str(run), "--episodes", "2", "--seed", "6", "--tag", "other"]) == 0
    other = json.loads((run / "eval_other.json").read_text())["conditions"]
    assert other != first
