"""Drive softening (``cdcr_gym.model.drive_softening``, the env option ``drive_softening``): the
map and its inverse, an env whose drives pull by tanh(σy)/σ is the plain env commanded with the
softened pulls, its resets rest and its goals are held, and the reach oracle inverts the map."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the envs)
from cdcr_gym.controllers import AnalyticIKController
from cdcr_gym.model.drive_softening import check_rate, command_for_pull, soften

PARAMS = "docs/figures/calibration/ftdcr_v4_ccka/params.yaml"  # the CCKA twin of the oracle tests
RATE = 27.0  # 1/m: d_s = 37 mm, what the v4 training rows give


def _env(mode: str = "displacement", **kwargs):
    return gym.make("cdcr_gym/CCKAReach-v0", params=PARAMS, action_mode=mode, **kwargs)


def _action(d: np.ndarray, low: float, high: float) -> np.ndarray:
    return (2.0 * (d - low) / (high - low) - 1.0).astype(np.float32)


def test_the_map_saturates_pulls_and_inverts():
    y = np.array([-0.01, -1e-4, 0.0, 1e-4, 0.005, 0.0124, 0.05])
    t = soften(y, RATE)
    np.testing.assert_array_equal(t[y <= 0.0], y[y <= 0.0])  # released: unchanged
    pulled = y > 0.0
    np.testing.assert_allclose(t[pulled], np.tanh(RATE * y[pulled]) / RATE, rtol=1e-15)
    assert np.all(t[pulled] < y[pulled]) and np.all(np.diff(t) > 0.0)
    assert t[-1] < 1.0 / RATE
    # 12.4 mm, the v4 file's largest pull, loses 3.6 %
    assert t[5] / y[5] == pytest.approx(0.964, abs=1e-3)
    np.testing.assert_allclose(command_for_pull(t, RATE), y, rtol=1e-12, atol=1e-18)
    np.testing.assert_array_equal(soften(y, 0.0), y)
    np.testing.assert_array_equal(command_for_pull(y, 0.0), y)


def test_a_pull_no_command_reaches_is_refused():
    with pytest.raises(ValueError, match="beyond every command"):
        command_for_pull(np.array([0.01, 1.0 / RATE]), RATE)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), "27", True])
def test_bad_rates_name_the_argument(bad):
    with pytest.raises(ValueError, match="drive_softening"):
        check_rate(bad)
    with pytest.raises(ValueError, match="drive_softening"):
        _env(drive_softening=bad)


def test_softening_needs_a_displacement_mode():
    with pytest.raises(ValueError, match="displacement action mode"):
        _env("tension_delta", drive_softening=RATE)


def test_env_is_the_plain_env_commanded_with_the_pulls():
    """Each step the tendons take tanh(σy)/σ of the commanded y (info ``tendon_displacements``),
    behind the drives' play; the robot is the plain one commanded with those pulls."""
    env, plain = _env(drive_softening=RATE, drive_backlash=2e-4), _env()
    low, high = env.unwrapped.params.displacement_range
    try:
        env.reset(seed=0)
        plain.reset(seed=0)
        rng = np.random.default_rng(1)
        for _ in range(8):
            _, _, _, _, info = env.step(rng.uniform(-1.0, 0.4, 9).astype(np.float32))
            pulls = info["tendon_displacements"]
            assert np.all(pulls <= soften(info["displacements"] + 1e-4, RATE) + 1e-15)
            _, _, _, _, info_plain = plain.step(_action(pulls, low, high))
            # (the plain env's actions are float32: its commands differ by ~1e-9 m)
            np.testing.assert_allclose(info["tensions"], info_plain["tensions"], atol=1e-5)
            np.testing.assert_allclose(info["tip"], info_plain["tip"], atol=1e-7)
        assert np.any(info["displacements"] > 0.005)  # some hard pulls: the map bit
    finally:
        env.close()
        plain.close()


