"""The random-policy reference row: uniform, in bounds, reproducible, clear errors."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401 - registers the ids
from training.evaluate.random_policy import RandomPolicy


def test_actions_are_uniform_in_the_box_and_reproducible() -> None:
    space = gym.spaces.Box(
        low=np.array([-1.0, 0.0, 2.0], np.float32), high=np.array([1.0, 0.5, 4.0], np.float32)
    )
    policy = RandomPolicy(space, seed=3)
    actions = np.concatenate([policy(np.zeros((500, 7))) for _ in range(20)])
    assert actions.shape == (10_000, 3) and actions.dtype == np.float32
    assert np.all(actions >= space.low) and np.all(actions <= space.high)
    # uniform: mean at the centre, standard deviation (high - low) / sqrt(12)
    np.testing.assert_allclose(actions.mean(0), (space.low + space.high) / 2, atol=0.02)
    np.testing.assert_allclose(actions.std(0), (space.high - space.low) / 12**0.5, rtol=0.03)
    again = RandomPolicy(space, seed=3)
    np.testing.assert_array_equal(again(np.zeros((500, 7))), actions[:500])
    assert not np.array_equal(RandomPolicy(space, seed=4)(np.zeros((500, 7))), actions[:500])


def test_dict_observations_give_one_action_per_row() -> None:
    env = gym.make("cdcr_gym/CCKAReach-v0", goal_conditioned=True)
    obs, _ = env.reset(seed=0)
    batch = {k: np.stack([v, v]) for k, v in obs.items()}
    actions = RandomPolicy.from_env(env)(batch)
    assert actions.shape == (2, *env.action_space.shape)
    assert env.action_space.contains(actions[0])
    env.close()


def test_unbounded_or_discrete_spaces_are_a_clear_error() -> None:
    with pytest.raises(ValueError, match="action_space must be bounded"):
        RandomPolicy(gym.spaces.Box(low=-np.inf, high=np.inf, shape=(3,)))
    with pytest.raises(ValueError, match="action_space must be a gymnasium Box"):
        RandomPolicy(gym.spaces.Discrete(3))
