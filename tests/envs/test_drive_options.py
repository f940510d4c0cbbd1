"""The env's drive options in the displacement action modes (``drive_max_tension``,
``drive_backlash``) and the calibrated twin they rebuild (``twin_kwargs_from_yaml``)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the envs)
from cdcr_gym.calibration import read_csv, twin_kwargs_from_yaml
from cdcr_gym.calibration.backlash import play
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.report import load_fitted
from cdcr_gym.model.backlash import play_step
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.params_yaml import load_yaml
from cdcr_gym.model.yaml_io import dump_yaml

ROOT = Path(__file__).resolve().parents[2]
FIT = ROOT / "docs" / "figures" / "calibration" / "ftdcr_v4_mujoco_helix" / "params.yaml"


def _ccka(**kwargs):
    return gym.make("cdcr_gym/CCKAReach-v0", action_mode="displacement", **kwargs)


def _action(d: np.ndarray, params: RobotParams) -> np.ndarray:
    low, high = params.displacement_range
    return (2.0 * (d - low) / (high - low) - 1.0).astype(np.float32)


def test_play_step_is_the_calibration_play_operator():
    rng = np.random.default_rng(0)
    d = np.cumsum(rng.normal(0.0, 1e-4, (50, 3)), axis=0)
    y = np.zeros(3)
    for m in range(len(d)):
        y = play_step(y, d[m], 2e-4)
    np.testing.assert_array_equal(y, play(d, 2e-4)[-1])
    np.testing.assert_array_equal(play_step(y, d[-1], 0.0), d[-1])


def test_env_backlash_plays_the_commands():
    """The tendons take the commands through the play (info ``tendon_displacements``), starting
    at the reset's displacements; the tensions follow the played ones."""
    w = 1e-3
    env = _ccka(drive_backlash=w)
    plain = _ccka()
    p = env.unwrapped.params
    try:
        _, info = env.reset(seed=0)
        plain.reset(seed=0)
        start = info["displacements"].copy() if "displacements" in info else None
        y = env.unwrapped.core._tendon_displacements[0].copy()
        if start is not None:
            np.testing.assert_array_equal(y, start)
        ramp = np.linspace(0.0, 4e-3, 6)
        commands = np.concatenate([ramp, ramp[::-1]])[:, None] * np.array([1.0, 0.0, 0.0])
        for d in commands:
            _, _, _, _, info = env.step(_action(d, p))
            _, _, _, _, info_plain = plain.step(_action(info["tendon_displacements"], p))
            y = play_step(y, info["displacements"], w)
            np.testing.assert_allclose(info["tendon_displacements"], y, atol=1e-12)
            # the robot is the plain one commanded with the played displacements
            np.testing.assert_allclose(info["tensions"], info_plain["tensions"], atol=1e-9)
        # on the way back the tendon lags the command by w/2: it stays more pulled
        assert info["tendon_displacements"][0] == pytest.approx(commands[-1, 0] + w / 2)
        assert "tendon_displacements" not in info_plain
    finally:
        env.close()
        plain.close()


def test_env_drive_cap():
    """``drive_max_tension=inf`` lets a hard pull exceed the robot's max_tension; the default
    caps it there and reports the saturation."""
    capped, free = _ccka(), _ccka(drive_max_tension=float("inf"))
    try:
        p = capped.unwrapped.params
        pull = np.array([p.displacement_range[1], 0.0, 0.0])
        for env in (capped, free):
            env.reset(seed=0)
        for _ in range(3):
            _, _, _, _, ic = capped.step(_action(pull, p))
            obs, _, _, _, i_f = free.step(_action(pull, p))
            assert free.observation_space.contains(obs)  # the observed tensions saturate
        assert ic["tensions"][0] == pytest.approx(p.max_tension)
        assert ic["saturated"][0]
        assert i_f["tensions"][0] > 1.5 * p.max_tension
        assert not i_f["saturated"][0]
    finally:
        capped.close()
        free.close()


@pytest.mark.parametrize(
    "env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/MuJoCoReach-v0", "cdcr_gym/BulletReach-v0"]
)
def test_reset_from_displacements_under_the_drive_cap(env_id):
    """A reset from ``initial_displacements`` rests in the drives' equilibrium under their own
    cap: with none, the distal tendons carry twice the robot's max_tension, and holding the same
    commands leaves the robot where it is."""
    kwargs = {} if "CCKA" in env_id else {"gravity": False}
    env = gym.make(
        env_id,
        robot="ftdcr_v4",
        action_mode="displacement",
        drive_max_tension=float("inf"),
        **kwargs,
    )
    try:
        p = env.unwrapped.params
        d = np.full(9, -0.0005)
        d[[0, 3, 6]] = [0.002, 0.004, 0.0075]
        _, info = env.reset(seed=0, options={"initial_displacements": d})
        start = info["tensions"].copy()
        assert start.max() > 2.0 * p.max_tension
        tip = env.unwrapped.core.backend.read().tip[0].copy()
        for _ in range(20):
            _, _, _, _, info = env.step(_action(d, p))
        np.testing.assert_allclose(info["tensions"], start, atol=0.02)
        np.testing.assert_allclose(env.unwrapped.core.backend.read().tip[0], tip, atol=5e-5)
    finally:
        env.close()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"drive_backlash": -1e-4}, "drive_backlash"),
        ({"drive_backlash": float("nan")}, "drive_backlash"),
        ({"drive_backlash": "0.1"}, "drive_backlash"),
        ({"drive_max_tension": 0.0}, "drive_max_tension"),
        ({"drive_max_tension": float("nan")}, "drive_max_tension"),
        ({"drive_max_tension": "big"}, "drive_max_tension"),
    ],
)
def test_bad_drive_options_name_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        _ccka(**kwargs)


