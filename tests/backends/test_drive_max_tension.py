"""The displacement drives' own tension cap (``Backend.set_drive_max_tension``): by default the
robot's ``max_tension`` (the tension-command range); set, every backend's drives pull up to it
(``inf``: no cap) and the law T = clip(T0 + k·(d − s), 0, T_max) holds at rest with it; the
physics calibration replay uses the tendon drive's cap, as its constant-curvature solve."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.base import Backend
from cdcr_gym.backends.bullet.backend import BulletBackend
from cdcr_gym.calibration import Measurements
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params import RobotParams

V4 = RobotParams.preset("ftdcr_v4")
FAST = {"physics_timestep": 0.04, "control_timestep": 0.04}


def _pull() -> np.ndarray:
    """One row (1, 9) m: all three sections pulled the same way, the distal tendon hardest
    (as the held-out `same` patterns); its drive asks for more than V4.max_tension = 9 N."""
    d = np.full((1, 9), -0.0005)
    d[0, [0, 3, 6]] = [0.002, 0.004, 0.0075]
    return d


def _backend(name: str):
    if name == "analytic":
        return AnalyticBackend(params=V4)
    if name == "mujoco":
        pytest.importorskip("mujoco")
        from cdcr_gym.backends.mujoco.backend import MuJoCoBackend

        return MuJoCoBackend(params=V4, gravity=False, **FAST)
    return BulletBackend(params=V4, gravity=False)


def _settle(backend, d: np.ndarray, steps: int = 150):
    for _ in range(1 if isinstance(backend, AnalyticBackend) else steps):
        backend.apply_displacements(d)
    r = backend.read()
    return r.tensions[0], backend.drive_state.saturated[0], r


def _law(d: np.ndarray, shortening: np.ndarray, cap: float) -> np.ndarray:
    k, t0 = np.asarray(V4.cable_stiffness), np.asarray(V4.cable_pretension)
    return np.clip(t0 + k * (d - shortening), 0.0, cap)


@pytest.mark.parametrize("name", ["analytic", "mujoco", "bullet"])
def test_each_backend_pulls_up_to_its_drive_cap(name):
    d = _pull()
    backend = _backend(name)
    try:
        assert backend.drive_max_tension == V4.max_tension
        t, sat, _ = _settle(backend, d)
        assert t.max() == pytest.approx(V4.max_tension, abs=1e-9) and sat[6]
        backend.set_drive_max_tension(np.inf)
        assert backend.drive_max_tension == np.inf
        t, sat, r = _settle(backend, d)
        assert t[6] > V4.max_tension + 2.0, t  # measured: 20.3-20.6 N
        assert not sat.any()
        if name == "analytic":
            s = backend.tendon_state.shortening[0]
        else:
            s = backend.straight_cable_lengths - r.cable_lengths[0]
        np.testing.assert_allclose(t, _law(d[0], s, np.inf), atol=0.02)
        backend.set_drive_max_tension(5.0)
        t, sat, _ = _settle(backend, d)
        assert t.max() == pytest.approx(5.0, abs=1e-9) and sat[6]
    finally:
        if hasattr(backend, "close"):
            backend.close()


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "strong", None])
def test_a_bad_cap_is_refused_and_keeps_the_old_one(bad):
    backend = AnalyticBackend(params=V4)
    backend.set_drive_max_tension(12.0)
    with pytest.raises(ValueError, match="max_tension"):
        backend.set_drive_max_tension(bad)
    assert backend.drive_max_tension == 12.0


def test_physics_replay_caps_the_drives_as_the_tendon_drive():
    """MuJoCo, gravity off: rows whose drives ask for more than V4.max_tension replay to the
    CCKA shapes of the same drive law, uncapped (the tendon drive's default) or capped at
    V4.max_tension; the two differ by centimetres."""
    pytest.importorskip("mujoco")
    d = np.repeat(_pull(), 3, axis=0) * np.array([[0.6], [0.8], [1.0]])
    data = Measurements(None, np.zeros((3, 3)), None, None, displacements=d)
    tips = {}
    for label, cap in (("free", np.inf), ("capped", V4.max_tension)):
        drive = dataclasses.replace(TendonDrive.of(V4), max_tension=cap)
        mj = PhysicsReplay(data, V4, drive, "mujoco", {"gravity": False, **FAST}, default_gap=2.0)
        tips[label] = mj({}).tip
        ccka = DriveReplay(data, V4, drive)({}).tip
        err = np.linalg.norm(tips[label] - ccka, axis=1)
        assert err.max() < 1.5e-3, (label, err)
    gap = np.linalg.norm(tips["free"] - tips["capped"], axis=1)
    assert gap[-1] > 5e-3, gap


@pytest.mark.parametrize("name", ["analytic", "mujoco", "bullet"])
@pytest.mark.parametrize("cap", [np.inf, 5.0])
def test_displacement_equilibrium_holds_the_drive_cap(name, cap):
    """The static equilibrium under displacement commands (goals of the displacement action
    modes, resets from ``initial_displacements``) is the one the drives settle to: with their own
    cap, above or below ``max_tension``."""
    d = _pull()
    backend = _backend(name)
    try:
        backend.set_drive_max_tension(cap)
        t, _, r = _settle(backend, d, steps=250)
        held = backend.displacement_equilibrium(d)
        np.testing.assert_allclose(held.tensions[0], t, atol=0.05)
        np.testing.assert_allclose(held.tip[0], r.tip[0], atol=2e-4)
        if np.isinf(cap):
            assert held.tensions[0, 6] > V4.max_tension + 2.0
        if name == "mujoco" and np.isinf(cap):
            # at 20 N on the distal tendons MuJoCo's fallback (the outer iteration on tension
            # solves) contracts slowly towards a co-contracted shape; its drive solve is the one
            # its dynamics settle to (above)
            return
        # the outer iteration on tension solves (the physics backends' fallback) agrees
        slow = Backend.displacement_equilibrium(backend, d)
        np.testing.assert_allclose(slow.tip[0], held.tip[0], atol=2e-4)
    finally:
        if hasattr(backend, "close"):
            backend.close()