@pytest.mark.parametrize("mode", ["displacement", "displacement_delta"])
def test_a_random_start_rests(mode):
    """A reset commands the displacements whose softened pulls hold its shape: holding them
    leaves the robot where it is. A start the drives cannot hold (seed 1: a pull of 12.47 mm,
    beyond the softened range's 12.32 mm) is rested under the range's end instead."""
    env = _env(mode, drive_softening=RATE, initial_state="random")
    low, high = env.unwrapped.params.displacement_range
    at_the_end = []
    try:
        for seed in range(3):
            _, info = env.reset(seed=seed)
            at_the_end.append(np.isclose(info["displacements"], high, rtol=0, atol=1e-12).any())
            start, tip = info["tensions"].copy(), info["tip"].copy()
            assert start.sum() > 5.0
            hold = _action(info["displacements"], low, high) if mode == "displacement" else None
            _, _, _, _, info = env.step(np.zeros(9, np.float32) if hold is None else hold)
            np.testing.assert_allclose(info["tensions"], start, atol=1e-6)
            np.testing.assert_allclose(info["tip"], tip, atol=1e-8)
        assert at_the_end == [False, True, False]
    finally:
        env.close()


def test_initial_displacements_are_commands():
    """``options['initial_displacements']`` are commands: the robot rests under their pulls."""
    env, plain = _env(drive_softening=RATE), _env()
    d = np.array([0.0, 0.002, 0.0, 0.008, 0.0, 0.0, 0.0, 0.009, 0.0])
    try:
        _, info = env.reset(seed=0, options={"initial_displacements": d})
        _, info_plain = plain.reset(seed=0, options={"initial_displacements": soften(d, RATE)})
        np.testing.assert_allclose(info["tip"], info_plain["tip"], atol=1e-9)
    finally:
        env.close()
        plain.close()


@pytest.mark.parametrize("feedback", [False, True])
def test_the_reach_oracle_inverts_the_softening(feedback):
    """The drive IK solves for the pulls within the softened range and commands the
    displacements that give them: the goals, held by the drives, are reached exactly; an
    oracle that ignores the softening misses them."""
    env = _env("displacement_delta", drive_softening=RATE, displacement_step=0.001)
    oracle = AnalyticIKController.from_env(env, feedback=feedback)
    assert oracle.drive_softening == RATE
    naive = AnalyticIKController(
        env.unwrapped.params,
        env.unwrapped.observation_spec,
        "displacement_delta",
        displacement_step=0.001,
    )
    try:
        missed = []
        for seed in range(1_000_000, 1_000_004):
            for controller in (oracle, naive):
                obs, info = env.reset(seed=seed)
                for _ in range(60):
                    obs, _, _, _, info = env.step(controller(obs))
                if controller is oracle:
                    assert info["distance"] < 1e-4, seed
                else:
                    missed.append(info["distance"])
        if not feedback:
            assert max(missed) > 1e-3
    finally:
        env.close()


def test_the_mujoco_twin_of_a_softened_fit_rests_and_pulls_softened():
    """The twin of the MuJoCo fit with a drive softening (``twin_kwargs_from_yaml``): its drives
    soften (info ``tendon_displacements``), a random start rests under the commands the reset
    holds, and the observed commands are the held ones."""
    pytest.importorskip("mujoco")
    from cdcr_gym.calibration import twin_kwargs_from_yaml

    fit = "docs/figures/calibration/ftdcr_v4_mujoco_softening/params.yaml"
    kw = twin_kwargs_from_yaml(fit)
    assert kw["drive_softening"] > 10.0
    env = gym.make("cdcr_gym/MuJoCoReach-v0", params=fit, initial_state="random", **kw)
    low, high = env.unwrapped.params.displacement_range
    try:
        for seed in range(4):
            _, info = env.reset(seed=seed)
            tip = info["tip"].copy()
            _, _, _, _, info = env.step(_action(info["displacements"], low, high))
            np.testing.assert_allclose(  # (the float32 action: within 1e-8 m of the reset's)
                info["tendon_displacements"],
                soften(info["displacements"], kw["drive_softening"]),
                atol=1e-8,
            )
            assert np.linalg.norm(info["tip"] - tip) < 1e-9  # measured: <= 3e-13 m
    finally:
        env.close()


def test_info_pulls_are_a_copy_of_the_env_state():
    """Mutating ``info["tendon_displacements"]`` (backlash only: the map is the identity) leaves
    the drives' state alone."""
    env = _env(drive_backlash=1e-3)
    try:
        env.reset(seed=0)
        _, _, _, _, info = env.step(np.zeros(9, np.float32))
        state = env.unwrapped.core._tendon_displacements
        info["tendon_displacements"][:] = 1.0
        assert not np.any(state == 1.0)
    finally:
        env.close()
