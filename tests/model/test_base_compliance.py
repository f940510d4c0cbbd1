"""The compliant base (``RobotParams.base_compliance``): every drive loses c·Σ(T − T0) of its
pull. The law holds exactly in every solver (model statics, the law at a shape, the calibration's
batched drive solve, MuJoCo), c = 0 is the rigid base, and a fit recovers c from tip data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from cdcr_gym.calibration import Measurements, calibrate
from cdcr_gym.calibration.drive import TendonDrive, solve_drive
from cdcr_gym.calibration.simulate import DriveReplay, drive_geometry
from cdcr_gym.model.ik import drive_displacements, solve_displacement_ik
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import cached_model
from cdcr_gym.model.tendons import (
    common_load,
    holding_displacements,
    solve_displacement_statics,
    tendon_tensions,
)

C = 1.4e-5  # m/N, the order the v4 measurements give
V4 = RobotParams.preset("ftdcr_v4", base_compliance=C)


def _commands(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-0.004, 0.010, (n, V4.n_cables))


def _law(p: RobotParams, d, s, t):
    k, t0 = np.asarray(p.cable_stiffness), np.asarray(p.cable_pretension)
    give = p.base_compliance * (t.sum(-1, keepdims=True) - t0.sum())
    return np.clip(t0 + k * (d - s - give), 0.0, p.max_tension)


def test_statics_obey_the_law_with_the_base_term():
    d = _commands(300)
    st = solve_displacement_statics(cached_model(V4), d, V4.cable_stiffness, V4.cable_pretension)
    np.testing.assert_allclose(st.tensions, _law(V4, d, st.shortening, st.tensions), atol=1e-9)
    assert st.slack.any() and (~st.slack).any()
    rigid = solve_displacement_statics(
        cached_model(V4), d, V4.cable_stiffness, V4.cable_pretension, base_compliance=0.0
    )
    # the base's give relieves a robot loaded beyond its pretension: less total tension
    loaded = rigid.tensions.sum(1) > sum(V4.cable_pretension) + 5.0
    assert loaded.sum() > 50
    assert np.mean(st.tensions.sum(1)[loaded] < rigid.tensions.sum(1)[loaded]) > 0.95


def test_zero_compliance_is_the_rigid_law():
    p0 = dataclasses.replace(V4, base_compliance=0.0)
    d = _commands(50, seed=1)
    a = solve_displacement_statics(cached_model(p0), d, p0.cable_stiffness, p0.cable_pretension)
    b = solve_displacement_statics(
        cached_model(V4), d, V4.cable_stiffness, V4.cable_pretension, base_compliance=0.0
    )
    np.testing.assert_allclose(a.tensions, b.tensions, atol=1e-12)
    s = np.random.default_rng(2).uniform(0.0, 0.006, d.shape)
    t, _, _ = tendon_tensions(d, s, 7000.0, 1.0, 9.0, 0.0)
    np.testing.assert_allclose(t, np.clip(1.0 + 7000.0 * (d - s), 0.0, 9.0), atol=1e-12)


def test_the_law_at_a_shape_is_exact():
    rng = np.random.default_rng(3)
    free = rng.normal(3.0, 6.0, (2000, 9))
    a = rng.uniform(0.0, 0.3, (2000, 9))
    for cap in (np.inf, 9.0):
        total = common_load(free, a, cap)
        residual = np.clip(free - a * total[:, None], 0.0, cap).sum(1) - total
        assert np.max(np.abs(residual)) < 1e-9
    d, s = _commands(40, seed=4), rng.uniform(0.0, 0.008, (40, 9))
    t, slack, _ = tendon_tensions(d, s, V4.cable_stiffness, V4.cable_pretension, 9.0, C)
    np.testing.assert_allclose(t, _law(dataclasses.replace(V4, max_tension=9.0), d, s, t))
    assert np.all(t[slack] == 0.0)


def test_calibration_drive_solve_equals_the_model_solver():
    d = _commands(60, seed=5)
    drive = TendonDrive.of(V4)
    assert drive is not None and drive.base_compliance == C
    ours = solve_drive(drive_geometry(V4, drive, [{}]), d)
    ref = solve_displacement_statics(
        cached_model(V4), d, V4.cable_stiffness, V4.cable_pretension, np.inf
    )
    np.testing.assert_allclose(ours.tensions[0], ref.tensions, rtol=1e-7, atol=1e-7)
    np.testing.assert_array_equal(ours.slack[0], ref.slack)


def test_displacement_ik_inverts_the_compliant_statics():
    model = cached_model(V4)
    d = np.clip(_commands(6, seed=6), *V4.displacement_range)
    st = solve_displacement_statics(model, d, V4.cable_stiffness, V4.cable_pretension)
    goal = model.tip_from_bending(st.bending)
    sol = solve_displacement_ik(goal, V4)
    assert np.max(sol.residual) < 1e-9
    # the displacements that hold a state include the base's give
    taut = ~(st.slack | st.saturated)
    assert taut.sum() > 10
    back = drive_displacements(st.tensions, st.bending, V4)
    np.testing.assert_allclose(back[taut], d[taut], atol=1e-12)


def test_fit_recovers_the_base_compliance():
    """Tips of a robot with a known compliant base (and frame), 0.05 mm noise: the fit gives c
    within 5 % and the frame within 0.3 mm."""
    rng = np.random.default_rng(7)
    d = rng.uniform(-0.004, 0.010, (200, 9))
    rigid = RobotParams.preset("ftdcr_v4")
    drive = TendonDrive.of(rigid)
    truth = {"base_compliance": 2.0e-5, "base_x": 0.8e-3, "base_z": -1.5e-3}
    template = Measurements(None, np.zeros((200, 3)), None, None, displacements=d)
    tip = DriveReplay(template, rigid, drive)(truth).tip + rng.normal(0.0, 0.05e-3, (200, 3))
    data = Measurements(None, tip, None, None, displacements=d)
    res = calibrate(data, rigid, "base_compliance,base_x,base_y,base_z", "ccka", drive=drive)
    assert abs(res.values["base_compliance"] / truth["base_compliance"] - 1) < 0.05
    assert abs(res.values["base_x"] - truth["base_x"]) < 0.3e-3
    assert abs(res.values["base_z"] - truth["base_z"]) < 0.3e-3
    assert res.params.base_compliance == pytest.approx(res.values["base_compliance"])


@pytest.mark.parametrize("bad", [-1e-6, float("nan"), float("inf"), "1e-5", True])
def test_bad_base_compliance_names_the_field(bad):
    with pytest.raises(ValueError, match="base_compliance"):
        RobotParams.preset("ftdcr_v4", base_compliance=bad)


def test_inextensible_tendons_refuse_a_compliant_base():
    with pytest.raises(ValueError, match="base_compliance"):
        solve_displacement_statics(cached_model(V4), _commands(2), np.inf, 0.0)


def test_yaml_round_trip_keeps_the_base():
    assert RobotParams.from_yaml(V4.to_yaml()) == V4
    assert "base_compliance" in V4.to_yaml()


def test_mujoco_settles_on_the_compliant_statics():
    """MuJoCo (gravity off) under three commands: its static solve holds (a dynamic hold from
    there moves < 0.1 mm), its tensions obey the law with the base term at its own shape, and
    its tips are within 2 % of the length of CCKA's, as with a rigid base (measured 3.3 mm
    and 3.2 mm at most)."""
    from cdcr_gym.backends.analytic import AnalyticBackend
    from cdcr_gym.backends.mujoco.backend import MuJoCoBackend

    d = np.zeros((3, 9))
    d[0, [0, 3, 6]] = 0.006
    d[1, [0, 3, 6, 1, 4, 7]] = [0.008, 0.008, 0.008, -0.002, -0.002, -0.002]
    d[2, 0] = 0.004
    gaps = {}
    for c in (0.0, C):
        p = dataclasses.replace(V4, base_compliance=c)
        backend = MuJoCoBackend(params=p, gravity=False)
        try:
            backend.enable_displacement_control()
            eq = backend.displacement_equilibrium(d)
            s = backend.straight_cable_lengths - eq.cable_lengths
            np.testing.assert_allclose(eq.tensions, _law(p, d, s, eq.tensions), atol=1e-6)
            ref = AnalyticBackend(params=p).displacement_equilibrium(d)
            gaps[c] = np.linalg.norm(eq.tip - ref.tip, axis=1)
            backend.reset(eq.tensions[:1])
            for _ in range(50):
                backend.apply_displacements(d[:1])
            assert np.linalg.norm(backend.read().tip[0] - eq.tip[0]) < 1e-4
            np.testing.assert_allclose(backend.read().tensions[0], eq.tensions[0], atol=0.05)
        finally:
            backend.close()
    assert np.all(gaps[C] < 0.02 * V4.length) and np.all(gaps[0.0] < 0.02 * V4.length), gaps
    with pytest.raises(ValueError, match="base_compliance"):
        MuJoCoBackend(params=V4).set_drive_parameters([0], np.ones((1, 9)), np.ones((1, 9)), [-1.0])


def test_mujoco_robots_carry_their_own_base_compliance():
    """A batched MuJoCo model with per-robot c (a calibration's Jacobian columns): each robot
    settles where a backend built with that c alone does."""
    from cdcr_gym.backends.mujoco.backend import MuJoCoBackend

    d = np.zeros((2, 9))
    d[:, [0, 3, 6]] = 0.006
    kw = {"gravity": False, "physics_timestep": 0.04, "control_timestep": 0.04}
    batched = MuJoCoBackend(params=V4, num_robots=2, **kw)
    k, t0 = np.tile(V4.cable_stiffness, (2, 1)), np.tile(V4.cable_pretension, (2, 1))
    batched.set_drive_parameters([0, 1], k, t0, [C, 0.0])
    for _ in range(50):
        batched.apply_displacements(d)
    tips = batched.read().tip
    for i, c in enumerate((C, 0.0)):
        alone = MuJoCoBackend(params=dataclasses.replace(V4, base_compliance=c), **kw)
        for _ in range(50):
            alone.apply_displacements(d[:1])
        np.testing.assert_allclose(tips[i], alone.read().tip[0], atol=1e-6)
    assert np.linalg.norm(tips[0] - tips[1]) > 5e-3  # the give matters: > 5 mm here


def test_bullet_settles_on_the_compliant_law_beside_mujoco():
    """pybullet with a compliant base (gravity off): the settled tensions obey the law with the
    base term, and the tip is within 1 mm of MuJoCo's static solve (measured 0.3 mm)."""
    from cdcr_gym.backends.bullet.backend import BulletBackend
    from cdcr_gym.backends.mujoco.backend import MuJoCoBackend

    d = np.zeros((1, 9))
    d[0, [0, 3, 6]] = 0.006
    bullet = BulletBackend(params=V4, gravity=False)
    try:
        for _ in range(150):
            bullet.apply_displacements(d)
        r = bullet.read()
    finally:
        bullet.close()
    s = bullet.straight_cable_lengths - r.cable_lengths
    np.testing.assert_allclose(r.tensions, _law(V4, d, s, r.tensions), atol=1e-6)
    ref = MuJoCoBackend(params=V4, gravity=False).displacement_equilibrium(d)
    assert np.linalg.norm(r.tip - ref.tip) < 1e-3


def test_holding_displacements_invert_the_law():
    """d = s + (T − T0)/k + c·Σ(T − T0) is the command under which the law gives back T at the
    shape s (every tendon taut); with c = 0 the base's give drops out."""
    rng = np.random.default_rng(4)
    d = rng.uniform(0.003, 0.004, (6, V4.n_cables))
    s = rng.uniform(0.0, 0.0002, (6, V4.n_cables))
    k, t0 = V4.cable_stiffness, V4.cable_pretension
    for c in (C, 0.0):
        t, slack, _ = tendon_tensions(d, s, k, t0, None, c)
        assert not slack.any()
        np.testing.assert_allclose(holding_displacements(s, t, k, t0, c), d, atol=1e-15)
    t, _, _ = tendon_tensions(d, s, k, t0, None, C)
    off = holding_displacements(s, t, k, t0, 0.0) - d  # without the give: short by c·Σ(T − T0)
    np.testing.assert_allclose(
        off, np.broadcast_to(-C * (t - np.asarray(t0)).sum(-1, keepdims=True), d.shape)
    )


@pytest.mark.parametrize("mode", ["displacement", "displacement_delta"])
def test_env_reset_rests_with_a_compliant_base(mode):
    """A random start in a displacement mode: the drives hold the reset shape (the base's give
    included), so holding still leaves the robot where it is."""
    import gymnasium as gym

    import cdcr_gym  # noqa: F401  (registers the envs)

    env = gym.make("cdcr_gym/CCKAReach-v0", params=V4, action_mode=mode, initial_state="random")
    try:
        _, info = env.reset(seed=3)
        start, tip = info["tensions"].copy(), env.unwrapped.core.backend.read().tip[0].copy()
        assert start.sum() > 5.0  # a loaded start: the give matters
        if mode == "displacement":
            low, high = V4.displacement_range
            hold = 2.0 * (info["displacements"] - low) / (high - low) - 1.0
        else:
            hold = np.zeros(V4.n_cables)
        _, _, _, _, info = env.step(hold.astype(np.float32))
        np.testing.assert_allclose(info["tensions"], start, atol=1e-6)
        np.testing.assert_allclose(env.unwrapped.core.backend.read().tip[0], tip, atol=1e-8)
    finally:
        env.close()


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"tensions": np.full(9, np.nan)}, "tensions"),
        ({"shortening": np.zeros(8)}, "shortening and tensions"),
        ({"stiffness": -1.0}, "stiffness"),
        ({"pretension": -0.5}, "pretension"),
        ({"base_compliance": -1e-5}, "base_compliance"),
    ],
)
def test_holding_displacements_refuse_bad_input(kwargs, name):
    args = {
        "shortening": np.zeros(9),
        "tensions": np.ones(9),
        "stiffness": 7000.0,
        "pretension": 0.5,
        "base_compliance": C,
    }
    with pytest.raises(ValueError, match=name):
        holding_displacements(**{**args, **kwargs})
