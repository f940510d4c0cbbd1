"""Domain randomisation and sensor/actuator imperfections (cdcr_gym.randomization) in the envs.

Statistics are checked with tolerances of several standard errors of the estimate, on fixed
seeds (deterministic), so a wrong σ, a wrong mean or a missing bias fails.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from test_vector import run_equivalence

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.params import RobotParams
from cdcr_gym.randomization import INFO_PREFIX, RANDOMIZABLE

CCKA = "cdcr_gym/CCKAReach-v0"
FULL_DR = {
    "youngs_modulus": [30e9, 40e9],
    "cable_radius": [0.027, 0.031],
    "backbone_density": [1700.0, 2100.0],
    "disk_mass": [0.008, 0.012],
    "tip_payload": [0.0, 0.05],
    "friction_coefficient": [0.0, 0.3],
    "base_tilt": [0.0, 0.2],
    "gravity": 0.5,
}
FULL_IMPERFECTIONS = {
    "tip_noise": 0.001,
    "tip_bias": 0.002,
    "cable_length_noise": 1e-4,
    "cable_length_bias": 1e-4,
    "tension_noise": 0.5,
    "tension_bias": 0.5,
    "action_delay": 2,
    "tension_lag": 1.5,
    "tension_response": 0.6,
    "tension_rate_limit": 3.0,
    "actuator_noise": 0.3,
}


def _randomized(info):
    return {k[len(INFO_PREFIX) :]: v for k, v in info.items() if k.startswith(INFO_PREFIX)}


def _trajectory(env, seed, actions):
    obs, info = env.reset(seed=seed)
    out = [obs.copy()]
    for a in actions:
        obs, _, _, _, info = env.step(a)
        out.append(np.concatenate([obs, info["tensions"], info["tip"]]))
    return out


@pytest.mark.parametrize(
    "off",
    [
        {},
        {"randomize": None, "imperfections": None},
        {"randomize": {}, "imperfections": {"tip_noise": 0.0, "action_delay": 0}},
    ],
)
def test_off_is_bit_identical(off):
    actions = np.random.default_rng(0).uniform(-1, 1, (30, 3)).astype(np.float32)
    plain = _trajectory(gym.make(CCKA, initial_state="random"), 5, actions)
    other = _trajectory(gym.make(CCKA, initial_state="random", **off), 5, actions)
    for a, b in zip(plain, other):
        assert np.array_equal(a, b)


def test_ranges_respected_seeded_and_reported():
    env = gym.make(CCKA, randomize=FULL_DR)
    draws = []
    for k in range(300):
        _, info = env.reset(seed=k)
        draws.append(_randomized(info))
    assert set(draws[0]) == set(FULL_DR) | {"base_tilt_azimuth"}
    for name, spec in FULL_DR.items():
        values = np.array([d[name] for d in draws])
        if name == "gravity":
            assert set(values) == {0.0, 1.0}
            assert 0.4 < values.mean() < 0.6
            continue
        lo, hi = spec
        assert values.min() >= lo and values.max() <= hi
        # uniform: spans the range
        assert values.min() < lo + 0.05 * (hi - lo) and values.max() > hi - 0.05 * (hi - lo)
    az = np.array([d["base_tilt_azimuth"] for d in draws])
    assert az.min() >= 0 and az.max() < 2 * np.pi
    # same seed -> same parameters; the values stay in info through the episode
    again = gym.make(CCKA, randomize=FULL_DR)
    _, info = again.reset(seed=17)
    assert _randomized(info) == draws[17]
    _, _, _, _, info = again.step(again.action_space.sample())
    assert _randomized(info) == draws[17]
    # a fixed value draws nothing and is reported as given
    _, info = gym.make(CCKA, randomize={"youngs_modulus": 33e9}).reset(seed=1)
    assert _randomized(info) == {"youngs_modulus": 33e9}


def test_vector_env_draws_what_the_single_envs_draw():
    vec = gym.make_vec(CCKA, num_envs=4, vectorization_mode="vector_entry_point", randomize=FULL_DR)
    _, info = vec.reset(seed=40)
    for i in range(4):
        _, single = gym.make(CCKA, randomize=FULL_DR).reset(seed=40 + i)
        for name, value in _randomized(single).items():
            assert info[INFO_PREFIX + name][i] == value


def test_everything_on_batched_equals_sync_across_autoresets():
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        ends = run_equivalence(
            3,
            60,
            seed=2,
            autoreset_mode=mode,
            max_episode_steps=25,
            initial_state="random",
            randomize=FULL_DR,
            imperfections=FULL_IMPERFECTIONS,
        )
        assert ends >= 6


def test_randomized_stiffness_and_radius_act_like_that_robot():
    env = gym.make(
        CCKA,
        action_mode="tension",
        randomize={k: FULL_DR[k] for k in ("youngs_modulus", "cable_radius")},
    )
    for seed in range(5):
        _, info = env.reset(seed=seed)
        drawn = _randomized(info)
        a = np.array([0.3, -0.8, -0.1], dtype=np.float32)
        _, _, _, _, info = env.step(a)
        robot = AnalyticBackend(
            RobotParams(youngs_modulus=drawn["youngs_modulus"], cable_radius=drawn["cable_radius"])
        )
        robot.apply_tensions(info["tensions"][None])
        truth = robot.read()
        np.testing.assert_allclose(info["tip"], truth.tip[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            info["cable_lengths"], truth.cable_lengths[0], rtol=0, atol=1e-12
        )
    # and the nominal robot differs (the draw did something)
    nominal = AnalyticBackend()
    nominal.apply_tensions(info["tensions"][None])
    assert np.linalg.norm(nominal.read().tip[0] - info["tip"]) > 1e-4


def test_length_control_with_randomized_robot_reports_its_tensions():
    env = gym.make(CCKA, action_mode="length_delta", randomize={"youngs_modulus": [20e9, 21e9]})
    env.reset(seed=0)
    for _ in range(5):
        _, _, _, _, info = env.step(np.array([1.0, -1.0, 0.0], dtype=np.float32))
    robot = AnalyticBackend(RobotParams(youngs_modulus=_randomized(info)["youngs_modulus"]))
    robot.apply_tensions(info["tensions"][None])
    np.testing.assert_allclose(robot.read().tip[0], info["tip"], rtol=0, atol=1e-9)


def _noise_run(imperfections, episodes, steps, seed=0):
    env = gym.make(
        CCKA, imperfections=imperfections, initial_state="random", max_episode_steps=steps + 1
    )
    rng = np.random.default_rng(seed)
    errors = []  # (episode, step, channel)
    for ep in range(episodes):
        obs, info = env.reset(seed=seed + ep)
        rows = []
        for _ in range(steps):
            obs, _, _, _, info = env.step(rng.uniform(-0.2, 0.2, 3).astype(np.float32))
            tip_err = obs[0:3] - info["tip"]
            t_err = obs[12:15] * 80.0 - info["tensions"]
            rows.append(np.concatenate([tip_err, t_err]))
        errors.append(rows)
    return np.array(errors)


def test_observation_noise_statistics():
    e = _noise_run({"tip_noise": 0.002, "tension_noise": 1.5}, episodes=4, steps=500)
    tip, ten = e[..., :3].ravel(), e[..., 3:].ravel()
    # where the tension is clipped at 0 (straight or slack cables) the noise saturates: use the rest
    n = tip.size
    assert abs(tip.mean()) < 4 * 0.002 / np.sqrt(n)
    assert tip.std() == pytest.approx(0.002, rel=0.05)
    live = np.abs(ten) < 8  # clipped readings (true tension near 0) are excluded by the 0 floor
    assert abs(ten[live].mean()) < 0.1
    assert ten[live].std() == pytest.approx(1.5, rel=0.1)


def test_per_episode_bias_statistics():
    e = _noise_run({"tip_bias": 0.003}, episodes=200, steps=5)
    # x and y (z saturates at the observation bound ℓ when the robot is nearly straight)
    per_episode = e[..., :2]
    # constant within an episode, and not zero
    assert np.allclose(per_episode, per_episode[:, :1], atol=2e-7)
    biases = per_episode[:, 0].ravel()
    assert abs(biases.mean()) < 4 * 0.003 / np.sqrt(biases.size)
    assert biases.std() == pytest.approx(0.003, rel=0.1)


def test_noise_acts_on_observations_not_on_reward_or_physics():
    actions = np.random.default_rng(1).uniform(-1, 1, (20, 3)).astype(np.float32)
    clean, noisy = (
        gym.make(CCKA),
        gym.make(CCKA, imperfections={"tip_noise": 0.01, "tip_bias": 0.01}),
    )
    goal = {"goal": [0.1, 0.05, 0.6]}  # given: the bias draw would come before the goal's draw
    clean.reset(seed=3, options=goal)
    noisy.reset(seed=3, options=goal)
    for a in actions:
        o1, r1, _, _, i1 = clean.step(a)
        o2, r2, _, _, i2 = noisy.step(a)
        assert r1 == r2 and np.array_equal(i1["tip"], i2["tip"])
        assert not np.array_equal(o1[:3], o2[:3])


@pytest.mark.parametrize("mode", ["tension", "tension_delta", "length_delta"])
def test_action_delay_shifts_actions_by_exactly_k_steps(mode):
    k = 3
    rng = np.random.default_rng(4)
    actions = rng.uniform(-1, 1, (25, 3)).astype(np.float32)
    plain = gym.make(CCKA, action_mode=mode)
    delayed = gym.make(CCKA, action_mode=mode, imperfections={"action_delay": k})
    _, i0 = plain.reset(seed=9, options={"initial_tensions": [10.0, 30.0, 0.0]})
    delayed.reset(seed=9, options={"initial_tensions": [10.0, 30.0, 0.0]})
    # the plain env is fed k "hold" actions first (the delay queue's reset content)
    hold = np.zeros(3, np.float32)
    if mode == "tension":
        hold = (2 * i0["tensions"] / 80.0 - 1).astype(np.float32)
    shifted = np.concatenate([np.repeat(hold[None], k, 0), actions[:-k]])
    for a, b in zip(actions, shifted):
        _, _, _, _, di = delayed.step(a)
        _, _, _, _, pi = plain.step(b)
        np.testing.assert_allclose(di["tensions"], pi["tensions"], rtol=0, atol=1e-5)
        np.testing.assert_allclose(di["tip"], pi["tip"], rtol=0, atol=1e-7)


def test_tension_rate_limit_and_lag():
    env = gym.make(CCKA, action_mode="tension", imperfections={"tension_rate_limit": 2.5})
    env.reset(seed=0)
    seen = [np.zeros(3)]
    rng = np.random.default_rng(0)
    for a in [np.ones(3)] * 5 + list(rng.uniform(-1, 1, (40, 3))):
        _, _, _, _, info = env.step(np.asarray(a, np.float32))
        seen.append(info["tensions"].copy())
    steps = np.abs(np.diff(seen, axis=0))
    assert steps.max() <= 2.5 + 1e-12
    np.testing.assert_allclose(seen[5], 12.5)  # 5 steps at the limit from 0 towards 80 N
    tau = 2.0
    _check_settling({"tension_lag": tau}, lambda k: 1 - np.exp(-k / tau))


def _check_settling(imperfections, fraction):
    """The actuators report the commanded 40 N at once; the shape is the static shape of
    40 N·fraction(k) after k steps."""
    env = gym.make(CCKA, action_mode="tension", imperfections=imperfections)
    env.reset(seed=0)
    robot = AnalyticBackend()
    action = np.array([0.0, -1.0, -1.0], np.float32)  # 40 N on cable 1
    for k in range(1, 12):
        _, _, _, _, info = env.step(action)
        assert np.array_equal(info["tensions"], [40.0, 0.0, 0.0])
        robot.apply_tensions(np.array([[40.0 * fraction(k), 0.0, 0.0]]))
        np.testing.assert_allclose(info["tip"], robot.read().tip[0], rtol=0, atol=1e-12)
    assert np.linalg.norm(info["tip"] - [0, 0, 0.641]) > 0.1  # it did bend


def test_second_order_tension_response_is_critically_damped():
    w = 0.44
    _check_settling({"tension_response": w}, lambda k: 1 - (1 + w * k) * np.exp(-w * k))


def test_actuator_noise_statistics():
    sigma = 0.8
    env = gym.make(
        CCKA, action_mode="tension", imperfections={"actuator_noise": sigma}, max_episode_steps=3000
    )
    env.reset(seed=0)
    applied = np.array([env.step(np.zeros(3, np.float32))[4]["tensions"] for _ in range(2000)])
    dev = applied - 40.0
    assert abs(dev.mean()) < 4 * sigma / np.sqrt(dev.size)
    assert dev.std() == pytest.approx(sigma, rel=0.05)


def test_check_env_with_everything_on():
    for kwargs in ({}, {"action_mode": "tension"}, {"goal_conditioned": True}):
        env = gym.make(CCKA, randomize=FULL_DR, imperfections=FULL_IMPERFECTIONS, **kwargs)
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)


@pytest.mark.parametrize(
    ("randomize", "match"),
    [
        ({"youngs_modulus": [40e9, 30e9]}, r"randomize\['youngs_modulus'\]"),
        ({"youngs_modulus": [0.0, 30e9]}, r"randomize\['youngs_modulus'\]"),
        ({"cable_radius": [0.03]}, r"randomize\['cable_radius'\]"),
        ({"disk_mass": [-0.1, 0.1]}, r"randomize\['disk_mass'\]"),
        ({"friction_coefficient": [0.0, 2.0]}, r"randomize\['friction_coefficient'\]"),
        ({"base_tilt": [0.0, 4.0]}, r"randomize\['base_tilt'\]"),
        ({"gravity": 1.5}, r"randomize\['gravity'\]"),
        ({"tip_payload": [0.0, float("nan")]}, r"randomize\['tip_payload'\]"),
        ({"tip_payload": ["a", 1.0]}, r"randomize\['tip_payload'\]"),
        ({"youngs_modulos": [30e9, 40e9]}, "did you mean 'youngs_modulus'"),
        ([("youngs_modulus", 1.0)], "randomize must be a mapping"),
    ],
)
def test_bad_randomize_is_a_named_value_error(randomize, match):
    with pytest.raises(ValueError, match=match):
        gym.make(CCKA, randomize=randomize)


@pytest.mark.parametrize(
    ("imperfections", "kwargs", "match"),
    [
        ({"tip_noise": -0.001}, {}, r"imperfections\['tip_noise'\]"),
        ({"tension_bias": float("inf")}, {}, r"imperfections\['tension_bias'\]"),
        ({"action_delay": 1.5}, {}, r"imperfections\['action_delay'\]"),
        ({"action_delay": -1}, {}, r"imperfections\['action_delay'\]"),
        ({"tension_rate_limit": 0.0}, {}, r"imperfections\['tension_rate_limit'\]"),
        ({"tension_lag": -2.0}, {}, r"imperfections\['tension_lag'\]"),
        ({"tension_response": 0.0}, {}, r"imperfections\['tension_response'\]"),
        (
            {"actuator_noise": 0.1},
            {"action_mode": "length_delta"},
            r"imperfections\['actuator_noise'\]",
        ),
        ({"tip_nosie": 0.1}, {}, "did you mean 'tip_noise'"),
    ],
)
def test_bad_imperfections_are_named_value_errors(imperfections, kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(CCKA, imperfections=imperfections, **kwargs)


def test_randomizable_table_is_documented():
    import cdcr_gym.randomization as R

    for name in (*RANDOMIZABLE, *R.IMPERFECTIONS):
        assert f"``{name}``" in R.__doc__