@pytest.mark.parametrize("kwargs", [{"drive_backlash": 1e-4}, {"drive_max_tension": 5.0}])
def test_drive_options_need_a_displacement_mode(kwargs):
    with pytest.raises(ValueError, match="displacement action mode"):
        gym.make("cdcr_gym/CCKAReach-v0", action_mode="tension", **kwargs)


def test_twin_kwargs_of_a_fit(tmp_path):
    kw = twin_kwargs_from_yaml(FIT)
    tendons = load_yaml(FIT)["calibration"]["tendons"]
    assert kw["action_mode"] == "displacement"
    assert kw["drive_max_tension"] == np.inf  # the fit's drives had no cap
    assert kw["drive_backlash"] == tendons["backlash"]
    assert kw["gate_damping"] is True and kw["gravity"] is False
    tension = twin_kwargs_from_yaml(FIT, action_mode="tension")
    assert "drive_backlash" not in tension and "drive_max_tension" not in tension
    # a robot without a tendon drive: the backend arguments only
    doc = load_yaml(FIT)
    del doc["calibration"]["tendons"]
    path = tmp_path / "no_drive.yaml"
    path.write_text(dump_yaml(doc))
    assert "drive_backlash" not in twin_kwargs_from_yaml(path)
    # a malformed drive: the file named
    doc["calibration"]["tendons"] = {"stiffness": [1.0, 2.0], "pretension": 0.0}
    path.write_text(dump_yaml(doc))
    with pytest.raises(ValueError, match="no_drive.yaml"):
        twin_kwargs_from_yaml(path)


#: The first held-out rows replayed by both (40: about 20 s of the robot's motion).
ROWS = 40


def _twin_tips(kwargs: dict, replay: PhysicsReplay, robot: RobotParams) -> np.ndarray:
    """The tips (ROWS, 3) m of the twin env stepping the replay's control-step commands."""
    env = gym.make("cdcr_gym/MuJoCoReach-v0", params=str(FIT), **kwargs)
    try:
        env.reset(seed=0, options={"initial_displacements": np.zeros(robot.n_cables)})
        d, steps = replay.data.displacements, replay.steps
        assert d is not None
        tips = np.empty((ROWS, 3))
        previous = d[0]
        for m in range(ROWS):
            for k in range(1, int(steps[m]) + 1):
                cmd = d[m] if m == 0 else previous + (d[m] - previous) * (k / steps[m])
                _, _, _, _, info = env.step(_action(cmd, robot))
            tips[m] = info["tip"]
            previous = d[m]
        return tips
    finally:
        env.close()


@pytest.mark.parametrize("drop", [None, "drive_backlash", "drive_max_tension", "gate_damping"])
def test_twin_env_is_the_calibrated_model(drop):
    """The env built from the main MuJoCo fit with ``twin_kwargs_from_yaml`` steps through the
    held-out rows as the calibration replayed them: within 0.3 mm on the first 40 rows
    (measured: 0.21 mm at most, median 0.12 mm; the env plays the backlash on every control
    step, the replay on the rows). Without any one of the drive's cap, its backlash or the
    gated damping it is more than 1 mm off."""
    pytest.importorskip("mujoco")
    robot, backend = load_fitted(FIT)
    cal = load_yaml(FIT)["calibration"]
    drive = TendonDrive.from_dict(cal["tendons"], robot.n_cables, str(FIT))
    val = read_csv(ROOT / "data/real/ftdcr_v4/val.csv", robot=robot, drive=drive)
    values = {k: float(v) for k, v in cal["fitted"].items()}
    fixed = {k: v for k, v in backend.items() if k != "base_orientation"}
    replay = PhysicsReplay(val.subset(np.arange(ROWS)), robot, drive, "mujoco", fixed)
    want = replay.simulate([values])[0][0]
    kwargs = twin_kwargs_from_yaml(FIT)
    if drop is not None:
        kwargs.pop(drop)
    gap = np.linalg.norm(_twin_tips(kwargs, replay, robot) - want, axis=1)
    if drop is None:
        assert gap.max() < 3e-4
    else:
        assert gap.max() > 1e-3
