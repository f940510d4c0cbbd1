"""The Pose task (cdcr_gym/{CCKA,Bullet,MuJoCo}Pose-v0) and its oracle."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest
from task_contracts import (
    batched_ids,
    batched_matches_single,
    check_env_both,
    combos,
    make,
    rollout,
)

from cdcr_gym.controllers import PoseIKController
from cdcr_gym.tasks.pose import Pose, pose_errors

COMBOS = combos("Pose")


@pytest.mark.parametrize("goal_conditioned", [False, True])
@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_check_env_passes(env_id, robot, goal_conditioned):
    env = make(env_id, robot, goal_conditioned=goal_conditioned)
    check_env_both(env)
    env.close()


@pytest.mark.parametrize("goal_conditioned", [False, True])
@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_same_seed_and_actions_give_identical_trajectories(env_id, robot, goal_conditioned):
    a = rollout(env_id, robot, goal_conditioned=goal_conditioned, initial_state="random")
    b = rollout(env_id, robot, goal_conditioned=goal_conditioned, initial_state="random")
    assert np.array_equal(a, b)


@pytest.mark.parametrize("env_id", batched_ids("Pose"))
def test_batched_env_matches_single_envs(env_id):
    batched_matches_single(env_id, "tdcr2", initial_state="random")


def test_ccka_pose_defaults_to_the_two_section_robot():
    env = gym.make("cdcr_gym/CCKAPose-v0")
    assert env.unwrapped.params.n_sections == 2
    assert env.action_space.shape == (6,)


def test_goal_env_reward_equals_compute_reward_batched_over_the_last_axis():
    env = gym.make("cdcr_gym/CCKAPose-v0", goal_conditioned=True)
    obs, info = env.reset(seed=3)
    achieved, desired, rewards = [], [], []
    for _ in range(6):
        obs, reward, _, _, info = env.step(env.action_space.sample())
        assert reward == env.unwrapped.compute_reward(
            obs["achieved_goal"], obs["desired_goal"], info
        )
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(reward)
    batch = env.unwrapped.compute_reward(np.array(achieved), np.array(desired), None)
    assert batch.shape == (6,)
    np.testing.assert_allclose(batch, rewards, rtol=0, atol=0)
    # the reward weighs the angle: same position, turned direction, lower reward
    a = np.array(achieved[-1], dtype=np.float64)
    turned = a.copy()
    turned[3:] = [1.0, 0.0, 0.0] if abs(a[3]) < 0.9 else [0.0, 1.0, 0.0]
    assert env.unwrapped.compute_reward(turned, a, None) < env.unwrapped.compute_reward(a, a, None)


def test_info_reports_distance_and_angle_and_success_needs_both():
    env = gym.make("cdcr_gym/CCKAPose-v0", distance_threshold=0.01, angle_threshold=0.1)
    obs, info = env.reset(seed=0)
    d, a = pose_errors(
        np.concatenate([info["tip"], env.unwrapped.core.readings.tip_direction[0]]),
        np.concatenate([info["goal"], info["goal_direction"]]),
    )
    assert info["distance"] == pytest.approx(d) and info["angle"] == pytest.approx(a)
    assert info["is_success"] == (d <= 0.01 and a <= 0.1)
    task = env.unwrapped.task
    assert task.compute_reward(np.r_[0, 0, 0.4, 0, 0, 1.0], np.r_[0, 0, 0.4, 0, 0, 1.0]) == 0.0
    reward = task.compute_reward(np.r_[0, 0, 0.4, 0, 0, 1.0], np.r_[0.003, 0, 0.4, 0, 1.0, 0])
    assert reward == pytest.approx(-(0.003 + 0.05 * np.pi / 2))


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_pose_oracle_is_within_1_mm_and_1_degree_on_ccka(robot):
    env = gym.make("cdcr_gym/CCKAPose-v0", robot=robot)
    controller = PoseIKController.from_env(env)
    worst_d = worst_a = 0.0
    for seed in range(8):
        obs, _ = env.reset(seed=seed)
        truncated = False
        while not truncated:
            obs, _, _, truncated, info = env.step(controller(obs))
        worst_d, worst_a = max(worst_d, info["distance"]), max(worst_a, info["angle"])
    assert worst_d < 1e-3 and worst_a < np.deg2rad(1.0), (worst_d, worst_a)


def test_a_given_goal_is_projected_to_a_reachable_pose():
    env = gym.make("cdcr_gym/CCKAPose-v0")
    _, info = env.reset(seed=0, options={"goal": [0.1, 0.0, 0.3, 0.0, 0.0, 2.0]})
    assert np.linalg.norm(info["goal_direction"]) == pytest.approx(1.0)
    controller = PoseIKController.from_env(env)
    obs, _ = env.reset(
        seed=0, options={"goal": info["goal"].tolist() + info["goal_direction"].tolist()}
    )
    for _ in range(100):
        obs, _, _, _, info = env.step(controller(obs))
    assert info["distance"] < 1e-6 and info["angle"] < 1e-5


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"angle_threshold": 0.0}, "angle_threshold"),
        ({"angle_threshold": 4.0}, "angle_threshold"),
        ({"angle_weight": -1.0}, "angle_weight"),
        ({"distance_threshold": -1.0}, "distance_threshold"),
        ({"reward_type": "dense2"}, "reward_type"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("cdcr_gym/CCKAPose-v0", **kwargs)


@pytest.mark.parametrize("goal", [[0, 0, 0.3], [0, 0, 0.3, 0, 0, 0], [0, 0, np.nan, 0, 0, 1]])
def test_bad_goal_options_raise_value_error(goal):
    env = gym.make("cdcr_gym/CCKAPose-v0")
    with pytest.raises(ValueError, match="goal"):
        env.reset(seed=0, options={"goal": goal})


def test_docstring_lists_the_arguments_and_the_observation_tables():
    doc = inspect.getdoc(Pose)
    for name in inspect.signature(Pose.__init__).parameters:
        if name != "self":
            assert f"{name}:" in doc, name
    for gc in (False, True):
        env = gym.make("cdcr_gym/CCKAPose-v0", goal_conditioned=gc)
        assert env.unwrapped.observation_spec.table() in doc
