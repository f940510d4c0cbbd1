"""Drive softening in the calibration (fit name ``drive_softening``): the CCKA and MuJoCo
replays pull with tanh(σy)/σ of the played commands, a fit recovers a known σ from synthetic
displacement data, the fitted drive keeps it in its YAML mapping and hands it to the twin."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.calibration import Measurements, calibrate, twin_kwargs_from_yaml
from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.drive_softening import soften
from cdcr_gym.model.params import RobotParams, params_to_dict
from cdcr_gym.model.yaml_io import dump_yaml
from tests.calibration.synthetic_commands import back_and_forth, displacement_rows

V4 = RobotParams.preset("ftdcr_v4")
FAST = {"physics_timestep": 0.04, "control_timestep": 0.04}
RATE = 27.0  # 1/m


def test_the_drive_keeps_its_softening():
    drive = TendonDrive.of(V4)
    assert drive.softening == 0.0 and "softening" not in drive.to_dict()
    soft = dataclasses.replace(drive, softening=RATE)
    back = TendonDrive.from_dict(soft.to_dict(), V4.n_cables, "test")
    assert back.softening == RATE
    with pytest.raises(ValueError, match="softening"):
        dataclasses.replace(drive, softening=-1.0)


def test_ccka_replay_pulls_with_the_softened_played_commands():
    d = back_and_forth(60)
    drive = TendonDrive.of(V4)
    w = 2e-4
    a = DriveReplay(displacement_rows(d), V4, drive)(
        {"drive_backlash": w, "drive_softening": RATE}
    ).tip
    pulled = DriveReplay(displacement_rows(soften(play(d, w), RATE)), V4, drive)({}).tip
    np.testing.assert_allclose(a, pulled, atol=1e-12)
    # a batch mixing drives equals the separate replays
    both = DriveReplay(displacement_rows(d), V4, drive).batch(
        [{"drive_backlash": w, "drive_softening": RATE}, {"drive_backlash": w}]
    )[0]
    np.testing.assert_allclose(both[0], a, atol=1e-12)
    plain = DriveReplay(displacement_rows(play(d, w)), V4, drive)({}).tip
    np.testing.assert_allclose(both[1], plain, atol=1e-12)
    assert np.abs(a - plain).max() > 1e-3  # the softening moves the tip


def test_ccka_fit_recovers_a_known_softening():
    d = back_and_forth(300, seed=1)
    drive = TendonDrive.of(V4)
    truth = {"drive_softening": RATE, "youngs_modulus": 55e9, "base_x": 0.001}
    tip = DriveReplay(displacement_rows(d), V4, drive)(truth).tip
    res = calibrate(
        displacement_rows(d, tip),
        V4,
        "drive_softening,E,base_x",
        "ccka",
        drive=drive,
        start={"drive_softening": 10.0},
    )
    assert res.values["drive_softening"] == pytest.approx(RATE, rel=0.02)
    assert res.values["youngs_modulus"] == pytest.approx(55e9, rel=0.02)
    assert res.values["base_x"] == pytest.approx(0.001, abs=0.3e-3)
    assert res.drive is not None and res.drive.softening == pytest.approx(RATE, rel=0.02)


def test_the_default_start_leaves_zero():
    """Without a start the fit starts at 10 1/m (at 0 its gradient vanishes) and finds σ."""
    d = back_and_forth(200, seed=4)
    drive = TendonDrive.of(V4)
    tip = DriveReplay(displacement_rows(d), V4, drive)({"drive_softening": RATE}).tip
    res = calibrate(displacement_rows(d, tip), V4, "drive_softening,base_x", "ccka", drive=drive)
    assert res.start["drive_softening"] == 10.0
    assert res.values["drive_softening"] == pytest.approx(RATE, rel=0.02)


def test_mujoco_replay_gives_each_robot_its_own_softened_commands():
    pytest.importorskip("mujoco")
    d = back_and_forth(12, seed=2)
    drive = TendonDrive.of(V4)
    kw = {"gravity": False, **FAST}
    tips = PhysicsReplay(displacement_rows(d), V4, drive, "mujoco", kw, default_gap=0.4).batch(
        [{"drive_softening": RATE}, {}]
    )[0]
    alone = PhysicsReplay(
        displacement_rows(soften(d, RATE)), V4, drive, "mujoco", kw, default_gap=0.4
    )
    np.testing.assert_allclose(tips[0], alone({}).tip, atol=1e-9)
    plain = PhysicsReplay(displacement_rows(d), V4, drive, "mujoco", kw, default_gap=0.4)({}).tip
    np.testing.assert_allclose(tips[1], plain, atol=1e-9)
    assert np.abs(tips[0] - tips[1]).max() > 1e-4


def test_softening_on_tension_data_is_refused():
    p = RobotParams.preset("tdcr2")
    t = np.random.default_rng(3).uniform(0.0, 3.0, (20, p.n_cables))
    with pytest.raises(ValueError, match="drive_softening"):
        calibrate(Measurements(t, np.zeros((20, 3)), None, None), p, "drive_softening", "ccka")


def test_the_twin_gets_the_fitted_softening(tmp_path):
    drive = dataclasses.replace(TendonDrive.of(V4), softening=RATE, backlash=1e-4)
    path = tmp_path / "params.yaml"
    path.write_text(
        dump_yaml({"robot": params_to_dict(V4), "calibration": {"tendons": drive.to_dict()}})
    )
    kw = twin_kwargs_from_yaml(path)
    assert kw["drive_softening"] == RATE and kw["drive_backlash"] == 1e-4
    assert "drive_softening" not in twin_kwargs_from_yaml(path, action_mode="tension")
