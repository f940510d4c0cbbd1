"""Cable–disk capstan friction in the pybullet backend (friction_coefficient > 0)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.model import friction as F
from cdcr_gym.params import RobotParams


def _segment_lengths(chain, q):
    """Per-span cable segment lengths (n_disks, C): from the pinholes (disk routing), else the
    via-point segments (``span_cable_lengths``, itself checked against the pinholes when b = 0)."""
    _, pins = chain.stations_and_pinholes(q)
    seg = pins[1:] - pins[:-1]
    pinhole = np.sqrt((seg * seg).sum(axis=-1)) * chain.routed  # (n_disks, C)
    via = chain.span_cable_lengths(q)
    if chain.routing == "disk":
        np.testing.assert_allclose(via, pinhole, rtol=1e-12, atol=1e-15)
        return pinhole
    return via


@pytest.mark.parametrize("routing", ["corrected", "disk"])
@pytest.mark.parametrize("links_per_span", [1, 2])
def test_per_segment_loads_match_finite_differences(links_per_span, routing):
    b = BulletBackend(gravity=False, links_per_span=links_per_span, routing=routing)
    try:
        chain = b.chain
        rng = np.random.default_rng(0)
        q = rng.uniform(-0.15, 0.15, chain.n_dof)
        seg_t = rng.uniform(0.0, 80.0, (chain.n_disks, 3))  # a different tension per segment
        tau, lengths = chain.cable_loads(q, seg_t)
        eps = 1e-6
        fd = np.empty_like(q)
        for j in range(q.size):
            dq = np.zeros_like(q)
            dq[j] = eps
            up = (seg_t * _segment_lengths(chain, q + dq)).sum()
            down = (seg_t * _segment_lengths(chain, q - dq)).sum()
            fd[j] = -(up - down) / (2 * eps)
        np.testing.assert_allclose(tau, fd, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(
            lengths, _segment_lengths(chain, q).sum(axis=0) + chain.rigid_lengths, rtol=1e-12
        )
        np.testing.assert_allclose(lengths, chain.cable_lengths(q), rtol=1e-12)
        # uniform per-segment tensions are the per-cable call
        uniform = np.broadcast_to(seg_t[0], seg_t.shape)
        np.testing.assert_allclose(
            chain.cable_loads(q, uniform)[0],
            chain.cable_loads(q, seg_t[0])[0],
            rtol=1e-12,
            atol=1e-12,
        )
    finally:
        b.close()


def _settle(b, tensions, steps=40):
    for _ in range(steps):
        b.apply_tensions(np.asarray(tensions, dtype=np.float64)[None])
    return b.read()


def test_zero_friction_is_the_frictionless_model_bit_for_bit():
    plain, rough0 = BulletBackend(), BulletBackend(friction_coefficient=0.0)
    try:
        rng = np.random.default_rng(1)
        for t in rng.uniform(0, 80, (15, 3)):
            plain.apply_tensions(t[None])
            rough0.apply_tensions(t[None])
            a, b = plain.read(), rough0.read()
            assert np.array_equal(a.tip, b.tip) and np.array_equal(a.cable_lengths, b.cable_lengths)
            assert b.anchor_tensions is None
    finally:
        plain.close()
        rough0.close()


def test_anchor_tension_is_the_capstan_decay_of_the_wraps():
    mu = 0.25
    b = BulletBackend(gravity=False, friction_coefficient=mu)
    try:
        r = _settle(b, [50.0, 0.0, 0.0])
        s = b.slip
        assert s[0] > 0.5  # pulled
        _, pins = b.chain.stations_and_pinholes(b.joint_positions)
        wraps = F.wrap_angles(pins[:, 0, :])
        assert wraps.sum() > 0.5  # bent: the cable wraps
        expected = 50.0 * np.exp(-s[0] * mu * wraps.sum())
        assert r.anchor_tensions[0, 0] == pytest.approx(expected, rel=1e-12)
        seg = b.segment_tensions[:, 0]
        ratios = seg / np.concatenate([[50.0], seg[:-1]])
        np.testing.assert_allclose(ratios, np.exp(-s[0] * mu * wraps), rtol=1e-12)
        assert np.all(np.diff(seg) < 0)  # falls towards the anchor while pulled
        # releasing reverses the slip: the tension rises towards the anchor
        r = _settle(b, [20.0, 0.0, 0.0])
        assert b.slip[0] < -0.5 and r.anchor_tensions[0, 0] > 20.0
    finally:
        b.close()


@pytest.mark.parametrize("mu", [0.0, 0.2])
def test_hysteresis_opens_with_friction_and_closes_without(mu):
    b = BulletBackend(gravity=False, friction_coefficient=mu)
    try:
        up = [_settle(b, [t, 0.0, 0.0]).tip[0] for t in (20.0, 40.0, 60.0, 80.0)]
        down = [_settle(b, [t, 0.0, 0.0]).tip[0] for t in (60.0, 40.0, 20.0)]
        width = np.linalg.norm(up[1] - down[1]) * 1000  # at 40 N, mm
        if mu == 0.0:
            assert width < 0.01
        else:
            assert width > 5.0
            # friction resists: the loading branch bends less, the unloading branch more
            assert np.linalg.norm(up[1][:2]) < np.linalg.norm(down[1][:2])
    finally:
        b.close()


@pytest.mark.slow
@pytest.mark.parametrize("gravity", [False, True])
def test_stable_over_long_random_runs_at_high_friction(gravity):
    b = BulletBackend(gravity=gravity, friction_coefficient=0.5)
    try:
        rng = np.random.default_rng(2)
        held = np.zeros(3)
        for _ in range(400):
            held = np.clip(held + rng.uniform(-16, 16, 3), 0.0, 80.0)
            b.apply_tensions(held[None])
            r = b.read()
            assert np.all(np.isfinite(r.tip)) and np.all(np.isfinite(r.anchor_tensions))
        for t in rng.uniform(0, 80, (40, 3)):  # and abrupt absolute commands
            b.apply_tensions(t[None])
            assert np.all(np.isfinite(b.read().tip))
    finally:
        b.close()


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), True, "0.2"])
def test_bad_friction_coefficient_is_named(bad):
    with pytest.raises(ValueError, match="friction_coefficient"):
        BulletBackend(friction_coefficient=bad)


def test_env_reports_anchor_tensions_and_two_section_robot_runs():
    env = gym.make("cdcr_gym/BulletReach-v0", friction_coefficient=0.2, action_mode="tension")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.5, -1, -1], np.float32))
    assert info["anchor_tensions"].shape == (3,)
    assert 0.0 < info["anchor_tensions"][0] < info["tensions"][0]
    env.close()
    env = gym.make("cdcr_gym/BulletReach-v0", robot="tdcr2", friction_coefficient=0.2)
    env.reset(seed=0)
    for _ in range(10):
        _, _, _, _, info = env.step(env.action_space.sample())
    assert np.all(np.isfinite(info["anchor_tensions"]))
    env.close()
    assert RobotParams.preset("tdcr2").n_cables == 6


def test_randomized_bullet_robot_acts_like_the_robot_built_with_those_parameters():
    dr = {"youngs_modulus": [30e9, 40e9], "friction_coefficient": [0.1, 0.3], "gravity": 0.5}
    env = gym.make("cdcr_gym/BulletReach-v0", randomize=dr, action_mode="tension")
    seen_gravity = set()
    try:
        for seed in (0, 1, 2, 3):
            _, info = env.reset(seed=seed)
            drawn = {k.split("/")[1]: v for k, v in info.items() if k.startswith("randomized/")}
            seen_gravity.add(drawn["gravity"])
            ref = BulletBackend(
                RobotParams(youngs_modulus=drawn["youngs_modulus"]),
                gravity=bool(drawn["gravity"]),
                friction_coefficient=drawn["friction_coefficient"],
            )
            try:
                a = np.array([0.2, -0.6, -1.0], np.float32)
                for _ in range(8):
                    _, _, _, _, info = env.step(a)
                    ref.apply_tensions(info["tensions"][None])
                r = ref.read()
                np.testing.assert_allclose(info["tip"], r.tip[0], rtol=0, atol=1e-9)
                np.testing.assert_allclose(info["anchor_tensions"], r.anchor_tensions[0], rtol=1e-9)
            finally:
                ref.close()
    finally:
        env.close()
    assert seen_gravity == {0.0, 1.0}


def test_capstan_prediction_of_the_hysteresis_study():
    from training.studies.hysteresis import capstan_equilibrium

    b = BulletBackend(gravity=False)
    try:
        # μ = 0: the frictionless static equilibrium
        frictionless = b.equilibrium(np.array([[50.0, 0.0, 0.0]])).tip[0]
        np.testing.assert_allclose(capstan_equilibrium(b, 50.0, 0.0), frictionless, atol=1e-9)
        # μ > 0: a pulled cable bends the robot less
        assert capstan_equilibrium(b, 50.0, 0.2)[0] < frictionless[0] - 0.005
    finally:
        b.close()


def _load_cable_one(b, levels, steps):
    """Cable 1 pulled in ``levels`` (N), ``steps`` control steps each, from rest at 0 N."""
    b.reset(np.zeros((1, 3)))
    out = []
    for t in levels:
        for _ in range(steps):
            b.apply_tensions(np.array([[t, 0.0, 0.0]]))
        out.append((b.tip.copy(), b.read().anchor_tensions, np.abs(b.joint_velocities).max()))
    return out


@pytest.mark.parametrize("links_per_span", [1, 2])
def test_loading_branch_bends_less_than_frictionless_and_settles(links_per_span):
    """Issue 21 item 4: loaded in 10 N steps, μ = 0.2 must bend *less* than μ = 0 at every
    level, settle (no stick–slip chatter), and its anchor must carry less than the actuator
    pulls. Before the implicit slip stiffness the slip state flipped every physics step
    (links_per_span=1: tip x 401.1 mm > 399.9 mm frictionless at 80 N, anchor 106.6 N)."""
    levels = (10.0, 30.0, 50.0, 80.0)
    rough = BulletBackend(gravity=False, links_per_span=links_per_span, friction_coefficient=0.2)
    plain = BulletBackend(gravity=False, links_per_span=links_per_span)
    try:
        up = _load_cable_one(rough, levels, 150)
        for (tip, anchor, speed), t in zip(up, levels):
            free = plain.equilibrium(np.array([[t, 0.0, 0.0]])).tip[0]
            assert tip[0] < free[0] - 1e-4  # bends less (x, m)
            assert 0.0 < anchor[0, 0] <= t  # pulled: the anchor carries less
            assert speed < 1e-6  # rad/s: settled, no chatter
        assert rough.slip[0] > 0.9  # pulled
    finally:
        rough.close()
        plain.close()


@pytest.mark.slow
def test_friction_settles_where_a_cosserat_rod_with_capstan_tensions_does():
    """Bullet (4 links per span) with μ = 0.2, loaded to 80 N, against an independent static
    Cosserat solve whose segment tensions are the capstan decay over the rod's own wrap angles
    (training.studies.cosserat.solve_static_capstan, at bullet's slip state): as close as
    the frictionless chain is to the rod (≈ 1 mm at 80 N), far below the friction effect."""
    from training.studies.cosserat import solve_static_capstan

    params = RobotParams()
    b = BulletBackend(gravity=False, links_per_span=4, friction_coefficient=0.2)
    try:
        ((tip, anchor, _),) = _load_cable_one(
            b, (10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0), 100
        )[-1:]
        rod, seg = solve_static_capstan(params, [80.0, 0.0, 0.0], 0.2, slip=float(b.slip[0]))
        free = b.equilibrium(np.array([[80.0, 0.0, 0.0]])).tip[0]
    finally:
        b.close()
    assert np.linalg.norm(tip - rod.tip) < 2.5e-3  # m
    assert np.linalg.norm(free - tip) > 15e-3  # the friction effect is much larger
    assert anchor[0, 0] == pytest.approx(seg[-1, 0], rel=0.01)


def test_load_unload_in_10_newton_steps_settles_at_every_hold():
    """Issue 21 item 4 on bullet (paper robot, gravity off, μ = 0.2, 10 N steps up to 80 N and
    back, 300 control steps per hold; ``training.studies.friction_chatter``): settled at every
    hold, on the loading branch while loading, above it while unloading. Before the slip law's
    slope was taken in the step's own sliding direction the first step back (70 N after 80 N)
    kept moving by 1.7 mm per 20 control steps (the stick stiffness of a reversing cable was
    left explicit)."""
    from training.studies.friction_chatter import branch_violations, frictionless_tips, load_unload

    rough = BulletBackend(gravity=False, friction_coefficient=0.2)
    plain = BulletBackend(gravity=False)
    try:
        holds = load_unload(rough, 300)
        assert branch_violations(holds, frictionless_tips(plain)) == []
    finally:
        rough.close()
        plain.close()
