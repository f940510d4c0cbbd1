"""The MuJoCo backend (``cdcr_gym.backends.mujoco``) and its ids ``cdcr_gym/MuJoCo*-v0``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.backends.bullet import SimulationDivergedError as BulletDiverged
from cdcr_gym.backends.mujoco import MuJoCoBackend, SimulationDivergedError, build_mjcf
from cdcr_gym.backends.mujoco import backend as mj_backend
from cdcr_gym.model import friction as F
from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.params import RobotParams, SectionParams

THREE_SECTIONS = RobotParams(
    sections=(
        SectionParams(0.2, 6, 0.012, (0.0, 2.0, 4.0)),
        SectionParams(0.15, 5, 0.010, (0.5, 2.5, 4.5)),
        SectionParams(0.1, 4, 0.008, (1.0, 3.0, 5.0)),
    ),
    youngs_modulus=54e9,
    backbone_diameter=0.0014,
    max_tension=1.0,
    disk_mass=0.0002,
    disk_radius=0.015,
    disk_thickness=0.001,
)
ROBOTS = {
    "paper": RobotParams.preset("paper"),
    "tdcr2": RobotParams.preset("tdcr2"),
    "three": THREE_SECTIONS,
}


def _model(params, **kwargs):
    mjcf = build_mjcf(params, **kwargs)
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    return mjcf, model, mujoco.MjData(model)


# -- the MJCF model -----------------------------------------------------------------------------
@pytest.mark.parametrize("robot", sorted(ROBOTS))
@pytest.mark.parametrize("joint", ["ball", "cardan"])
@pytest.mark.parametrize("routing", ["corrected", "disk"])
@pytest.mark.parametrize("links_per_span", [1, 2])
def test_mjcf_of_one_two_three_sections_has_one_tendon_and_actuator_per_cable(
    robot, joint, routing, links_per_span
):
    params = ROBOTS[robot]
    mjcf, model, data = _model(params, joint=joint, routing=routing, links_per_span=links_per_span)
    n = sum(s.n_disks for s in params.sections) * links_per_span
    assert mjcf.n_links == n and model.nbody == n + 2  # world, base, links
    assert model.njnt == (n if joint == "ball" else 2 * n)
    assert model.ntendon == params.n_cables and model.nu == params.n_cables
    assert np.all(model.actuator_gear[:, 0] == -1.0)  # a positive tension shortens
    np.testing.assert_array_equal(model.actuator_ctrlrange[:, 1], params.max_tension)
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    # masses: the discretised chain's
    np.testing.assert_allclose(
        model.body_mass[2:], DiscreteBackbone(params, links_per_span).link_masses, rtol=1e-12
    )
    # straight: every tendon is exactly its cable's run (the proximal sections' too)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.ten_length, params.cable_run_lengths, rtol=0, atol=1e-12)
    np.testing.assert_allclose(data.site("tip").xpos, (0, 0, params.length), atol=1e-12)


def _arc_lengths(params, theta, phi):
    """PCC cable lengths with every section bent by theta (rad) in the plane phi."""
    out = []
    for section_of_cable, r, beta in zip(
        params.cable_section, params.cable_radii, params.cable_angles
    ):
        run = 0.0
        for j in range(section_of_cable + 1):
            s = params.sections[j]
            run += s.length - r * theta * s.length / params.length * math.cos(phi - beta)
        out.append(run)
    return np.array(out)


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
@pytest.mark.parametrize("routing", ["corrected", "disk"])
@pytest.mark.parametrize("links_per_span", [1, 3])
def test_tendon_lengths_of_a_held_arc_are_the_pcc_lengths_within_the_chord_effect(
    robot, routing, links_per_span
):
    """An arc of total bend θ in the plane φ held by the ball joints (every joint turns α = κΔ
    about the same axis): tendon lengths = PCC lengths ℓ − rθ·cos(φ − β) up to the straight
    chords' shortening Σ R(α − 2 sin(α/2)) ≈ l_pcc·(κh)²/24 per cable (h the disk span), the
    physical discrete-routing effect, with the corrected routing; (1 + 2/m²) times that with
    the straight pinhole-to-pinhole routing (the polygon vertices' excess); 10 % margin for
    the higher orders."""
    params = ROBOTS[robot]
    mjcf, model, data = _model(params, joint="ball", routing=routing, links_per_span=links_per_span)
    theta, phi = 1.2, 0.7
    kappa = theta / params.length
    axis = np.array([-math.sin(phi), math.cos(phi), 0.0])
    for j in range(mjcf.n_links):
        alpha = kappa * mjcf.chain.segment_lengths[j]
        data.qpos[4 * j : 4 * j + 4] = [math.cos(alpha / 2), *(math.sin(alpha / 2) * axis)]
    mujoco.mj_forward(model, data)
    pcc = _arc_lengths(params, theta, phi)
    h = max(s.disk_spacing for s in params.sections)
    excess = 1.0 if routing == "corrected" else 1.0 + 2.0 / links_per_span**2
    tolerance = 1.1 * excess * pcc * (kappa * h) ** 2 / 24
    error = np.abs(data.ten_length - pcc)
    assert np.all(error <= tolerance), (error, tolerance)
    # and the tip lies on the arc to the same order
    tip = np.array(
        [
            (1 - math.cos(theta)) / kappa * math.cos(phi),
            (1 - math.cos(theta)) / kappa * math.sin(phi),
            math.sin(theta) / kappa,
        ]
    )
    assert np.linalg.norm(data.site("tip").xpos - tip) < params.length * (kappa * h) ** 2


# -- statics and dynamics -----------------------------------------------------------------------
@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_dynamics_settle_at_the_static_equilibrium_and_a_reset_stays_put(robot):
    params = ROBOTS[robot]
    b = MuJoCoBackend(params)
    t = np.zeros((1, params.n_cables))
    t[0, 0], t[0, -1] = params.max_tension, 0.5 * params.max_tension
    eq = b.equilibrium(t)
    for _ in range(150):  # 3 s
        b.apply_tensions(t)
    r = b.read()
    np.testing.assert_allclose(r.tip, eq.tip, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.cable_lengths, eq.cable_lengths, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(r.tip_direction), 1.0, atol=1e-12)
    b.reset(t)
    np.testing.assert_allclose(b.read().tip, eq.tip, rtol=0, atol=1e-12)
    b.apply_tensions(t)
    np.testing.assert_allclose(b.read().tip, eq.tip, rtol=0, atol=1e-10)
    # readings are the tendon lengths MuJoCo computes, and the rendering geometry agrees
    data = b._datas[0]
    mujoco.mj_forward(b.model, data)
    np.testing.assert_array_equal(b.read().cable_lengths[0], data.ten_length[: params.n_cables])
    pts = b.backbone_points(0)
    centres, rots = b.disk_frames(0)
    assert pts.shape == (2 * b.n_links + 1, 3) and centres.shape == (b.mjcf.chain.n_disks + 1, 3)
    np.testing.assert_allclose(pts[-1], eq.tip[0], atol=1e-9)
    np.testing.assert_allclose(centres[-1], eq.tip[0], atol=1e-9)
    np.testing.assert_allclose(
        rots @ rots.transpose(0, 2, 1), np.broadcast_to(np.eye(3), rots.shape), atol=1e-9
    )
    b.close()
    b.close()
    with pytest.raises(RuntimeError, match="closed"):
        b.read()


@pytest.mark.parametrize("routing", ["disk", "corrected"])
@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_same_discretisation_settles_where_bullet_settles(robot, routing):
    """``links_per_span=1, joint="cardan"`` is bullet's model, with either routing (one
    implementation of the routing geometry, ``cdcr_gym.model.discrete``): the settled tips agree
    to 0.1 mm with gravity (measured ≈ 1e-9 m: the same equilibrium), the cable lengths to 1 µm."""
    params = ROBOTS[robot]
    mj = MuJoCoBackend(params, links_per_span=1, joint="cardan", routing=routing)
    bullet = BulletBackend(params, links_per_span=1, routing=routing)
    rng = np.random.default_rng(4)
    tensions = rng.uniform(0, params.max_tension, (3, params.n_cables))
    tensions[0] = 0.0
    tensions[1, 1:] = 0.0
    try:
        ours, theirs = mj.equilibrium(tensions), bullet.equilibrium(tensions)
        assert np.max(np.linalg.norm(ours.tip - theirs.tip, axis=1)) <= 1e-4
        np.testing.assert_allclose(ours.cable_lengths, theirs.cable_lengths, rtol=0, atol=1e-6)
        # and MuJoCo's dynamics settle there (3 s)
        for _ in range(150):
            mj.apply_tensions(tensions[2:])
        assert np.linalg.norm(mj.read().tip[0] - theirs.tip[2]) <= 1e-4
        # the unloaded robot sags under gravity by the same amount (a bent robot shows it)
        assert np.linalg.norm(ours.tip[0] - theirs.tip[0]) <= 1e-4
    finally:
        mj.close()
        bullet.close()


def test_turned_base_sags_like_bullet_and_readings_stay_in_the_base_frame():
    """A horizontal base (backbone along +X_world): the cantilever sags under its weight, ≈ 38 mm
    (SPEC §4), along −x of R0 (gravity turned into R0); bullet's model gives the same
    equilibria."""
    quat = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))
    mj = MuJoCoBackend(base_orientation=quat, joint="cardan", routing="disk")
    bullet = BulletBackend(base_orientation=quat, routing="disk")
    t = np.array([[0.0, 0.0, 0.0], [80.0, 0.0, 0.0]])
    try:
        ours, theirs = mj.equilibrium(t).tip, bullet.equilibrium(t).tip
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)
        assert 0.035 < ours[0, 0] < 0.041 and abs(ours[0, 1]) < 1e-12
        assert mj.read().tip[0, 0] == pytest.approx(ours[0, 0], abs=1e-12)  # reset rests there
    finally:
        mj.close()
        bullet.close()


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
@pytest.mark.parametrize("gravity", [False, True])
def test_default_is_within_half_a_percent_of_the_converged_chain(robot, gravity):
    """Default MuJoCo (one link per span, ball joints, corrected routing) against the converged
    discrete-disk rod, at the maximum tension of single cables and of a cable pair (both
    sections of tdcr2 loaded): ≤ 0.5 % of ℓ (measured ≤ 0.2 %). Reference: eight ball-jointed
    links per span with the cable straight from pinhole to pinhole (no routing correction: its
    only discretisation error is the (1 + 2/m²) moment-arm excess, 3 % of the physical
    discrete-routing effect at m = 8); Cardan chains converge only at O(1/m) out of the x and
    y planes (their twist), so they are no reference there."""
    params = ROBOTS[robot]
    c, t_max = params.n_cables, params.max_tension
    pair = np.where(np.arange(c) % 3 == 1, t_max, 0.0) + np.where(
        np.arange(c) % 3 == 2, 0.5 * t_max, 0.0
    )
    cases = np.array([np.eye(c)[0] * t_max, np.eye(c)[-1] * t_max, pair])
    ours = MuJoCoBackend(params, gravity=gravity).equilibrium(cases).tip
    ref = MuJoCoBackend(params, gravity=gravity, links_per_span=8, routing="disk")
    error = np.linalg.norm(ours - ref.equilibrium(cases).tip, axis=1)
    assert np.all(error <= 0.005 * params.length), error / params.length
    # and bullet's default discretisation is far off (what the default buys)
    coarse = MuJoCoBackend(params, gravity=gravity, joint="cardan", routing="disk")
    assert (
        np.max(np.linalg.norm(coarse.equilibrium(cases).tip - ref.equilibrium(cases).tip, axis=1))
        > 0.01 * params.length
    )


COSSERAT_REFERENCE = (
    Path(__file__).resolve().parents[2] / "docs/figures/physics/cosserat_reference.json"
)


def test_default_is_within_half_a_percent_of_the_cosserat_reference():
    """Every case of the committed Cosserat-rod reference (its robot, gravity and tensions):
    the default MuJoCo env's settled tip within 0.5 % of ℓ of the rod's."""
    cases = json.loads(COSSERAT_REFERENCE.read_text())["cases"]
    assert cases
    groups: dict = {}
    for case in cases:
        groups.setdefault((case["robot"], bool(case["gravity"])), []).append(case)
    checked = set()
    for (robot, gravity), group in groups.items():
        params = RobotParams.preset(robot)
        tensions = np.array([c["tensions"] for c in group], dtype=float)
        assert tensions.max() <= params.max_tension  # every case is inside the action range
        ours = MuJoCoBackend(params, gravity=gravity).equilibrium(tensions).tip
        error = np.linalg.norm(ours - np.array([c["tip"] for c in group]), axis=1)
        assert np.all(error <= 0.005 * params.length), (robot, gravity, error / params.length)
        checked.add((robot, gravity))
    assert checked == {(r, g) for r in ("paper", "tdcr2") for g in (False, True)}


def test_static_solve_finds_the_settled_state_where_the_plain_iteration_oscillates():
    """tdcr2 with gravity and every cable near max_tension: the plain fixed-point iteration
    oscillates (MuJoCoPose-v0 goal sampling failed there with "no static equilibrium"); the
    relaxed restart finds the state the dynamics settle to, and resets hold it."""
    backend = MuJoCoBackend(ROBOTS["tdcr2"], gravity=True)
    t = np.array([[5.2686, 5.0532, 5.9195, 5.1965, 5.8729, 5.9842]])
    data, model = backend._scratch, backend.model
    assert not backend._solve_static(model, data, t[0], relaxations=(1.0,))
    tip = backend.equilibrium(t).tip
    backend.reset(np.zeros((1, 6)))
    for _ in range(400):  # 8 s of dynamics from the straight robot
        backend.apply_tensions(t)
    np.testing.assert_allclose(backend.read().tip, tip, atol=1e-9)
    backend.reset(t)
    for _ in range(50):
        backend.apply_tensions(t)
    np.testing.assert_allclose(backend.read().tip, tip, atol=1e-9)


# -- friction -----------------------------------------------------------------------------------
def _run(backend, steps):
    rng = np.random.default_rng(0)
    c, t_max = backend.params.n_cables, backend.params.max_tension
    out = []
    for k in range(steps):
        if k % 5 == 0:
            t = rng.uniform(0, t_max, (backend.num_robots, c))
        backend.apply_tensions(t)
        r = backend.read()
        out.append(
            np.concatenate([r.tip.ravel(), r.tip_direction.ravel(), r.cable_lengths.ravel()])
        )
    return np.array(out)


def test_zero_friction_is_the_frictionless_model_bit_for_bit():
    plain = MuJoCoBackend()
    explicit = MuJoCoBackend(friction_coefficient=0.0)
    segmented = MuJoCoBackend()  # a model with friction segments (an episode drew μ > 0), μ = 0
    segmented.set_randomized(np.array([0]), {"friction_coefficient": np.array([0.1])})
    segmented.set_randomized(np.array([0]), {"friction_coefficient": np.array([0.0])})
    assert segmented._has_segments and not plain._has_segments
    segmented.reset(np.zeros((1, 3)))
    a, b, c = _run(plain, 40), _run(explicit, 40), _run(segmented, 40)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert plain.read().anchor_tensions is None


def _capstan_statics(params, tensions, mu, slip):
    """Independent static solve of bullet's chain (m = 1, no gravity) loaded span by span by the
    capstan profile at the equilibrium's own wrap angles (fixed point over the shape)."""
    chain = DiscreteBackbone(params, 1, gravity=False)
    q = np.zeros(chain.n_dof)
    for _ in range(60):
        pins = chain.stations_and_pinholes(q)[1]
        wraps = F.wrap_angles(pins.transpose(1, 0, 2))
        seg = F.tension_profile(tensions, wraps, mu, slip).T  # (n_disks, C)
        q_new, ok = chain.static_equilibrium(seg, tol=1e-14)
        assert ok
        if np.max(np.abs(q_new - q)) < 1e-13:
            break
        q = q_new
    return chain.stations_and_pinholes(q_new)[0][-1], seg


