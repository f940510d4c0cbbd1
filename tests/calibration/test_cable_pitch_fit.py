"""Helical routing in the calibration (fit name ``cable_pitch``): the CCKA replay of a helical
robot, a fit that recovers a known pitch from synthetic displacement data, the fitted robot's
YAML that carries it, and the physics replays, which keep the pitch of the file they start from
(MuJoCo and bullet build the helix from it) rather than fit it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.calibration import calibrate
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.parameters import parameter_specs, resolve_names
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params import RobotParams
from tests.calibration.synthetic_commands import back_and_forth, displacement_rows

V4 = RobotParams.preset("ftdcr_v4")
PITCH = -1.0  # rad/m


def test_replay_of_the_value_equals_the_helical_robot():
    d = back_and_forth(40)
    drive = TendonDrive.of(V4)
    by_value = DriveReplay(displacement_rows(d), V4, drive)({"cable_pitch": PITCH}).tip
    helical = dataclasses.replace(V4, cable_pitch=PITCH)
    by_robot = DriveReplay(displacement_rows(d), helical, drive)({}).tip
    np.testing.assert_array_equal(by_value, by_robot)
    parallel = DriveReplay(displacement_rows(d), V4, drive)({}).tip
    assert np.max(np.linalg.norm(by_value - parallel, axis=1)) > 1e-3


def test_ccka_fit_recovers_a_known_pitch_and_writes_it(tmp_path):
    d = back_and_forth(300, seed=1)
    drive = TendonDrive.of(V4)
    truth = {"cable_pitch": PITCH, "youngs_modulus": 55e9, "base_x": 0.001}
    tip = DriveReplay(displacement_rows(d), V4, drive)(truth).tip
    res = calibrate(displacement_rows(d, tip), V4, "cable_pitch,E,base_x", "ccka", drive=drive)
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
