"""Tendon displacement commands (SPEC §8) on the physics backends, against the CCKA statics."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet.backend import BulletBackend
from cdcr_gym.backends.mujoco.backend import RELEASED, MuJoCoBackend
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.tendons import shortening_matrix

PHYSICS = {"MuJoCo": MuJoCoBackend, "Bullet": BulletBackend}


def _consistent_commands(p: RobotParams, n: int, seed: int = 2) -> np.ndarray:
    """Displacements (n, C) that hold CCKA shapes of tensions in [0.1, 0.7]·max_tension:
    d = s(T) + (T − T0)/k (every tendon taut on the model)."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.1, 0.7, (n, p.n_cables)) * p.max_tension
    m = shortening_matrix(AnalyticBackend(p).model)
    return t @ m + (t - np.asarray(p.cable_pretension)) / np.asarray(p.cable_stiffness)


def _settle(backend, d: np.ndarray, steps: int = 100):
    for _ in range(steps):
        backend.apply_displacements(d)
    return backend.read()


@pytest.mark.parametrize("name", sorted(PHYSICS))
@pytest.mark.parametrize("stiffness", [2.0e4, 1.0e5])
def test_stiff_tendons_settle_on_the_ccka_displacement_statics(name, stiffness):
    """Paper robot, gravity off: the settled tips are within 0.5 % of ℓ (3.2 mm) of CCKA's
    (measured ≤ 0.065 % on both backends, both stiffnesses)."""
    p = dataclasses.replace(RobotParams(), tendon_stiffness=stiffness)
    backend = PHYSICS[name](p, gravity=False)
    reference = AnalyticBackend(p)
    try:
        for d in _consistent_commands(p, 3):
            r = _settle(backend, d[None])
            reference.apply_displacements(d[None])
            error = np.linalg.norm(r.tip[0] - reference.read().tip[0])
            assert error < 0.005 * p.length, (name, stiffness, error)
            before = r.tip.copy()
            backend.apply_displacements(d[None])
            assert np.linalg.norm(backend.read().tip - before) < 1e-8  # settled
    finally:
        backend.close()


def test_mujoco_and_bullet_agree_on_the_tensions():
    """Both discretise the robot alike (model.discrete, corrected routing): their settled
    tensions under one command agree to 0.5 N (of 80 N) although they differ from CCKA's by
    several N at k = 1e5 N/m (a 0.1 mm shortening gap is 10 N there)."""
    p = dataclasses.replace(RobotParams(), tendon_stiffness=1.0e5)
    d = _consistent_commands(p, 1)
    mj, bt = MuJoCoBackend(p, gravity=False), BulletBackend(p, gravity=False)
    try:
        t_mj, t_bt = _settle(mj, d).tensions, _settle(bt, d).tensions
        assert np.max(np.abs(t_mj - t_bt)) < 0.5
    finally:
        mj.close()
        bt.close()


@pytest.mark.parametrize("robot", ["paper", "tdcr2", "ftdcr_v4"])
@pytest.mark.parametrize("stiffness", [None, 1.0e5])
def test_mujoco_drives_are_stable_at_the_default_timestep(robot, stiffness):
    p = RobotParams.preset(robot)
    if stiffness is not None:
        p = dataclasses.replace(p, tendon_stiffness=stiffness)
    backend = MuJoCoBackend(p)
    backend.enable_displacement_control()
    assert backend.drive_stability() < 0.9
    assert backend.model.opt.integrator == 3  # implicitfast: the tendon damping implicit
    backend.close()


@pytest.mark.parametrize("name", sorted(PHYSICS))
@pytest.mark.parametrize("robot", ["paper", "ftdcr_v4"])
def test_long_random_runs_with_stiff_tendons_stay_finite(name, robot):
    p = dataclasses.replace(RobotParams.preset(robot), tendon_stiffness=1.0e5)
    backend = PHYSICS[name](p)
    rng = np.random.default_rng(0)
    low, high = p.displacement_range
    try:
        for i in range(150):
            if i % 10 == 0:
                d = rng.uniform(low, high, (1, p.n_cables))
            backend.apply_displacements(d)  # raises SimulationDivergedError on a blow-up
            r = backend.read()
            state = backend.drive_state
            assert np.all(np.isfinite(r.tip))
            assert np.all(r.tensions[state.slack] == 0.0)
            assert np.all(r.tensions[state.saturated] == p.max_tension)
    finally:
        backend.close()


def test_mujoco_actuator_sign_and_release():
    p = RobotParams()
    backend = MuJoCoBackend(p, gravity=False)
    d = np.array([[0.02, -0.01, 0.0]])
    r = _settle(backend, d)
    data = backend._datas[0]
    drive = backend._drive_slice
    # the drives pull: a negative force along the tendon, the law's tension at rest
    assert np.allclose(-np.asarray(data.actuator_force[drive]), r.tensions[0], atol=1e-6)
    assert r.tensions[0, 0] > 0.0 and backend.drive_state is not None
    # a tension command releases the drives: exactly zero force, no drive damping
    backend.apply_tensions(np.array([[10.0, 0.0, 0.0]]))
    assert np.all(np.asarray(data.ctrl[drive]) == RELEASED)
    assert np.all(np.asarray(data.actuator_force[drive]) == 0.0)
    assert np.all(backend.model.tendon_damping == 0.0)
    assert backend.drive_state is None
    assert np.array_equal(backend.read().tensions, [[10.0, 0.0, 0.0]])
    backend.close()


def test_mujoco_threads_and_friction():
    p = RobotParams()
    d = np.array([[0.02, -0.01, 0.0], [0.0, 0.015, -0.005]])
    serial = MuJoCoBackend(p, num_robots=2)
    threaded = MuJoCoBackend(p, num_robots=2, threads=2)
    rough = MuJoCoBackend(p, num_robots=2, friction_coefficient=0.2)
    try:
        a, b, c = _settle(serial, d, 30), _settle(threaded, d, 30), _settle(rough, d, 30)
        assert np.allclose(a.tip, b.tip, atol=1e-9)
        assert c.anchor_tensions is not None
        taut = c.tensions > 1.0
        assert np.any(np.abs(c.anchor_tensions - c.tensions)[taut] > 0.1)  # capstan acts
        assert np.all(c.tensions[rough.drive_state.slack] == 0.0)
    finally:
        for backend in (serial, threaded, rough):
            backend.close()


@pytest.mark.parametrize("name", ["CCKA", "MuJoCo", "Bullet"])
def test_displacement_equilibrium(name):
    """The backend's own static equilibrium under displacements: holding them from there
    moves nothing (to 0.1 mm on physics), and on CCKA it is the displacement statics."""
    p = RobotParams()
    backend = AnalyticBackend(p) if name == "CCKA" else PHYSICS[name](p, gravity=False)
    d = np.array([[0.015, -0.005, 0.002]])
    try:
        eq = backend.displacement_equilibrium(d)
        backend.reset(eq.tensions)
        backend.apply_displacements(d)
        assert np.linalg.norm(backend.read().tip - eq.tip) < (1e-12 if name == "CCKA" else 1e-4)
    finally:
        backend.close()


def test_bad_displacements_name_the_argument():
    for backend in (MuJoCoBackend(RobotParams()), BulletBackend(RobotParams())):
        with pytest.raises(ValueError, match="displacements"):
            backend.apply_displacements(np.full((1, 3), np.nan))
        with pytest.raises(ValueError, match="displacements"):
            backend.apply_displacements(np.zeros((1, 4)))
        backend.close()