def test_loading_branch_bends_less_with_friction_as_the_capstan_statics_say():
    """Paper robot, gravity off, cable 1 pulled quasi-statically (a 4 s ramp) to 80 N: with
    μ = 0.2 the tip bends less than without friction (the tension falls towards the anchor),
    and it settles where an independent static solve with the capstan-decayed segment
    tensions (at the backend's slip state) puts it. (Abrupt 10 N steps with ζ = 0.7 overshoot:
    the spring-back slides the cable back by more than the slip length, the slip state flips to
    "releasing" and the robot then bends further, as issue 21 measured on bullet;
    ``docs/mujoco_backend.md``.)"""
    tips, backends = {}, {}
    for mu in (0.0, 0.2):
        b = MuJoCoBackend(gravity=False, friction_coefficient=mu, joint="cardan", routing="disk")
        for k in range(200):
            b.apply_tensions(np.array([[80.0 * (k + 1) / 200, 0.0, 0.0]]))
        for _ in range(100):
            b.apply_tensions(np.array([[80.0, 0.0, 0.0]]))
        tips[mu], backends[mu] = b.read(), b
    assert tips[0.2].tip[0, 0] < tips[0.0].tip[0, 0] - 0.015  # ≈ 21 mm less
    assert 50.0 < tips[0.2].anchor_tensions[0, 0] < 80.0
    slip = backends[0.2].slip[0]
    assert slip[0] > 0.9  # pulled
    ref_tip, seg = _capstan_statics(RobotParams(), np.array([80.0, 0.0, 0.0]), 0.2, slip)
    assert np.linalg.norm(tips[0.2].tip[0] - ref_tip) < 1e-5
    np.testing.assert_allclose(tips[0.2].anchor_tensions[0, 0], seg[-1, 0], rtol=1e-6)


