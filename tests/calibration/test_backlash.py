"""Backlash of the tendon drives (``cdcr_gym.calibration.backlash``, fit name
``drive_backlash``): the play operator, its use by the CCKA and MuJoCo replays, and a fit that
recovers a known backlash from synthetic displacement data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.calibration import Measurements, calibrate
from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params import RobotParams

V4 = RobotParams.preset("ftdcr_v4")
FAST = {"physics_timestep": 0.04, "control_timestep": 0.04}


def test_play_lags_by_half_the_width_and_holds_on_reversal():
    d = np.array([[0.0], [1.0], [2.0], [1.8], [1.5], [0.0]]) * 1e-3
    y = play(d, 0.5e-3)
    np.testing.assert_allclose(y[:, 0] * 1e3, [0.0, 0.75, 1.75, 1.75, 1.75, 0.25], atol=1e-12)
    np.testing.assert_array_equal(play(d, 0.0), d)
    # per tendon widths; the output stays within w/2 of the command
    d2 = np.random.default_rng(0).uniform(-0.005, 0.005, (200, 3))
    w = np.array([0.0, 1e-4, 1e-3])
    y2 = play(d2, w)
    assert np.all(np.abs(y2 - d2) <= w / 2 + 1e-15)
    np.testing.assert_array_equal(y2[:, 0], d2[:, 0])


@pytest.mark.parametrize(
    ("d", "w", "match"),
    [
        (np.zeros((3, 2)), -1e-4, "width"),
        (np.zeros((3, 2)), float("nan"), "width"),
        (np.zeros((3, 2)), [1e-4, 1e-4, 1e-4], "width"),
        (np.zeros(3), 1e-4, "displacements"),
        (np.array([[0.0, np.nan]]), 1e-4, "displacements"),
    ],
)
def test_play_refuses_bad_input(d, w, match):
    with pytest.raises(ValueError, match=match):
        play(d, w)


def test_drive_backlash_is_refused_when_negative_and_kept_in_the_yaml_mapping():
    drive = TendonDrive.of(V4)
    with pytest.raises(ValueError, match="backlash"):
        dataclasses.replace(drive, backlash=-1e-4)
    d = dataclasses.replace(drive, backlash=1.2e-4)
    back = TendonDrive.from_dict(d.to_dict(), V4.n_cables, "test")
    assert back.backlash == pytest.approx(1.2e-4)
    assert "backlash" not in drive.to_dict()


def _sequence(n: int, seed: int = 0) -> np.ndarray:
    """Commands (n, 9) m that go back and forth (reversals on every tendon)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None]
    phase = rng.uniform(0, 2 * np.pi, (1, 9))
    return 0.003 * np.sin(0.3 * t + phase) + 0.0005 * rng.standard_normal((n, 9))


def test_ccka_replay_uses_the_played_commands():
    d = _sequence(60)
    data = Measurements(None, np.zeros((60, 3)), None, None, displacements=d)
    drive = TendonDrive.of(V4)
    w = 2e-4
    a = DriveReplay(data, V4, drive)({"drive_backlash": w}).tip
    played = dataclasses.replace(data, displacements=play(d, w))
    b = DriveReplay(played, V4, drive)({}).tip
    np.testing.assert_allclose(a, b, atol=1e-12)
    c = DriveReplay(data, V4, dataclasses.replace(drive, backlash=w))({}).tip
    np.testing.assert_allclose(a, c, atol=1e-12)
    # a batch mixing widths equals the separate replays
    both = DriveReplay(data, V4, drive).batch([{"drive_backlash": w}, {}])[0]
    np.testing.assert_allclose(both[0], a, atol=1e-12)
    np.testing.assert_allclose(both[1], DriveReplay(data, V4, drive)({}).tip, atol=1e-12)
    assert np.abs(a - both[1]).max() > 1e-4  # the backlash moves the tip


def test_ccka_fit_recovers_a_known_backlash_and_stiffness():
    d = _sequence(300, seed=1)
    drive = TendonDrive.of(V4)
    truth = {"drive_backlash": 1.5e-4, "youngs_modulus": 55e9, "base_x": 0.001}
    tip = DriveReplay(
        Measurements(None, np.zeros((300, 3)), None, None, displacements=d), V4, drive
    )(truth).tip
    data = Measurements(None, tip, None, None, displacements=d)
    res = calibrate(
        data,
        V4,
        "drive_backlash,E,base_x",
        "ccka",
        drive=drive,
        start={"drive_backlash": 1e-4},
    )
    assert res.values["drive_backlash"] == pytest.approx(1.5e-4, rel=0.02)
    assert res.values["youngs_modulus"] == pytest.approx(55e9, rel=0.02)
    assert res.values["base_x"] == pytest.approx(0.001, abs=0.3e-3)


def test_mujoco_replay_gives_each_robot_its_own_played_commands():
    pytest.importorskip("mujoco")
    d = _sequence(12, seed=2)
    data = Measurements(None, np.zeros((12, 3)), None, None, displacements=d)
    drive = TendonDrive.of(V4)
    kw = {"gravity": False, **FAST}
    w = 3e-4
    batch = PhysicsReplay(data, V4, drive, "mujoco", kw, default_gap=0.4)
    tips = batch.batch([{"drive_backlash": w}, {}])[0]
    played = dataclasses.replace(data, displacements=play(d, w))
    alone = PhysicsReplay(played, V4, drive, "mujoco", kw, default_gap=0.4)({}).tip
    np.testing.assert_allclose(tips[0], alone, atol=1e-9)
    plain = PhysicsReplay(data, V4, drive, "mujoco", kw, default_gap=0.4)({}).tip
    np.testing.assert_allclose(tips[1], plain, atol=1e-9)
    assert np.abs(tips[0] - tips[1]).max() > 1e-4


def test_the_cli_keeps_the_fitted_backlash_of_a_params_yaml(tmp_path):
    """A fit started from a fitted params.yaml (``--robot``) replays with the backlash kept in
    its calibration.tendons (RobotParams has no backlash: the environments do not model it)."""
    from cdcr_gym.model.params import params_to_dict
    from cdcr_gym.model.yaml_io import dump_yaml
    from training.studies.calibrate import _drive

    drive = dataclasses.replace(TendonDrive.of(V4), backlash=1.1e-4)
    path = tmp_path / "params.yaml"
    doc = {"robot": params_to_dict(V4), "calibration": {"tendons": drive.to_dict()}}
    path.write_text(dump_yaml(doc))
    robot = RobotParams.from_yaml(path)
    assert _drive(str(path), robot).backlash == pytest.approx(1.1e-4)
    assert _drive("ftdcr_v4", V4).backlash == 0.0


def test_backlash_on_tension_data_is_refused():
    p = RobotParams.preset("tdcr2")
    t = np.random.default_rng(3).uniform(0.0, 3.0, (20, p.n_cables))
    data = Measurements(t, np.zeros((20, 3)), None, None)
    with pytest.raises(ValueError, match="drive_backlash"):
        calibrate(data, p, "drive_backlash,base_x", "ccka")
