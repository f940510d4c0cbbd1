"""The oracles: exact open loop on the analytic backend; closed loop (``feedback=True``) they reach
the goals of the physics backend (bullet, gravity on), where open loop they miss by centimetres."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.controllers import (
    AnalyticIKController,
    ObstaclePlanner,
    PoseIKController,
    TrackingIKController,
)

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


# -- closed loop (feedback=True) on the physics backend ------------------------------------------

FIXED_SEEDS = (1_000_000, 1_000_001)  # reset seeds of the fixed goals (the study's first ones)


def _final_info(env, controller, seed, steps=100):
    obs, info = env.reset(seed=seed)
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(controller(obs))
        if terminated or truncated:
            break
    return info


@pytest.mark.parametrize("seed", FIXED_SEEDS)
def test_feedback_reaches_bullet_goals_with_gravity_where_open_loop_misses(seed):
    env = gym.make("cdcr_gym/BulletReach-v0", gravity=True)
    closed = _final_info(env, AnalyticIKController.from_env(env, feedback=True), seed)
    opened = _final_info(env, AnalyticIKController.from_env(env), seed)
    env.close()
    assert closed["distance"] < 0.005 and closed["is_success"]
    assert closed["distance"] < opened["distance"]
    assert opened["distance"] > 0.02  # the open-loop row: centimetres off on bullet


@pytest.mark.parametrize("seed", FIXED_SEEDS)
def test_feedback_pose_on_bullet_tdcr2_with_gravity(seed):
    env = gym.make("cdcr_gym/BulletPose-v0", gravity=True)
    closed = _final_info(env, PoseIKController.from_env(env, feedback=True), seed)
    opened = _final_info(env, PoseIKController.from_env(env), seed)
    env.close()
    assert closed["is_success"] and closed["distance"] < 0.005
    assert closed["angle"] < np.deg2rad(5.0)
    assert closed["distance"] < opened["distance"] and closed["angle"] < opened["angle"]


def test_feedback_tracking_on_bullet_beats_open_loop():
    env = gym.make("cdcr_gym/BulletTrack-v0", gravity=True)
    closed = _final_info(env, TrackingIKController.from_env(env, feedback=True), FIXED_SEEDS[0])
    opened = _final_info(env, TrackingIKController.from_env(env), FIXED_SEEDS[0])
    env.close()
    assert closed["tracking_rms"] < 0.005 < opened["tracking_rms"]
    assert closed["distance"] < 0.005


def test_feedback_planner_on_bullet_ends_on_the_goal():
    env = gym.make("cdcr_gym/BulletObstacle-v0", gravity=True)
    closed = _final_info(env, ObstaclePlanner.from_env(env, feedback=True), FIXED_SEEDS[0])
    opened = _final_info(env, ObstaclePlanner.from_env(env), FIXED_SEEDS[0])
    env.close()
    assert closed["distance"] < 0.005 < opened["distance"]
    assert closed["is_success"] and not closed["collided"]


@pytest.mark.parametrize(
    "env_id, cls",
    [
        ("cdcr_gym/MuJoCoReach-v0", AnalyticIKController),
        ("cdcr_gym/MuJoCoPose-v0", PoseIKController),
    ],
)
def test_feedback_reaches_mujoco_goals_with_gravity(env_id, cls):
    env = gym.make(env_id, gravity=True)
    closed = _final_info(env, cls.from_env(env, feedback=True), FIXED_SEEDS[0])
    opened = _final_info(env, cls.from_env(env), FIXED_SEEDS[0])
    env.close()
    assert closed["is_success"] and closed["distance"] < 0.005
    assert closed["distance"] < opened["distance"]
    assert opened["distance"] > 0.01  # the open-loop row: centimetres off


@pytest.mark.parametrize("mode", ["tension", "tension_delta", "length_delta"])
def test_feedback_converges_on_the_analytic_backend_in_every_action_mode(mode):
    env = gym.make(ENV_ID, action_mode=mode, initial_state="random")
    controller = AnalyticIKController.from_env(env, feedback=True)
    assert controller.mode == "closed_loop"
    for seed in range(3):
        assert _final_info(env, controller, seed)["distance"] < 1e-3


def test_feedback_reads_goal_conditioned_observations_and_batches():
    env = gym.make(ENV_ID, goal_conditioned=True)
    controller = AnalyticIKController.from_env(env, feedback=True)
    assert _final_info(env, controller, 0)["distance"] < 1e-3
    flat = gym.make(ENV_ID)
    controller = AnalyticIKController.from_env(flat, feedback=True)
    observations = np.stack([flat.reset(seed=s)[0] for s in range(4)])
    actions, _ = controller.predict(observations)
    assert actions.shape == (4, 3) and actions.dtype == np.float32
    assert np.all(np.abs(actions) <= 1.0)
    # stateless: a row's action depends on that row only
    assert np.array_equal(actions[2], controller(observations[2]))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"feedback": "yes"}, "feedback"),
        ({"feedback": 1}, "feedback"),
        ({"gain": 0.0}, "gain"),
        ({"gain": 1.5}, "gain"),
        ({"gain": float("nan")}, "gain"),
        ({"gain": "fast"}, "gain"),
    ],
)
def test_feedback_arguments_are_validated(kwargs, name):
    env = gym.make(ENV_ID)
    with pytest.raises(ValueError, match=name):
        AnalyticIKController.from_env(env, **kwargs)
    with pytest.raises(ValueError, match=name):
        TrackingIKController.from_env(gym.make("cdcr_gym/CCKATrack-v0"), **kwargs)
    with pytest.raises(ValueError, match=name):
        PoseIKController.from_env(gym.make("cdcr_gym/CCKAPose-v0"), **kwargs)
    with pytest.raises(ValueError, match=name):
        ObstaclePlanner.from_env(gym.make("cdcr_gym/CCKAObstacle-v0"), **kwargs)
