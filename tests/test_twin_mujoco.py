"""The MuJoCo twin of the FTDCR v4 robot (the MuJoCo fit's params.yaml) as a training env: its
fast static solves (``cdcr_gym/backends/mujoco/anderson.py``) reach the same equilibria as the
plain iteration and as a long physics settle, and the env resets and steps in
``displacement_delta`` mode (configs/twin_ftdcr_v4_mujoco_reach.yaml)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the envs)
from cdcr_gym.backends.base import Backend
from cdcr_gym.backends.mujoco.backend import MuJoCoBackend
from cdcr_gym.calibration import twin_kwargs_from_yaml
from cdcr_gym.calibration.report import backend_kwargs_from_yaml, load_fitted
from cdcr_gym.model.tendons import holding_displacements
from cdcr_gym.model.workspace import sample_tensions_each
from cdcr_gym.tasks.reach import Reach

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "docs" / "figures" / "calibration"
FIT = FITS / "ftdcr_v4_mujoco_selected" / "params.yaml"  # the twin of the training config
#: the earlier fit (gravity, rigid base; its drives capped at max_tension) and the selected one
#: (no gravity, compliant base, drives uncapped as fitted; its backbone friction left out: the
#: static solves are frictionless, friction acts in the dynamics)
TWINS = {
    "stage0": FITS / "ftdcr_v4_mujoco_stage0" / "params.yaml",
    "selected": FIT,
}
#: A goal's tip vs the tip after a long physics settle of the same command (m): the settle is
#: 300 control steps (12 s); measured on these goals: <= 2e-14 m after 200 steps, 7e-6 m after 50.
SETTLE_TOL = 1e-9
SETTLE_STEPS = 300


@pytest.fixture(scope="module", params=sorted(TWINS))
def backend(request) -> MuJoCoBackend:
    path = str(TWINS[request.param])
    params, kwargs = load_fitted(path)
    kwargs.pop("backbone_friction", None)
    b = MuJoCoBackend(params, **kwargs)
    b.enable_displacement_control()
    b.set_drive_max_tension(twin_kwargs_from_yaml(path)["drive_max_tension"])
    return b


def test_fast_static_solve_matches_the_plain_iteration(backend: MuJoCoBackend) -> None:
    p = backend.params
    tensions = np.vstack(
        [
            np.zeros(p.n_cables),
            sample_tensions_each([np.random.default_rng(s) for s in range(4)], p),
        ]
    )
    fast = backend.equilibrium(tensions)
    data = backend._scratch
    for row, tip in zip(tensions, fast.tip):
        assert backend._solve_static(backend.model, data, row)  # the plain relaxed iteration
        np.testing.assert_allclose(tip, data.site_xpos[backend._tip_id], rtol=0.0, atol=1e-10)


def test_drive_solve_matches_the_outer_tension_iteration(backend: MuJoCoBackend) -> None:
    low, high = backend.params.displacement_range
    d = np.random.default_rng(3).uniform(low, high, (3, backend.params.n_cables))
    cap = backend.drive_max_tension
    # uncapped, these commands co-contract tendons at 17-40 N, where the shape under the
    # tensions alone is ambiguous and the outer iteration lands 20-40 mm away from the drive
    # solve (which is where the dynamics settle: the next test); compared at the robot's cap
    backend.set_drive_max_tension(min(cap, backend.params.max_tension))
    try:
        fast = backend.displacement_equilibrium(d)
        slow = Backend.displacement_equilibrium(backend, d)  # tension solves, CCKA-Newton loop
    finally:
        backend.set_drive_max_tension(cap)
    np.testing.assert_allclose(fast.tip, slow.tip, rtol=0.0, atol=1e-8)
    np.testing.assert_allclose(fast.tensions, slow.tensions, rtol=0.0, atol=1e-6)
    # the returned tensions are the drives' law at the settled lengths
    p = backend.params
    s = backend.straight_cable_lengths - fast.cable_lengths
    give = (fast.tensions - np.asarray(p.cable_pretension)).sum(axis=1, keepdims=True)
    law = np.clip(
        p.cable_pretension + np.asarray(p.cable_stiffness) * (d - s - p.base_compliance * give),
        0,
        min(cap, p.max_tension),
    )
    np.testing.assert_allclose(fast.tensions, law, rtol=0.0, atol=1e-9)


def test_goals_are_where_the_robot_settles_under_in_range_commands(
    backend: MuJoCoBackend,
) -> None:
    """Displacement-mode goals (Task.sample_goal_readings): each is the tip of a displacement
    command d within the drives' range (d = s + (T − T0)/k of the goal's shape, clipped); holding
    that d for 12 s of physics from the straight pose settles within SETTLE_TOL of the goal."""
    p = backend.params
    task = Reach()
    task.bind(p, 1)
    task.goal_displacement_range = tuple(p.displacement_range)
    rngs = [np.random.default_rng(seed) for seed in (11, 12, 13)]  # 11, 13: clipped
    goals = task.sample_goal_readings(rngs, backend)
    s = backend.straight_cable_lengths - goals.cable_lengths
    held = holding_displacements(
        s, goals.tensions, p.cable_stiffness, p.cable_pretension, p.base_compliance
    )
    d = np.clip(held, *p.displacement_range)
    low, high = p.displacement_range
    assert np.all((d >= low) & (d <= high))
    clipped = 0
    for row, goal in zip(d, goals.tip):
        clipped += int(np.any(np.isclose(row, low) | np.isclose(row, high)))
        backend.reset(np.zeros((1, p.n_cables)))
        for _ in range(SETTLE_STEPS):
            backend.apply_displacements(row[None])
        settled = backend.read().tip[0]
        assert np.linalg.norm(settled - goal) < SETTLE_TOL, (row, settled, goal)
    assert clipped >= 1  # the drive-solve path is exercised, not only the tension solves


@pytest.mark.parametrize("twin", sorted(TWINS))
def test_mujoco_twin_resets_and_steps_in_displacement_delta_mode(twin: str) -> None:
    path = str(TWINS[twin])
    kwargs = (
        twin_kwargs_from_yaml(path, action_mode="displacement_delta")
        if twin == "selected"
        else {"action_mode": "displacement_delta", **backend_kwargs_from_yaml(path)}
    )
    env = gym.make("cdcr_gym/MuJoCoReach-v0", params=path, initial_state="random", **kwargs)
    try:
        obs, info = env.reset(seed=5)
        goal = np.asarray(info["goal"]).copy()
        d0 = np.asarray(info["displacements"]).copy()
        action = np.full(9, 0.5, dtype=np.float32)
        for _ in range(3):
            obs, reward, term, trunc, info = env.step(action)
        assert np.isfinite(obs).all() and np.isfinite(reward)
        np.testing.assert_array_equal(info["goal"], goal)
        lo, hi = env.unwrapped.params.displacement_range
        want = np.clip(d0 + 3 * 0.5 * 1e-3, lo, hi)  # default displacement_step 1 mm
        np.testing.assert_allclose(info["displacements"], want, rtol=0.0, atol=1e-12)
        _, info2 = env.reset(seed=5)  # same seed: the same goal
        np.testing.assert_allclose(info2["goal"], goal, rtol=0.0, atol=1e-12)
    finally:
        env.close()