def test_load_unload_in_10_newton_steps_settles_at_every_hold():
    """Issue 21 item 4 on MuJoCo (paper robot, gravity off, μ = 0.2, 300 control steps per
    hold, ζ = 1: no overshoot, so that every step stays on its branch). Before the slip state
    was implicit in the step (``backends/mujoco/friction.py``) the tip kept moving by 1.1–1.5
    mm per 20 steps from 50 N up and the anchor read 105 N at 80 N (slip cycling)."""
    from training.studies.friction_chatter import branch_violations, frictionless_tips, load_unload

    b = MuJoCoBackend(gravity=False, friction_coefficient=0.2, damping_ratio=1.0)
    holds = load_unload(b, 300)
    assert branch_violations(holds, frictionless_tips(MuJoCoBackend(gravity=False))) == []


def test_load_unload_settles_with_the_default_damping():
    """The same protocol with the default ζ = 0.7 (steps overshoot): still settled at every
    hold (the overshoot may leave the first load step's slip released, so only settling and
    the loading branch's tip at 80 N are checked)."""
    from training.studies.friction_chatter import load_unload

    holds = load_unload(MuJoCoBackend(gravity=False, friction_coefficient=0.2), 300)
    assert max(h.motion for h in holds) < 1e-5
    top = next(h for h in holds if h.tension == 80.0)
    assert top.anchor < 70.0 and top.slip > 0.9
    assert top.tip_x < 0.3837 - 0.015  # m, μ = 0 at 80 N (ball joints): ≈ 19 mm less


