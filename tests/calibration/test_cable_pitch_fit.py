"""Helical routing in the calibration (fit name ``cable_pitch``): the CCKA replay of a helical
robot, a fit that recovers a known pitch from synthetic displacement data, the fitted robot's
YAML that carries it, and the physics replays, which keep the pitch of the file they start from
(MuJoCo and bullet build the helix from it) rather than fit it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.calibration import Measurements, calibrate
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.parameters import parameter_specs, resolve_names
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params import RobotParams

V4 = RobotParams.preset("ftdcr_v4")
PITCH = -1.0  # rad/m


def _sequence(n: int, seed: int = 0) -> np.ndarray:
    """Commands (n, 9) m up to ~10 mm, every tendon back and forth."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None]
    phase = rng.uniform(0, 2 * np.pi, (1, 9))
    return 0.002 + 0.008 * np.sin(0.3 * t + phase) + 0.0005 * rng.standard_normal((n, 9))


def _data(d: np.ndarray, tip: np.ndarray | None = None) -> Measurements:
    tips = np.zeros((len(d), 3)) if tip is None else tip
    return Measurements(None, tips, None, None, displacements=d)


def test_replay_of_the_value_equals_the_helical_robot():
    d = _sequence(40)
    drive = TendonDrive.of(V4)
    by_value = DriveReplay(_data(d), V4, drive)({"cable_pitch": PITCH}).tip
    helical = dataclasses.replace(V4, cable_pitch=PITCH)
    by_robot = DriveReplay(_data(d), helical, drive)({}).tip
    np.testing.assert_array_equal(by_value, by_robot)
    parallel = DriveReplay(_data(d), V4, drive)({}).tip
    assert np.max(np.linalg.norm(by_value - parallel, axis=1)) > 1e-3


def test_ccka_fit_recovers_a_known_pitch_and_writes_it(tmp_path):
    d = _sequence(300, seed=1)
    drive = TendonDrive.of(V4)
    truth = {"cable_pitch": PITCH, "youngs_modulus": 55e9, "base_x": 0.001}
    tip = DriveReplay(_data(d), V4, drive)(truth).tip
    res = calibrate(_data(d, tip), V4, "cable_pitch,E,base_x", "ccka", drive=drive)
    assert res.values["cable_pitch"] == pytest.approx(PITCH, rel=0.01)
    assert res.values["youngs_modulus"] == pytest.approx(55e9, rel=0.01)
    assert res.params.cable_pitch == res.values["cable_pitch"]
    text = res.params.to_yaml()
    assert RobotParams.from_yaml(text).cable_pitch == res.values["cable_pitch"]


def test_the_name_is_scaled_bounded_and_kept_from_the_physics_replay():
    (spec,) = parameter_specs(["cable_pitch"], V4, {})
    assert spec.unit == "rad/m" and spec.scale == 0.1
    assert spec.lower == pytest.approx(-np.pi / 0.064) and spec.upper == -spec.lower
    assert resolve_names("cable_pitch", V4) == ["cable_pitch"]
    from cdcr_gym.backends.mujoco import MuJoCoBackend

    with pytest.raises(ValueError, match="cable pitch"):
        resolve_names("cable_pitch", V4, MuJoCoBackend, "mujoco", displacement=True)
