"""One rollout and one summary for every task: ``training.run.rollout.run_episodes`` runs seeded
scenes (any task) and explicit goals alike, and ``training.run.metrics.summarize`` reads each
task's numbers from its rollouts."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from training.run.metrics import oracle_for, summarize
from training.run.rollout import EpisodeSpecs, make_env, run_episodes


def _env_fn(task: str, steps: int | None = None):
    return lambda: make_env(f"cdcr_gym/CCKA{task}-v0", {}, steps)


@pytest.mark.parametrize("task", ["Reach", "Track", "Pose", "Obstacle"])
def test_the_summary_comes_from_the_one_rollout(task):
    env = _env_fn(task)()
    oracle = oracle_for(env)
    env.close()
    rollouts = run_episodes(_env_fn(task), oracle, EpisodeSpecs.from_seeds(3, 7), record=1)
    s = summarize(task, rollouts)
    d_mm = 1e3 * np.array([info["distance"] for info in rollouts.final_infos])
    assert s["final_distance_mm"]["max"] == pytest.approx(d_mm.max(), rel=1e-12)
    assert s["task"] == task and s["episodes"] == 3 and len(rollouts.paths) == 1
    assert rollouts.paths[0]["tip"].shape == (rollouts.episode_length[0] + 1, 3)
    # the task names its metrics through the info its env reports
    assert ("tracking_rms_mm" in s) == (task == "Track")
    assert ("final_angle_deg" in s) == (task == "Pose")
    assert ("collision_rate" in s) == (task == "Obstacle")
    if task == "Obstacle":
        assert np.isfinite(s["min_clearance_mm"]["median"])
    if task == "Track":
        assert s["tracking_rms_mm"]["max"] < 1.0  # the tracking oracle
    if task == "Reach":
        assert s["success_rate"] == 1.0  # the exact IK on CCKA


def test_longer_than_training_episodes_report_holding_the_goal_and_the_oracle_distance():
    env = _env_fn("Reach", 60)()
    ik = oracle_for(env)
    env.close()
    specs = EpisodeSpecs.from_seeds(4, 3)
    ref = run_episodes(_env_fn("Reach", 60), ik, specs, 60)
    zero = run_episodes(_env_fn("Reach", 60), lambda o: np.zeros((len(o), 3)), specs, 60)
    s = summarize("Reach", zero, train_horizon=40, reference=ref)
    assert "max_distance_after_train_horizon_mm" in s and "to_oracle" in s
    assert s["to_oracle"]["tension_distance_n"]["median"] > 0.0
    assert "to_oracle" not in summarize("Reach", ref, train_horizon=60)
    assert "max_distance_after_train_horizon_mm" not in summarize("Reach", ref, train_horizon=60)
    same = summarize("Reach", ref, reference=ref)["to_oracle"]
    assert same["cable_length_distance_mm"]["max"] == 0.0


def test_explicit_goals_give_the_same_episodes_in_any_batch_size():
    env = _env_fn("Reach", 60)()
    goals, starts = [], []
    for i in range(5):
        _, info = env.reset(seed=i)
        goals.append(info["goal"])
        starts.append(info["tensions"])
    ik = oracle_for(env)
    env.close()
    specs = EpisodeSpecs(np.array(goals), np.array(starts), "straight", 0)
    one = run_episodes(_env_fn("Reach", 60), ik.action, specs, 40, batch_size=1)
    three = run_episodes(_env_fn("Reach", 60), ik.action, specs, 40, batch_size=3)
    np.testing.assert_array_equal(one.distances, three.distances)
    np.testing.assert_array_equal(one.goals, specs.goals)
    seeded = run_episodes(_env_fn("Reach", 60), ik.action, EpisodeSpecs.from_seeds(5, 0), 40)
    np.testing.assert_allclose(seeded.distances, one.distances, atol=1e-12)


def test_a_summary_of_no_episodes_is_an_error():
    env = _env_fn("Reach", 5)()
    env.close()
    empty = run_episodes(_env_fn("Reach", 5), lambda o: o, EpisodeSpecs.from_seeds(0, 0), 5)
    with pytest.raises(ValueError, match="rollouts"):
        summarize("Reach", empty)


def test_a_rollout_without_a_horizon_needs_a_time_limit():
    def env_fn():
        return gym.make("cdcr_gym/CCKAReach-v0", max_episode_steps=None).unwrapped

    with pytest.raises(ValueError, match="horizon"):
        run_episodes(env_fn, lambda obs: np.zeros((len(obs), 3)), EpisodeSpecs.from_seeds(1, 0))
