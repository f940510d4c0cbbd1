"""Reach's reward_log_scale: the dense reward −s·ln(1 + d/s) (m), default unchanged (−d)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.tasks.reach import Reach


def test_default_dense_reward_is_minus_the_distance():
    d = np.array([0.0, 1e-4, 0.02])
    np.testing.assert_allclose(Reach().reward_from_distance(d), -d, rtol=0, atol=0)


def test_log_reward_is_minus_distance_near_the_goal_and_logarithmic_far():
    s = 1e-3
    task = Reach(reward_log_scale=s)
    near = np.array([1e-7, 1e-6])
    np.testing.assert_allclose(task.reward_from_distance(near), -near, rtol=1e-3)
    far = np.array([0.05, 0.1])
    np.testing.assert_allclose(task.reward_from_distance(far), -s * np.log(far / s), rtol=0.03)
    d = np.linspace(0.0, 0.1, 50)
    r = task.reward_from_distance(d)
    assert r[0] == 0.0 and np.all(np.diff(r) < 0)  # 0 at the goal, falls with the distance


def test_env_reward_and_compute_reward_use_the_log_scale():
    s = 2e-3
    env = gym.make("cdcr_gym/CCKAReach-v0", goal_conditioned=True, reward_log_scale=s)
    env.reset(seed=0)
    for a in np.random.default_rng(1).uniform(-1, 1, (5, 3)).astype(np.float32):
        obs, reward, _, _, info = env.step(a)
        assert reward == pytest.approx(-s * np.log1p(info["distance"] / s), rel=1e-6)
        again = env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert again == pytest.approx(reward, rel=1e-6)


@pytest.mark.parametrize("bad", [0.0, -1e-3, float("nan"), "1mm", True])
def test_bad_reward_log_scale_is_a_value_error_naming_it(bad):
    with pytest.raises(ValueError, match="reward_log_scale"):
        Reach(reward_log_scale=bad)


def test_reward_log_scale_with_a_sparse_reward_is_a_value_error():
    with pytest.raises(ValueError, match="reward_log_scale.*sparse|sparse.*reward_log_scale"):
        Reach(reward_type="sparse", reward_log_scale=1e-3)