def test_loading_branch_of_the_10_newton_steps_is_the_capstan_rod():
    """The 80 N hold of the 10 N-step loading (ζ = 1) against an independent static Cosserat
    solve with capstan-decayed tensions at the backend's slip state
    (``training.studies.cosserat.solve_static_capstan``): within 1.5 mm (measured 0.89 mm; the
    frictionless chain is 1.13 mm from the frictionless rod at 80 N, the friction effect ≈ 20
    mm)."""
    from training.studies.cosserat import solve_static_capstan
    from training.studies.friction_chatter import load_unload

    b = MuJoCoBackend(gravity=False, friction_coefficient=0.2, damping_ratio=1.0)
    levels = tuple(float(t) for t in range(10, 90, 10))
    top = load_unload(b, 200, levels)[-1]
    tip = b.read().tip[0]
    rod, seg = solve_static_capstan(RobotParams(), [80.0, 0.0, 0.0], 0.2, slip=top.slip)
    assert top.slip > 0.9
    assert np.linalg.norm(tip - rod.tip) < 1.5e-3  # m
    assert top.anchor == pytest.approx(seg[-1, 0], rel=0.01)


# -- arguments and errors -----------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"links_per_span": 0}, "links_per_span"),
        ({"links_per_span": 1.5}, "links_per_span"),
        ({"joint": "universal"}, "joint"),
        ({"routing": "pulleys"}, "routing"),
        ({"gravity": "yes"}, "gravity"),
        ({"physics_timestep": -0.01}, "physics_timestep"),
        ({"physics_timestep": 0.03}, "physics_timestep"),
        ({"control_timestep": math.nan}, "control_timestep"),
        ({"damping_ratio": 0.0}, "damping_ratio"),
        ({"tip_payload": -1.0}, "tip_payload"),
        ({"friction_coefficient": 1.5}, "friction_coefficient"),
        ({"friction_slip_length": 0.0}, "friction_slip_length"),
        ({"base_orientation": (0, 0, 0, 2)}, "base_orientation"),
        ({"integrator": "Verlet"}, "integrator"),
        ({"num_robots": 0}, "num_robots"),
        ({"threads": 0}, "threads"),
        ({"params": "paper"}, "params"),
        ({"solid_obstacles": 1}, "solid_obstacles"),
        # more than tdcr2 holds bent under gravity (bullet refuses it too)
        ({"params": ROBOTS["tdcr2"], "tip_payload": 0.05}, "tip_payload"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        MuJoCoBackend(**kwargs)


def test_a_payload_is_checked_only_under_gravity_and_a_light_one_passes():
    # the shared check (cdcr_gym.model.statics.check_tip_payload) with MuJoCo's static solve
    MuJoCoBackend(ROBOTS["tdcr2"], tip_payload=0.05, gravity=False).close()
    MuJoCoBackend(ROBOTS["paper"], tip_payload=0.5).close()
    with pytest.raises(ValueError, match=r"tip_payload=1\.5 kg"):
        MuJoCoBackend(ROBOTS["paper"], tip_payload=1.5)


def test_bad_tensions_and_buckling_robots_are_refused():
    b = MuJoCoBackend()
    with pytest.raises(ValueError, match="tensions"):
        b.apply_tensions(np.array([[90.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match="tensions"):
        b.apply_tensions(np.array([[np.nan, 0.0, 0.0]]))
    with pytest.raises(ValueError, match="tensions"):
        b.equilibrium(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="buckles"):
        MuJoCoBackend(RobotParams(n_disks=3))


def test_divergence_raises_the_named_error():
    assert SimulationDivergedError is BulletDiverged  # one error for every backend
    assert mj_backend._BADQACC == int(mujoco.mjtWarning.mjWARN_BADQACC)
    b = MuJoCoBackend(physics_timestep=0.1, control_timestep=0.2, damping_ratio=0.01)
    with pytest.raises(SimulationDivergedError, match="diverged") as info:
        for _ in range(20):
            b.apply_tensions(np.array([[80.0, 0.0, 40.0]]))
    assert set(info.value.state) == {"joint_positions", "joint_velocities", "tensions", "time"}


@pytest.mark.parametrize("joint", ["ball", "cardan"])
def test_stable_over_long_random_runs(joint):
    params = ROBOTS["tdcr2"]
    b = MuJoCoBackend(params, joint=joint, num_robots=2, damping_ratio=0.3)
    out = _run(b, 500)  # 10 s of random tensions held for 0.1 s each
    assert np.all(np.isfinite(out))


# -- obstacles ----------------------------------------------------------------------------------
SCENE = np.array([[[0.1, 0.0, 0.4, 0.04], [0.0, 0.0, 0.0, 0.0]], [[0.0, 0.3, 0.3, 0.03]] * 2])


@pytest.mark.parametrize("solid", [False, True])
def test_spheres_are_mujoco_geoms_detected_and_solid_ones_push_back(solid):
    """Robot 0 bends (60 N on cable 1, +x) into a sphere in its way, robot 1's sphere is off
    its path. Detected spheres (``solid_obstacles=False``) exert no force: both robots move as
    without spheres, robot 0 ends inside its sphere. Solid spheres stop robot 0 (the tip stays
    > 0.1 m short of the free tip, penetration < 15 mm: MuJoCo's soft contact at h = 0.02 s)
    with a contact force, and leave robot 1 alone."""
    from cdcr_gym.tasks.collision import backend_geometry, clearance

    params = RobotParams()
    b = MuJoCoBackend(gravity=False, solid_obstacles=solid, num_robots=2)
    free = MuJoCoBackend(gravity=False, num_robots=2)
    b.apply_tensions(np.zeros((2, 3)))
    b.set_obstacles(np.arange(2), SCENE)  # builds the geoms; the robots keep their state
    np.testing.assert_array_equal(b.read().tip, free.read().tip)
    # the straight robots' clearance: MuJoCo's distance = the task's geometric check (the
    # task's disks are discs, MuJoCo's 3 mm cylinders)
    geometric = clearance(
        backend_geometry(b), SCENE, 0.5 * params.backbone_diameter, params.disk_radius
    ).min(axis=1)
    np.testing.assert_allclose(b.obstacle_clearance, geometric, atol=2e-3)
    assert np.all(b.obstacle_clearance > 0)
    t = np.array([[60.0, 0.0, 0.0]] * 2)
    for _ in range(100):
        b.apply_tensions(t)
        free.apply_tensions(t)
    ours, theirs = b.read().tip, free.read().tip
    np.testing.assert_allclose(ours[1], theirs[1], rtol=0, atol=1e-12)
    assert b.obstacle_clearance[1] > 0 and b.contact_forces[1] == 0.0
    if solid:
        assert ours[0, 0] < theirs[0, 0] - 0.1
        assert -0.015 < b.obstacle_clearance[0] < 0.0
        assert b.contact_forces[0] > 0.5
    else:
        np.testing.assert_allclose(ours[0], theirs[0], rtol=0, atol=1e-12)
        assert b.obstacle_clearance[0] < -0.01 and b.contact_forces[0] == 0.0
    # a reset keeps the scene
    b.reset(np.zeros((2, 3)))
    np.testing.assert_allclose(b.obstacle_clearance, geometric, atol=2e-3)
    with pytest.raises(ValueError, match="spheres"):
        b.set_obstacles(np.arange(2), SCENE[:, :, :3])


# -- randomisation, batching, ids ---------------------------------------------------------------
def test_randomized_robot_acts_like_the_robot_built_with_those_parameters():
    dr = {"youngs_modulus": [30e9, 40e9], "gravity": 0.5, "tip_payload": [0.0, 0.05]}
    env = gym.make("cdcr_gym/MuJoCoReach-v0", randomize=dr, action_mode="tension")
    seen = set()
    try:
        for seed in (0, 1, 2, 3):
            _, info = env.reset(seed=seed)
            drawn = {k.split("/")[1]: v for k, v in info.items() if k.startswith("randomized/")}
            seen.add(drawn["gravity"])
            ref = MuJoCoBackend(
                RobotParams(youngs_modulus=drawn["youngs_modulus"]),
                gravity=bool(drawn["gravity"]),
                tip_payload=drawn["tip_payload"],
            )
            a = np.array([0.2, -0.6, -1.0], np.float32)
            for _ in range(8):
                _, _, _, _, info = env.step(a)
                ref.apply_tensions(info["tensions"][None])
            np.testing.assert_allclose(info["tip"], ref.read().tip[0], rtol=0, atol=1e-9)
            ref.close()
    finally:
        env.close()
    assert seen == {0.0, 1.0}


def test_action_delay_applies_every_action_one_step_later():
    """``imperfections={"action_delay": 1}`` on MuJoCo: the tensions of step t are those
    commanded at step t − 1 (the first step holds the reset's tensions), and the robot moves
    exactly as an undelayed env fed the shifted actions (CCKA's delay semantics)."""
    rng = np.random.default_rng(4)
    actions = rng.uniform(-1, 1, (12, 3)).astype(np.float32)
    make = lambda **kw: gym.make("cdcr_gym/MuJoCoReach-v0", action_mode="tension", **kw)  # noqa: E731
    plain, delayed = make(), make(imperfections={"action_delay": 1})
    start = {"initial_tensions": [10.0, 30.0, 0.0]}
    try:
        _, i0 = plain.reset(seed=9, options=start)
        delayed.reset(seed=9, options=start)
        commanded = (actions.astype(np.float64) + 1.0) / 2.0 * RobotParams().max_tension
        held = np.concatenate([i0["tensions"][None], commanded[:-1]])  # lags by one step
        hold = (2.0 * i0["tensions"] / RobotParams().max_tension - 1.0).astype(np.float32)
        shifted = np.concatenate([hold[None], actions[:-1]])
        for a, b, want in zip(actions, shifted, held):
            _, _, _, _, di = delayed.step(a)
            _, _, _, _, pi = plain.step(b)
            np.testing.assert_allclose(di["tensions"], want, rtol=0, atol=1e-4)
            np.testing.assert_allclose(di["tensions"], pi["tensions"], rtol=0, atol=1e-12)
            np.testing.assert_allclose(di["tip"], pi["tip"], rtol=0, atol=1e-12)
        assert not np.allclose(held[1:], commanded[1:])  # the lag is visible
    finally:
        plain.close()
        delayed.close()


def test_vector_env_rows_equal_single_envs_and_runs_are_deterministic():
    n, seed = 3, 11
    vec = gym.make_vec(
        "cdcr_gym/MuJoCoReach-v0", num_envs=n, vectorization_mode="vector_entry_point"
    )
    singles = [gym.make("cdcr_gym/MuJoCoReach-v0") for _ in range(n)]
    obs_v, _ = vec.reset(seed=seed)
    obs_s = np.stack([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    np.testing.assert_array_equal(obs_v, obs_s)
    rng = np.random.default_rng(0)
    for _ in range(30):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        out_v = vec.step(actions)
        out_s = [e.step(a) for e, a in zip(singles, actions)]
        np.testing.assert_array_equal(out_v[0], np.stack([o[0] for o in out_s]))
        np.testing.assert_array_equal(out_v[1], [o[1] for o in out_s])
        np.testing.assert_array_equal(out_v[4]["tip"], np.stack([o[4]["tip"] for o in out_s]))
    # the rollout path (threads) gives the same rows
    threaded = gym.make_vec(
        "cdcr_gym/MuJoCoReach-v0", num_envs=n, vectorization_mode="vector_entry_point", threads=2
    )
    obs_t, _ = threaded.reset(seed=seed)
    vec.reset(seed=seed)
    for _ in range(5):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        np.testing.assert_array_equal(threaded.step(actions)[0], vec.step(actions)[0])
    for e in (vec, threaded, *singles):
        e.close()


def test_vector_env_rows_equal_single_envs_with_randomised_robots_and_friction():
    n, seed = 3, 4
    kwargs = {
        "randomize": {"youngs_modulus": [30e9, 40e9], "friction_coefficient": [0.0, 0.3]},
        "physics_timestep": 0.01,  # two physics steps per control step
    }
    vec = gym.make_vec(
        "cdcr_gym/MuJoCoReach-v0", num_envs=n, vectorization_mode="vector_entry_point", **kwargs
    )
    singles = [gym.make("cdcr_gym/MuJoCoReach-v0", **kwargs) for _ in range(n)]
    obs_v, info_v = vec.reset(seed=seed)
    obs_s = np.stack([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    np.testing.assert_array_equal(obs_v, obs_s)
    rng = np.random.default_rng(2)
    for _ in range(25):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        out_v = vec.step(actions)
        out_s = [e.step(a) for e, a in zip(singles, actions)]
        np.testing.assert_array_equal(out_v[0], np.stack([o[0] for o in out_s]))
        np.testing.assert_array_equal(
            out_v[4]["anchor_tensions"], np.stack([o[4]["anchor_tensions"] for o in out_s])
        )
    for e in (vec, *singles):
        e.close()


def test_pickled_and_copied_backends_step_like_the_original_and_independently():
    import copy
    import pickle

    b = MuJoCoBackend(num_robots=2, friction_coefficient=0.1, threads=1)
    b.set_randomized(np.array([1]), {"youngs_modulus": np.array([30e9])})
    t = np.array([[40.0, 0.0, 10.0], [0.0, 60.0, 0.0]])
    for _ in range(5):
        b.apply_tensions(t)
    twins = [pickle.loads(pickle.dumps(b)), copy.deepcopy(b)]
    for _ in range(5):
        b.apply_tensions(t)
    for twin in twins:
        assert twin._models[0] is twin.model and twin._models[1] is not twin.model
        before = twin.read().tip.copy()
        assert not np.array_equal(before, b.read().tip)  # not moved by the original
        for _ in range(5):
            twin.apply_tensions(t)
        np.testing.assert_array_equal(twin.read().tip, b.read().tip)
        np.testing.assert_array_equal(twin.read().anchor_tensions, b.read().anchor_tensions)
    env = gym.make("cdcr_gym/MuJoCoReach-v0")
    env.reset(seed=0)
    clone = pickle.loads(pickle.dumps(env.unwrapped))
    a = np.array([0.3, -0.2, 0.1], np.float32)
    np.testing.assert_array_equal(env.unwrapped.step(a)[0], clone.step(a)[0])


def test_same_seed_same_trajectory():
    def run():
        env = gym.make("cdcr_gym/MuJoCoReach-v0", initial_state="random")
        obs, _ = env.reset(seed=5)
        rows = [obs]
        rng = np.random.default_rng(1)
        for _ in range(20):
            rows.append(env.step(rng.uniform(-1, 1, 3).astype(np.float32))[0])
        env.close()
        return np.array(rows)

    assert np.array_equal(run(), run())


@pytest.mark.parametrize(
    "env_id, kwargs",
    [
        ("cdcr_gym/MuJoCoReach-v0", {}),
        ("cdcr_gym/MuJoCoReach-v0", {"goal_conditioned": True}),
        ("cdcr_gym/MuJoCoTrack-v0", {}),
        ("cdcr_gym/MuJoCoPose-v0", {}),
        ("cdcr_gym/MuJoCoObstacle-v0", {}),
        ("MuJoCoReach-v0", {"robot": "tdcr2", "friction_coefficient": 0.2}),
    ],
)
def test_ids_pass_the_env_checkers_and_render_headless(env_id, kwargs):
    import warnings

    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    image = env.render()
    assert image.shape == (480, 480, 3) and image.dtype == np.uint8 and image.std() > 0
    env.close()


def test_documented_defaults_match_the_signature():
    import inspect
    import re

    doc = inspect.getdoc(MuJoCoBackend)
    for name, parameter in inspect.signature(MuJoCoBackend.__init__).parameters.items():
        if name in ("self", "params"):
            continue
        entry = re.search(rf"^\s*{name}:(.*?)(?=^\s*\w+:|\Z)", doc, flags=re.M | re.S)
        assert entry, f"{name} is documented"
        text = " ".join(entry.group(1).split())
        match = re.search(r"\(default:? ``([^`]+)``", text) or re.search(
            r"\(default:? ([^\s,:;)]+)", text
        )
        if match is None:
            match = re.search(r"``(True|False)`` \(default\)", text)
        assert match, f"{name}: no default stated"
        import ast

        stated = re.sub(r"\s*s$", "", match.group(1))
        value = ast.literal_eval(stated)
        assert value == parameter.default, (name, value, parameter.default)


def test_pose_defaults_to_tdcr2_and_bad_keywords_are_named():
    env = gym.make("cdcr_gym/MuJoCoPose-v0")
    assert env.unwrapped.params.n_sections == 2
    env.close()
    with pytest.raises(ValueError, match="links_per_sapn"):
        gym.make("cdcr_gym/MuJoCoReach-v0", links_per_sapn=2)


def test_the_obstacle_task_places_its_spheres_in_the_mujoco_scene_and_reads_its_contacts():
    """MuJoCoObstacle-v0: the task's spheres become MuJoCo geoms at reset (the clearance is
    MuJoCo's, close to the task's geometric one), and a solid sphere's push is in info."""
    from cdcr_gym.tasks.collision import backend_geometry, clearance

    for solid in (False, True):
        env = gym.make("cdcr_gym/MuJoCoObstacle-v0", solid_obstacles=solid)
        _, info = env.reset(seed=3)
        task, backend = env.unwrapped.task, env.unwrapped.backend
        placed = backend._datas[0].mocap_pos[: task.max_obstacles]
        present = task.obstacles[0, :, 3] > 0
        np.testing.assert_allclose(placed[present], task.obstacles[0, present, :3])
        geometric = clearance(backend_geometry(backend), task.obstacles, task._rod, task._disk).min(
            1
        )
        assert info["min_clearance"] == pytest.approx(geometric[0], abs=2e-3)
        assert info["contact_force"] == 0.0  # the start is free
        for _ in range(5):
            _, _, _, _, info = env.step(env.action_space.sample())
        assert np.isfinite(info["min_clearance"]) and info["contact_force"] >= 0.0
        env.close()
