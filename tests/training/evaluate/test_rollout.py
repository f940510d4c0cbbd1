"""One rollout for every task: ``training.run.rollout.run_episodes`` runs seeded scenes (any
task) and explicit Reach goals alike, and ``training.run.metrics`` reads each task's numbers
from its rollouts."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from training.run.metrics import oracle_for, run_task_episodes, summarize, task_metrics
from training.run.rollout import EpisodeSpecs, make_env, make_specs, run_episodes


def _env_fn(task: str, steps: int | None = None):
    return lambda: make_env(f"cdcr_gym/CCKA{task}-v0", {}, steps)


@pytest.mark.parametrize("task", ["Reach", "Track", "Obstacle"])
def test_task_metrics_come_from_the_one_rollout(task):
    env = _env_fn(task)()
    oracle = oracle_for(env)
    env.close()
    rollouts = run_episodes(_env_fn(task), oracle, EpisodeSpecs.from_seeds(3, 7), record=1)
    metrics = task_metrics(task, rollouts)
    again = run_task_episodes(_env_fn(task), oracle_for(_env_fn(task)()), 3, 7, record=1)
    np.testing.assert_array_equal(metrics["final_distance_mm"], again["final_distance_mm"])
    np.testing.assert_array_equal(metrics["final_distance_mm"], 1e3 * rollouts.final_distance)
    assert metrics["task"] == task and len(metrics["paths"]) == 1
    assert metrics["paths"][0]["tip"].shape == (rollouts.episode_length[0] + 1, 3)
    if task == "Obstacle":
        assert np.all(np.isfinite(metrics["min_clearance_mm"]))
    if task == "Track":
        assert np.all(metrics["tracking_rms_mm"] < 1.0)  # the tracking oracle


def test_explicit_reach_goals_give_the_same_episodes_in_any_batch_size():
    specs = make_specs(5, 0, "random", None)
    env = _env_fn("Reach", 60)()
    ik = oracle_for(env)
    env.close()
    one = run_episodes(_env_fn("Reach", 60), ik.action, specs, 40, batch_size=1)
    three = run_episodes(_env_fn("Reach", 60), ik.action, specs, 40, batch_size=3)
    np.testing.assert_array_equal(one.distances, three.distances)
    np.testing.assert_array_equal(one.goals, specs.goals)
    assert summarize(one.final_distance, 0.005)["success_rate"] == 1.0  # the exact IK on CCKA


def test_a_rollout_without_a_horizon_needs_a_time_limit():
    def env_fn():
        return gym.make("cdcr_gym/CCKAReach-v0", max_episode_steps=None).unwrapped

    with pytest.raises(ValueError, match="horizon"):
        run_episodes(env_fn, lambda obs: np.zeros((len(obs), 3)), EpisodeSpecs.from_seeds(1, 0))
