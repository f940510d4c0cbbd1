"""The analytic-IK controller is an exact oracle on the analytic backend."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.controllers import AnalyticIKController

ENV_ID = "cdcr_gym/CCKAReach-v0"


@pytest.mark.parametrize("goal_conditioned", [False, True])
@pytest.mark.parametrize("initial_state", ["straight", "random"])
@pytest.mark.parametrize(
    "mode, steps_allowed", [("tension", 1), ("tension_delta", 100), ("length_delta", 100)]
)
def test_ik_controller_reaches_every_goal_below_a_micrometre(
    mode, steps_allowed, initial_state, goal_conditioned
):
    env = gym.make(
        ENV_ID, action_mode=mode, initial_state=initial_state, goal_conditioned=goal_conditioned
    )
    controller = AnalyticIKController.from_env(env)
    for seed in range(100):
        obs, info = env.reset(seed=seed)
        reached_at = None
        for t in range(steps_allowed):
            obs, _, _, truncated, info = env.step(controller(obs))
            if info["distance"] < 1e-6:
                reached_at = t + 1
                break
        assert reached_at is not None, f"seed {seed}: {info['distance']} m left"
        for _ in range(5):  # ... and it holds the goal once there
            obs, _, _, _, info = env.step(controller(obs))
            assert info["distance"] < 1e-6


def test_controller_predict_matches_sb3_signature_and_batches():
    env = gym.make(ENV_ID)
    controller = AnalyticIKController.from_env(env)
    observations = np.stack([env.reset(seed=s)[0] for s in range(4)])
    actions, state = controller.predict(observations, deterministic=True)
    assert state is None and actions.shape == (4, 3) and actions.dtype == np.float32
    assert np.array_equal(actions[2], controller(observations[2]))


def test_controller_rejects_foreign_observations():
    controller = AnalyticIKController.from_env(gym.make(ENV_ID))
    with pytest.raises(ValueError, match="obs"):
        controller(np.zeros(5, dtype=np.float32))
    with pytest.raises(ValueError, match="action_mode"):
        AnalyticIKController(controller.params, controller.spec, action_mode="torque")
