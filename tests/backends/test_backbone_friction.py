"""Backbone friction on MuJoCo (``backbone_friction``, N·m): a Coulomb moment against every
joint's bending, with a slip state per degree of freedom (hysteresis that needs no tendon load)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.backends.mujoco.backend import MuJoCoBackend
from cdcr_gym.model.params import RobotParams

# the v4 robot with slack-prone drives (little pretension), as calibrated
ROBOT = RobotParams.preset("ftdcr_v4", tendon_pretension=0.0, base_compliance=1.0e-5)
KW = {"gravity": False, "physics_timestep": 0.04, "control_timestep": 0.04}
PULL = np.zeros((1, 9))
PULL[0, [0, 3, 6]] = 0.006  # every section towards its first tendon


def _pull_and_release(backend: MuJoCoBackend) -> tuple[np.ndarray, np.ndarray]:
    """Tips (N, 3) m held at PULL for 2 s, then released to d = 0 for 3 s."""
    n = backend.num_robots
    for _ in range(50):
        backend.apply_displacements(np.repeat(PULL, n, axis=0))
    loaded = backend.read().tip.copy()
    for _ in range(75):
        backend.apply_displacements(np.zeros((n, 9)))
    return loaded, backend.read().tip.copy()


def test_friction_leaves_the_released_robot_bent_towards_where_it_was():
    """Released from a bend, the tip stays on the side it came from, more so with more
    friction; while loading, friction holds the robot back (less bend)."""
    straight = MuJoCoBackend(params=ROBOT, **KW)
    _, rest = _pull_and_release(straight)
    side = -1.0  # PULL bends the tip towards −x (the first tendons' side)
    residual, bend = [], []
    for m_f in (0.0, 2e-3, 5e-3):
        backend = MuJoCoBackend(params=ROBOT, backbone_friction=m_f, **KW)
        loaded, released = _pull_and_release(backend)
        residual.append(side * (released[0, 0] - rest[0, 0]))
        bend.append(side * loaded[0, 0])
        backend.close()
    assert residual[0] == pytest.approx(0.0, abs=1e-9)
    assert 0.0 < residual[1] < residual[2]
    assert residual[2] > 2e-3  # > 2 mm left at 5 mN·m
    assert bend[2] < bend[1] < bend[0]


def test_per_robot_friction_and_serial_fallback_of_threads():
    """Robots of one backend with their own M_f (set_randomized) move as robots built with it
    alone; with threads the friction robots are stepped one by one, identically."""
    batched = MuJoCoBackend(params=ROBOT, num_robots=2, threads=2, **KW)
    batched.set_randomized(np.arange(2), {"backbone_friction": np.array([0.0, 5e-3])})
    _, released = _pull_and_release(batched)
    for i, m_f in enumerate((0.0, 5e-3)):
        alone = MuJoCoBackend(params=ROBOT, backbone_friction=m_f, **KW)
        np.testing.assert_allclose(released[i], _pull_and_release(alone)[1][0], atol=1e-9)


def test_reset_clears_the_slip_state():
    backend = MuJoCoBackend(params=ROBOT, backbone_friction=5e-3, **KW)
    first = _pull_and_release(backend)
    backend.reset(np.zeros((1, 9)))
    assert not backend._backbone_slip.any()
    second = _pull_and_release(backend)
    np.testing.assert_allclose(first[1], second[1], atol=1e-9)


@pytest.mark.parametrize("bad", [-1e-3, float("nan"), float("inf"), "1e-3"])
def test_bad_backbone_friction_names_the_argument(bad):
    with pytest.raises(ValueError, match="backbone_friction"):
        MuJoCoBackend(params=ROBOT, backbone_friction=bad)


def test_an_unstable_stick_band_is_refused():
    """h·2k/d at the largest timestep the damping accepts is refused with advice."""
    backend = MuJoCoBackend(params=dataclasses.replace(ROBOT), **KW)
    model = backend._own_model(0)
    model.dof_damping[:] = model.dof_damping * 0.3  # a robot damped too little for the band
    with pytest.raises(ValueError, match="backbone_friction.*unstable"):
        backend.set_backbone_friction([0], [1e-3])


def test_backbone_friction_is_a_mujoco_fit_name_only():
    """The calibration fits it on MuJoCo (a column of its own robot) and refuses it where the
    backend has no such argument."""
    from cdcr_gym.calibration import Measurements, calibrate
    from cdcr_gym.calibration.drive import TendonDrive
    from cdcr_gym.calibration.parameters import resolve_names

    names = resolve_names("backbone_friction", ROBOT, MuJoCoBackend, "mujoco", displacement=True)
    assert names == ["backbone_friction"]
    d = np.zeros((4, 9))
    d[:, 0] = np.linspace(0.0, 0.004, 4)
    data = Measurements(None, np.zeros((4, 3)), None, None, displacements=d)
    for backend in ("ccka", "bullet"):
        with pytest.raises(ValueError, match="backbone_friction"):
            calibrate(data, ROBOT, "backbone_friction", backend, drive=TendonDrive.of(ROBOT))
