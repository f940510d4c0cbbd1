"""The Track task (cdcr_gym/{CCKA,Bullet,MuJoCo}Track-v0) and its oracle."""

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

from cdcr_gym.controllers import TrackingIKController
from cdcr_gym.tasks.track import NOMINAL_TIMESTEP, Track

COMBOS = combos("Track")


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_check_env_passes(env_id, robot):
    env = make(env_id, robot)
    check_env_both(env)
    env.close()


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_same_seed_and_actions_give_identical_trajectories(env_id, robot):
    a, b = rollout(env_id, robot), rollout(env_id, robot)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, rollout(env_id, robot, seed=6))


@pytest.mark.parametrize("env_id", batched_ids("Track"))
def test_batched_env_matches_single_envs(env_id):
    batched_matches_single(env_id, "tdcr2", initial_state="random")


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_target_moves_at_the_given_speed_on_a_reachable_path(robot):
    speed = 0.08
    env = gym.make("cdcr_gym/CCKATrack-v0", robot=robot, speed=speed)
    obs, info = env.reset(seed=2)
    task = env.unwrapped.task
    spec = env.unwrapped.observation_spec
    targets = [info["target"]]
    for _ in range(40):
        obs, _, _, _, info = env.step(env.action_space.sample())
        targets.append(info["target"])
        np.testing.assert_allclose(np.linalg.norm(info["target_velocity"]), speed, rtol=1e-9)
        np.testing.assert_allclose(spec.decode(obs, "target"), info["target"], atol=1e-6)
    steps = np.linalg.norm(np.diff(targets, axis=0), axis=1)
    # chords of a smooth curve: just below speed·dt
    assert np.all(steps <= speed * NOMINAL_TIMESTEP * (1 + 1e-9))
    assert np.all(steps > 0.99 * speed * NOMINAL_TIMESTEP)
    # the path is reachable: the IK of every point has (almost) no residual
    from cdcr_gym.model.ik import solve_ik

    residual = solve_ik(task.path_points(0, 200), env.unwrapped.params).residual
    assert residual.max() < 1e-4, residual.max()


def test_tracking_metrics_count_the_steps_after_the_settling_window():
    env = gym.make("cdcr_gym/CCKATrack-v0", settle_steps=10)
    env.reset(seed=0)
    distances = []
    for k in range(30):
        _, reward, _, _, info = env.step(np.zeros(3, dtype=np.float32))
        distances.append(info["distance"])
        assert reward == pytest.approx(-info["distance"])
        assert info["tracking_steps"] == max(0, k + 1 - 10)
    tail = np.array(distances[10:])
    assert info["tracking_rms"] == pytest.approx(np.sqrt(np.mean(tail**2)), rel=1e-12)
    assert info["tracking_max"] == pytest.approx(tail.max(), rel=1e-12)


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_tracking_oracle_rms_is_below_1_mm_on_ccka(robot):
    env = gym.make("cdcr_gym/CCKATrack-v0", robot=robot)
    controller = TrackingIKController.from_env(env)
    rms = []
    for seed in range(8):
        obs, _ = env.reset(seed=seed)
        truncated = False
        while not truncated:
            obs, _, _, truncated, info = env.step(controller(obs))
        rms.append(info["tracking_rms"])
    assert max(rms) < 1e-3, rms


def test_a_lagging_controller_is_measurably_worse_than_the_feed_forward_oracle():
    env = gym.make("cdcr_gym/CCKATrack-v0")
    oracle = TrackingIKController.from_env(env)
    lagging = TrackingIKController.from_env(env)
    lagging.timestep = 1e-12  # IK on the current target only
    out = []
    for c in (oracle, lagging):
        obs, _ = env.reset(seed=1)
        truncated = False
        while not truncated:
            obs, _, _, truncated, info = env.step(c(obs))
        out.append(info["tracking_rms"])
    assert out[0] < 0.1 * out[1]
    # lag = one step of the target: speed · dt = 1 mm by default
    assert out[1] == pytest.approx(0.05 * NOMINAL_TIMESTEP, rel=0.05)


def test_bullet_target_uses_the_backend_control_timestep():
    env = gym.make("cdcr_gym/BulletTrack-v0", gravity=False, control_timestep=0.04)
    env.reset(seed=0)
    assert env.unwrapped.task.dt == 0.04
    controller = TrackingIKController.from_env(env)
    assert controller.timestep == 0.04


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"speed": 0.0}, "speed"),
        ({"speed": float("nan")}, "speed"),
        ({"settle_steps": -1}, "settle_steps"),
        ({"n_waypoints": 2}, "n_waypoints"),
        ({"timestep": -0.1}, "timestep"),
        ({"distance_threshold": 0}, "distance_threshold"),
        ({"goal_conditioned": True}, "goal_conditioned"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("cdcr_gym/CCKATrack-v0", **kwargs)


def test_a_goal_option_is_refused():
    env = gym.make("cdcr_gym/CCKATrack-v0")
    with pytest.raises(ValueError, match="goal"):
        env.reset(seed=0, options={"goal": [0, 0, 0.6]})


def test_docstring_lists_the_arguments_and_the_observation_table():
    doc = inspect.getdoc(Track)
    for name in inspect.signature(Track.__init__).parameters:
        if name != "self":
            assert f"{name}:" in doc, name
    env = gym.make("cdcr_gym/CCKATrack-v0")
    assert env.unwrapped.observation_spec.table() in doc


def test_render_draws_the_target():
    env = gym.make(
        "cdcr_gym/CCKATrack-v0", render_mode="rgb_array", render_width=160, render_height=160
    )
    env.reset(seed=0)
    task = env.unwrapped.task
    task.target[0] = [0.3, 0.0, 0.3]  # beside the straight robot
    with_target = env.render()
    task.target[0] = [0.0, 0.0, 10.0]  # far out of view
    without = env.render()
    assert with_target.shape == (160, 160, 3)
    assert np.sum(np.any(with_target != without, axis=-1)) > 5  # a ~10 mm sphere: ~10 px
