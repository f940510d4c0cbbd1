"""Issue 23, env side: observations stay in their Box under domain randomisation (item 2),
errors that name what is wrong (item 4: reset options, a tip payload the robot cannot hold),
and bool arrays refused as actions (item 5). Each test failed on the main of the time."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)

CCKA = "cdcr_gym/CCKAReach-v0"


# 23.2: every randomisation range is checked like the nominal robot ----------------------------
@pytest.mark.parametrize(
    "randomize, key",
    [
        ({"youngs_modulus": [5e9, 6e9]}, "youngs_modulus"),
        ({"cable_radius": [0.05, 0.1]}, "cable_radius"),
        ({"youngs_modulus": [18e9, 35e9], "cable_radius": [0.029, 0.04]}, "cable_radius"),
    ],
)
@pytest.mark.parametrize("env_id", [CCKA, "cdcr_gym/CCKAPose-v0"])
def test_randomisation_ranges_whose_extreme_robot_is_invalid_are_refused(randomize, key, env_id):
    low, high = randomize[key]
    with pytest.raises(ValueError, match=rf"randomize\['{key}'\]=\[{low!r}, {high!r}\]"):
        gym.make(env_id, randomize=randomize)


def test_the_vector_env_refuses_the_same_ranges():
    with pytest.raises(ValueError, match=r"randomize\['youngs_modulus'\]"):
        gym.make_vec(
            CCKA,
            num_envs=2,
            vectorization_mode="vector_entry_point",
            randomize={"youngs_modulus": [5e9, 6e9]},
        )


#: The most compliant paper robot the checks accept: softest E, widest routing (fixed values
#: at the extremes of allowed ranges).
EXTREME = {"youngs_modulus": 18e9, "cable_radius": 0.0305}


def _pulls(n_cables: int) -> list[np.ndarray]:
    """Absolute-tension actions pulling each cable, and each pair, to max_tension."""
    out = []
    for i in range(n_cables):
        for j in range(i, n_cables):
            a = -np.ones(n_cables, dtype=np.float32)
            a[[i, j]] = 1.0
            out.append(a)
    return out


@pytest.mark.parametrize("mode", ["tension", "length_delta"])
def test_randomised_envs_at_the_range_extremes_keep_observations_in_their_box(mode):
    env = gym.make(CCKA, action_mode=mode, randomize=EXTREME)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    rng = np.random.default_rng(0)
    actions = _pulls(3) * 3 if mode == "tension" else [np.ones(3, np.float32)] * 200
    actions += list(rng.uniform(-1, 1, (50, 3)).astype(np.float32))
    for a in actions:
        obs, *_ = env.step(a)
        assert env.observation_space.contains(obs), (a, obs)
    env.close()


def test_the_vector_env_at_the_range_extremes_keeps_observations_in_their_box():
    env = gym.make_vec(
        CCKA,
        num_envs=6,
        vectorization_mode="vector_entry_point",
        action_mode="tension",
        randomize={"youngs_modulus": [18e9, 35e9], "cable_radius": [0.028, 0.0305]},
    )
    obs, _ = env.reset(seed=3)
    for a in _pulls(3) * 4:
        obs, *_ = env.step(np.tile(a, (6, 1)))
        assert env.observation_space.contains(obs)
    env.close()


# 23.4: errors that name what is wrong -------------------------------------------------------
@pytest.mark.parametrize("options", ["goal", 5, ["goal"]])
def test_reset_options_that_are_not_a_mapping_raise_value_error_naming_options(options):
    env = gym.make(CCKA)
    with pytest.raises(ValueError, match="options must be None or a dict"):
        env.reset(seed=0, options=options)
    venv = gym.make_vec(CCKA, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="options must be None or a dict"):
        venv.reset(seed=0, options=options)


def test_unknown_reset_options_are_named():
    env = gym.make(CCKA)
    with pytest.raises(ValueError, match="unknown keys \\['gaol'\\]"):
        env.reset(seed=0, options={"gaol": [0.1, 0.1, 0.5]})


def test_a_tip_payload_the_robot_cannot_hold_is_refused_naming_it():
    pytest.importorskip("pybullet")
    with pytest.raises(ValueError, match=r"tip_payload=1\.5 kg"):
        gym.make("cdcr_gym/BulletReach-v0", tip_payload=1.5)


def test_a_tip_payload_the_robot_holds_still_works():
    pytest.importorskip("pybullet")
    env = gym.make("cdcr_gym/BulletReach-v0", tip_payload=0.5)
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        assert env.observation_space.contains(obs)
    env.close()


# 23.5: bool arrays are not actions ----------------------------------------------------------
@pytest.mark.parametrize("action", [np.array([True, False, True]), [True, False, True]])
def test_bool_actions_raise_value_error_naming_action(action):
    env = gym.make(CCKA)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    venv = gym.make_vec(CCKA, num_envs=2, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        venv.step(np.array([action, action]))


@pytest.mark.parametrize(
    "action",
    [
        np.array([1, 0, -1]),
        np.array([0.5, 0.0, -0.25], dtype=np.float64),
        np.array([0.5, 0.0, -0.25], dtype=np.float32),
        [0.5, 0, -1],
    ],
)
def test_int_and_float_actions_keep_working(action):
    env = gym.make(CCKA)
    env.reset(seed=0)
    obs, *_ = env.step(action)
    assert env.observation_space.contains(obs)
