"""Every registered id × robot preset: Gymnasium/SB3 contracts, determinism, spaces, oracle."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import cdcr_gym
from cdcr_gym.controllers import AnalyticIKController
from cdcr_gym.params import RobotParams

IDS = ["cdcr_gym/CCKAReach-v0", "cdcr_gym/BulletReach-v0", "cdcr_gym/MuJoCoReach-v0"]
ROBOTS = ["paper", "tdcr2"]
#: every (id, robot) the release supports
COMBOS = [(i, r) for i in IDS for r in ROBOTS]


def _make(env_id, robot, **kwargs):
    if env_id.startswith("cdcr_gym/Bullet"):
        kwargs.setdefault("gravity", False)
    return gym.make(env_id, robot=robot, **kwargs)


@pytest.mark.parametrize("goal_conditioned", [False, True])
@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_check_env_passes_for_every_id_and_robot(env_id, robot, goal_conditioned):
    env = _make(env_id, robot, goal_conditioned=goal_conditioned)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)
    env.close()


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_action_has_one_entry_per_cable_and_obs_stay_in_space(env_id, robot):
    env = _make(env_id, robot, action_mode="tension", initial_state="random")
    params = RobotParams.preset(robot)
    assert env.action_space.shape == (params.n_cables,)
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=1)
    assert info["tensions"].shape == info["cable_lengths"].shape == (params.n_cables,)
    for _ in range(30):
        # extreme actions: every cable at 0 or max tension
        action = rng.choice([-1.0, 1.0], size=params.n_cables).astype(np.float32)
        obs, *_ = env.step(action)
        assert env.observation_space.contains(obs), obs
    env.close()


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_same_seed_and_actions_give_identical_trajectories(env_id, robot):
    def rollout():
        env = _make(env_id, robot, initial_state="random")
        obs, info = env.reset(seed=5)
        rows = [obs]
        rng = np.random.default_rng(3)
        for _ in range(10):
            obs, reward, *_ = env.step(
                env.action_space.sample() * 0
                + rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            )
            rows.append(np.append(obs, reward))
        env.close()
        return np.concatenate(rows)

    assert np.array_equal(rollout(), rollout())


@pytest.mark.parametrize("mode", ["tension", "tension_delta", "length_delta"])
def test_ik_oracle_reaches_every_sampled_tdcr2_goal_on_ccka(mode):
    env = gym.make("cdcr_gym/CCKAReach-v0", robot="tdcr2", action_mode=mode, max_episode_steps=400)
    controller = AnalyticIKController.from_env(env)
    worst = 0.0
    for seed in range(100 if mode == "tension" else 15):
        obs, info = env.reset(seed=seed)
        for _ in range(400):
            obs, _, _, truncated, info = env.step(controller(obs))
            if info["distance"] < 1e-7 or truncated:
                break
        worst = max(worst, info["distance"])
    assert worst < 1e-6


@pytest.mark.parametrize(
    "action",
    ["abc", {"a": 1}, np.array([1j, 0, 0, 0, 0, 0]), [0.0] * 5, np.array(["1"] * 6)],
)
def test_non_real_or_misshapen_actions_raise_value_error_naming_action(action):
    env = gym.make("cdcr_gym/CCKAReach-v0", robot="tdcr2")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.unwrapped.step(action)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"robot": "tdcr3"}, "robot"),
        ({"robot": "paper", "params": RobotParams()}, "robot"),
        ({"gravty": True}, "gravty"),
        ({"params": {"length": 1.0}}, "params"),
    ],
)
def test_bad_make_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("cdcr_gym/CCKAReach-v0", **kwargs)


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/MuJoCoReach-v0"])
def test_batched_env_matches_single_envs_for_tdcr2(env_id):
    n = 3
    venv = gym.make_vec(
        env_id,
        num_envs=n,
        robot="tdcr2",
        vectorization_mode="vector_entry_point",
        initial_state="random",
    )
    envs = [gym.make(env_id, robot="tdcr2", initial_state="random") for _ in range(n)]
    obs_v, _ = venv.reset(seed=9)
    obs_s = [e.reset(seed=9 + i)[0] for i, e in enumerate(envs)]
    np.testing.assert_allclose(obs_v, np.stack(obs_s), rtol=0, atol=1e-6)
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, (n, 6)).astype(np.float32)
        obs_v, r_v, *_ = venv.step(a)
        outs = [e.step(a[i]) for i, e in enumerate(envs)]
        np.testing.assert_allclose(obs_v, np.stack([o[0] for o in outs]), rtol=0, atol=1e-6)
        np.testing.assert_allclose(r_v, [o[1] for o in outs], rtol=0, atol=1e-12)


def test_all_ids_registered_from_the_table():
    for env_id in IDS:
        assert env_id in gym.registry
        assert gym.registry[env_id].max_episode_steps == cdcr_gym.MAX_EPISODE_STEPS


def test_ccka_env_pickles_and_the_copy_is_independent():
    env = gym.make("cdcr_gym/CCKAReach-v0", robot="tdcr2")
    env.reset(seed=0)
    copy = pickle.loads(pickle.dumps(env))
    a = np.ones(6, dtype=np.float32)
    obs_copy = copy.step(a)[0]
    obs_orig = env.step(np.zeros(6, dtype=np.float32))[0]
    assert not np.array_equal(obs_copy, obs_orig)
