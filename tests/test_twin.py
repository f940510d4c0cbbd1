"""The calibrated twin: ``gym.make`` with a fitted params.yaml in displacement mode, and goals
the drives can reach (configs/twin_ftdcr_v4_reach.yaml; docs/sim2real.md "Train on the
calibrated twin")."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import cdcr_gym  # noqa: F401  (registers the envs)
from cdcr_gym.backends import AnalyticBackend
from cdcr_gym.calibration.report import backend_kwargs_from_yaml, load_fitted
from cdcr_gym.tasks.reach import Reach

ROOT = Path(__file__).resolve().parents[1]
FIT = ROOT / "docs" / "figures" / "calibration" / "ftdcr_v4_ccka" / "params.yaml"


def test_gym_make_builds_the_fitted_robot_on_mujoco_in_displacement_mode() -> None:
    path = str(FIT)
    env = gym.make(
        "cdcr_gym/MuJoCoReach-v0",
        params=path,
        action_mode="displacement",
        **backend_kwargs_from_yaml(path),
    )
    try:
        fitted, backend_kwargs = load_fitted(path)
        robot = yaml.safe_load(FIT.read_text())["robot"]
        p = env.unwrapped.params
        assert p == fitted
        assert p.n_sections == 3 and p.n_cables == 9
        np.testing.assert_allclose(
            [s.length for s in p.sections], [s["length"] for s in robot["sections"]], rtol=1e-12
        )
        np.testing.assert_allclose(p.cable_stiffness, robot["tendon_stiffness"], rtol=1e-12)
        np.testing.assert_allclose(p.cable_pretension, robot["tendon_pretension"], atol=1e-15)
        assert tuple(p.displacement_range) == tuple(robot["displacement_range"])
        assert env.action_space.shape == (9,)
        _, info = env.reset(seed=0)
        for _ in range(3):
            obs, reward, term, trunc, info = env.step(np.zeros(9, dtype=np.float32))
        assert np.isfinite(obs).all() and np.isfinite(reward)
        for key in ("distance", "is_success", "goal", "tip", "tensions", "displacements"):
            assert key in info
        assert info["displacements"].shape == (9,)
        assert info["slack"].shape == info["saturated"].shape == (9,)
        lo, hi = p.displacement_range
        assert np.all((info["displacements"] >= lo) & (info["displacements"] <= hi))
        # action 0 holds the middle of the range (the absolute displacement mode)
        np.testing.assert_allclose(info["displacements"], 0.5 * (lo + hi), atol=1e-12)
        assert np.all((info["tensions"] >= 0.0) & (info["tensions"] <= p.max_tension + 1e-9))
        assert 0.0 <= info["distance"] < 2.0 * p.length
    finally:
        env.close()


@pytest.mark.parametrize(
    "text",
    [None, "robot: [1, 2\n", "robot:\n  no_such_field: 1\n", "- 1\n"],
    ids=["missing", "not-yaml", "unknown-key", "not-a-mapping"],
)
def test_gym_make_with_a_bad_params_file_names_the_file(tmp_path: Path, text: str | None) -> None:
    path = tmp_path / "fit_params.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(ValueError, match=re.escape(str(path))):
        gym.make("cdcr_gym/MuJoCoReach-v0", params=str(path), action_mode="displacement")


def _unreachable(params, readings, straight) -> np.ndarray:
    """(M,) bool: no drive displacement within the range holds ``readings``' tensions at its
    shape (the law T = clip(T0 + k(d − s), 0, max_tension) per tendon)."""
    s = straight - readings.cable_lengths
    k, t0 = np.asarray(params.cable_stiffness), np.asarray(params.cable_pretension)
    t = readings.tensions
    d = s + (t - t0) / k
    low, high = params.displacement_range
    need_low = np.where(t > 1e-9, d, -np.inf)  # pulling: d at least this
    need_high = np.where(t < params.max_tension - 1e-9, d, np.inf)  # below the limit: at most
    tol = 1e-7  # m
    return (np.maximum(need_low, low) > np.minimum(need_high, high) + tol).any(axis=1)


def test_displacement_mode_goals_are_within_the_drive_range() -> None:
    params, _ = load_fitted(FIT)
    backend = AnalyticBackend(params)
    straight = backend.straight_cable_lengths
    m = 300
    task = Reach()
    task.bind(params, 1)
    tension_goals = task.sample_goal_readings([np.random.default_rng(i) for i in range(m)], backend)
    out_tension = _unreachable(params, tension_goals, straight).mean()
    # tension-mode goals: a fraction is beyond the drives (so this test can fail)
    assert out_tension > 0.05
    task.goal_displacement_range = tuple(params.displacement_range)
    goals = task.sample_goal_readings([np.random.default_rng(i) for i in range(m)], backend)
    assert not _unreachable(params, goals, straight).any()
    # the reachable draws are kept as they were; the others moved to the drives' equilibrium
    same = np.all(np.abs(goals.tip - tension_goals.tip) < 1e-12, axis=1)
    ok = ~_unreachable(params, tension_goals, straight)
    assert np.array_equal(same | ~ok, np.ones(m, dtype=bool))
    # and every goal is the tip of the equilibrium under displacements within the range
    s = straight - goals.cable_lengths
    k, t0 = np.asarray(params.cable_stiffness), np.asarray(params.cable_pretension)
    d = np.clip(s + (goals.tensions - t0) / k, *params.displacement_range)
    held = backend.displacement_equilibrium(d)
    np.testing.assert_allclose(held.tip, goals.tip, atol=1e-9)


@pytest.mark.parametrize("mode", ["displacement", "displacement_delta", "tension_delta"])
def test_env_sets_the_goal_range_in_displacement_modes(mode: str) -> None:
    env = gym.make("cdcr_gym/CCKAReach-v0", params=str(FIT), action_mode=mode)
    try:
        rng = env.unwrapped.task.goal_displacement_range
        if mode.startswith("displacement"):
            assert rng == tuple(env.unwrapped.params.displacement_range)
        else:
            assert rng is None
        _, info = env.reset(seed=3)
        assert np.isfinite(info["goal"]).all()
    finally:
        env.close()


def test_training_accepts_a_params_yaml_path_and_nine_cable_episodes() -> None:
    from training.run.rollout import EpisodeSpecs, make_env, robot_of, run_episodes

    fitted, _ = load_fitted(FIT)
    assert robot_of(str(FIT)) == fitted
    kwargs = {"params": str(FIT), "initial_state": "random"}
    rollouts = run_episodes(
        lambda: make_env("cdcr_gym/CCKAReach-v0", kwargs, 5),
        lambda obs: np.zeros((len(obs), 9)),
        EpisodeSpecs.from_seeds(3, 7),
        5,
    )
    assert len(rollouts.returns) == 3
    tensions = np.array([info["tensions"] for info in rollouts.final_infos])
    assert tensions.shape == (3, 9)
    assert np.all((tensions >= 0.0) & (tensions <= fitted.max_tension))
    with pytest.raises(ValueError, match="no_such_file"):
        robot_of("no_such_file.yaml")
