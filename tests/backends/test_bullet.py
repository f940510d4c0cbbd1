"""The pybullet backend: construction, hygiene, cable loading, physics against theory, envs.

Physics tests compare the simulated (settled) robot with closed-form mechanics; the numbers
they check are tabulated in docs/bullet_backend.md (``cdcr-gym verification``).
"""

from __future__ import annotations

import gc
import inspect
import math
import os
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from cdcr_gym import kinematics
from cdcr_gym.backends.base import Backend
from cdcr_gym.backends.bullet import MAX_JOINTS, BulletBackend, SimulationDivergedError
from cdcr_gym.model import statics
from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.params import RobotParams
from training.studies.verification import (
    HORIZONTAL,
    beam_theory_sag,
    bending_angle_of_tip,
    discrete_routing_theta,
    elastica_tip,
    settled_tip,
    settling_time,
)

pytestmark = pytest.mark.filterwarnings("error")

P = RobotParams()
ELL = P.length
REPO = Path(__file__).resolve().parents[2]
TILTED = (0.3, 0.1, 0.2, math.sqrt(1.0 - 0.14))  # an arbitrary base orientation


@pytest.fixture
def make():
    """Build backends and close them at the end of the test."""
    made = []

    def _make(*args, **kwargs):
        backend = BulletBackend(*args, **kwargs)
        made.append(backend)
        return backend

    yield _make
    for backend in made:
        backend.close()


def _random_pose(
    backend: BulletBackend, rng: np.random.Generator, scale: float = 0.25
) -> np.ndarray:
    q = rng.uniform(-scale, scale, backend.n_dof) / backend.links_per_span
    backend.set_joint_state(q)
    return q


# ------------------------------------------------------------------------------------------
# construction, validation, hygiene
# ------------------------------------------------------------------------------------------


def test_is_a_backend_with_the_documented_defaults(make):
    b = make()
    assert isinstance(b, Backend)
    assert b.supports_length_control is False
    with pytest.raises(NotImplementedError):
        b.apply_cable_lengths(np.full(3, ELL))
    sig = inspect.signature(BulletBackend.__init__).parameters
    documented = {
        "gravity": (True, "``True`` (default)"),
        "links_per_span": (1, "(default 1)"),
        "control_timestep": (0.02, "(default 0.02 s"),
        "physics_timestep": (0.01, "(default\n            0.01 s"),
        "base_orientation": ((0.0, 0.0, 0.0, 1.0), "(default (0, 0, 0, 1)"),
        "tip_payload": (0.0, "(default 0.0)"),
        "gui": (False, "(default ``False``)"),
        "damping_ratio": (0.7, "(default 0.7)"),
    }
    doc = BulletBackend.__doc__
    for name, (value, text) in documented.items():
        assert sig[name].default == value, name
        assert text in doc, (name, text)
    assert b.params == RobotParams()
    assert b.control_timestep == 0.02 and b.physics_timestep == 0.01 and b.n_substeps == 2
    assert b.n_links == 9 and b.n_dof == 18
    np.testing.assert_allclose(b.stiffness, P.bending_stiffness / P.disk_spacing)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"params": "paper"}, "params"),
        ({"gravity": "yes"}, "gravity"),
        ({"gui": 1}, "gui"),
        ({"links_per_span": 0}, "links_per_span"),
        ({"links_per_span": 1.5}, "links_per_span"),
        ({"links_per_span": True}, "links_per_span"),
        ({"links_per_span": 7}, "links_per_span"),  # 9 × 7 = 63 joints > pybullet's 60
        ({"params": RobotParams(n_disks=61)}, "n_disks"),
        ({"control_timestep": 0.0}, "control_timestep"),
        ({"control_timestep": float("nan")}, "control_timestep"),
        ({"physics_timestep": -0.01}, "physics_timestep"),
        ({"physics_timestep": 0.03}, "physics_timestep"),
        ({"physics_timestep": 0.007}, "physics_timestep"),
        ({"base_orientation": (0.0, 0.0, 0.0, 2.0)}, "base_orientation"),
        ({"base_orientation": (0.0, 0.0, 1.0)}, "base_orientation"),
        ({"base_orientation": (float("nan"), 0.0, 0.0, 1.0)}, "base_orientation"),
        ({"base_orientation": "up"}, "base_orientation"),
        ({"tip_payload": -0.1}, "tip_payload"),
        ({"tip_payload": float("inf")}, "tip_payload"),
        ({"damping_ratio": 0.0}, "damping_ratio"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        BulletBackend(**kwargs)


def test_bad_tensions_raise_value_error(make):
    b = make()
    for bad in ([1.0, 2.0], [np.nan, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 81.0, 0.0]):
        with pytest.raises(ValueError, match="tensions"):
            b.apply_tensions(np.array(bad))
        with pytest.raises(ValueError, match="tensions"):
            b.reset(np.array(bad))


def test_close_disconnects_and_is_safe_twice():
    b = BulletBackend()
    pb, client = b._pb, b._client
    assert pb.getConnectionInfo(physicsClientId=client)["isConnected"] == 1
    b.close()
    assert pb.getConnectionInfo(physicsClientId=client)["isConnected"] == 0
    b.close()
    with pytest.raises(RuntimeError, match="closed"):
        b.apply_tensions(np.zeros(3))
    with pytest.raises(RuntimeError, match="closed"):
        b.tip  # noqa: B018


def test_an_unclosed_backend_disconnects_when_collected():
    b = BulletBackend()
    pb, client = b._pb, b._client
    del b
    gc.collect()
    assert pb.getConnectionInfo(physicsClientId=client)["isConnected"] == 0


def test_no_start_up_banner_on_stdout_in_process(capfd):
    b = BulletBackend()
    b.reset(np.array([10.0, 0.0, 0.0]))
    b.close()
    out, err = capfd.readouterr()
    assert out == ""
    assert err == ""


def test_no_start_up_banner_on_stdout_in_a_fresh_interpreter():
    """pybullet prints 'pybullet build time' from C at import: nothing may reach the user."""
    code = (
        "import numpy as np\n"
        "from cdcr_gym.backends.bullet import BulletBackend\n"
        "b = BulletBackend(); b.apply_tensions(np.zeros(3)); b.close()\n"
        "print('done')\n"
    )
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout == "done\n"
    assert "pybullet" not in res.stderr


def test_one_client_per_backend_with_state_isolated(make):
    a, b = make(), make()
    assert a._client != b._client
    a.reset(np.array([80.0, 0.0, 0.0]))
    b.reset(np.zeros(3))
    np.testing.assert_allclose(b.tip, (0.0, 0.0, ELL), atol=1e-12)


def test_pybullet_holds_the_largest_allowed_chain_exactly(make):
    """At MAX_JOINTS joints every joint coordinate survives a set/get round trip."""
    b = make(replace(P, n_disks=MAX_JOINTS), gravity=False)
    q = np.linspace(-0.01, 0.01, b.n_dof)
    b.set_joint_state(q)
    np.testing.assert_array_equal(b.joint_positions, q)


# ------------------------------------------------------------------------------------------
# model: kinematics, masses, loads
# ------------------------------------------------------------------------------------------


def test_straight_robot_geometry(make):
    b = make(gravity=False)
    np.testing.assert_allclose(b.tip, (0.0, 0.0, ELL), atol=1e-15)
    np.testing.assert_allclose(b.cable_lengths, np.full(3, ELL), rtol=1e-14)
    pts = b.backbone_points()
    assert pts.shape == (2 * b.n_links + 1, 3)
    np.testing.assert_array_equal(pts[0], 0.0)
    np.testing.assert_array_equal(pts[-1], b.tip)
    # every disk station is a point of the polyline
    for k in range(P.n_disks + 1):
        assert np.min(np.linalg.norm(pts - (0.0, 0.0, k * P.disk_spacing), axis=1)) < 1e-12
    pins = b.pinhole_positions()
    assert pins.shape == (P.n_disks + 1, 3, 3)
    np.testing.assert_allclose(np.linalg.norm(pins[..., :2], axis=-1), P.cable_radius, rtol=1e-12)
    np.testing.assert_allclose(pins[0, 0], (P.cable_radius, 0.0, 0.0), atol=1e-15)  # cable 1 at +X0


@pytest.mark.parametrize("m, orientation", [(1, (0.0, 0.0, 0.0, 1.0)), (3, TILTED)])
def test_forward_kinematics_matches_pybullet(make, m, orientation):
    b = make(links_per_span=m, base_orientation=orientation)
    _random_pose(b, np.random.default_rng(m), scale=0.4)
    pos, rot = b._pybullet_link_frames()
    pose = b._read()
    # pybullet reports link frames in single precision
    np.testing.assert_allclose(pos[1::2], pose.joint_points, atol=1e-6)
    np.testing.assert_allclose(rot[1::2], pose.link_rot, atol=1e-6)
    np.testing.assert_allclose(rot[0::2][:, :, 0], pose.joint_axes[:, 0], atol=1e-6)
    np.testing.assert_allclose(rot[0::2][:, :, 1], pose.joint_axes[:, 1], atol=1e-6)


@pytest.mark.parametrize(
    "kwargs", [{}, {"links_per_span": 2, "tip_payload": 0.05}, {"base_orientation": TILTED}]
)
def test_masses_and_gravity_loads_match_pybullet(make, kwargs):
    b = make(**kwargs)
    pb = b._pb
    masses = [pb.getDynamicsInfo(b._body, i, physicsClientId=b._client)[0] for i in range(b.n_dof)]
    np.testing.assert_array_equal(masses[0::2], 0.0)  # the intermediate Cardan links
    np.testing.assert_allclose(masses[1::2], b.chain.link_masses, rtol=1e-12)
    rod = P.backbone_linear_density * (
        ELL - 0.5 * b.segment_lengths[0]
    )  # the base half link is clamped
    np.testing.assert_allclose(
        b.chain.link_masses.sum(),
        rod + P.n_disks * P.disk_mass + kwargs.get("tip_payload", 0.0),
        rtol=1e-12,
    )
    q = _random_pose(b, np.random.default_rng(7), scale=0.4)
    np.testing.assert_allclose(b.chain.gravity_loads(q), b.gravity_generalized_forces(), atol=1e-12)


def _virtual_work_forces(b, q, tensions, eps):
    """−Σ T_i ∂l_i/∂q (n_dof,) by central differences of the sensed cable lengths at pose q."""
    fd = np.empty(b.n_dof)
    for j in range(b.n_dof):
        dq = np.zeros(b.n_dof)
        dq[j] = eps
        b.set_joint_state(q + dq)
        lp = b.cable_lengths
        b.set_joint_state(q - dq)
        fd[j] = -tensions @ (lp - b.cable_lengths) / (2 * eps)
    return fd


@pytest.mark.parametrize("m, orientation", [(1, (0.0, 0.0, 0.0, 1.0)), (3, TILTED)])
def test_cable_loads_equal_virtual_work_of_sensed_lengths(make, m, orientation):
    """τ = −Σ T_i ∂l_i/∂q, with ∂l/∂q by central differences of the sensed cable lengths."""
    b = make(links_per_span=m, base_orientation=orientation)
    rng = np.random.default_rng(10 + m)
    eps = 1e-6
    for _ in range(4):
        q = _random_pose(b, rng, scale=0.4)
        tensions = rng.uniform(0.0, P.max_tension, 3)
        tau = b.cable_generalized_forces(tensions)
        fd = _virtual_work_forces(b, q, tensions, eps)
        np.testing.assert_allclose(tau, fd, rtol=0, atol=1e-6 * np.abs(tau).max())
        assert np.abs(tau).max() > 0.1  # the check is not vacuous
        b.set_joint_state(q)
        # the span-local lengths used in the dynamics equal the world-frame sensed lengths
        np.testing.assert_allclose(b.chain.cable_loads(q, tensions)[1], b.cable_lengths, atol=1e-14)


def test_one_link_fast_path_equals_the_general_span_loop():
    chain = DiscreteBackbone(P, 1)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = rng.uniform(-0.4, 0.4, chain.n_dof)
        t = rng.uniform(0.0, 80.0, 3)
        fast, general = chain.cable_loads(q, t), chain._cable_loads_spans(q, t)
        np.testing.assert_allclose(fast[0], general[0], rtol=0, atol=1e-13)
        np.testing.assert_allclose(fast[1], general[1], rtol=0, atol=1e-15)


def test_the_generalized_forces_pybullet_receives_are_the_cable_loads(make):
    """End to end: from rest, one physics step under tensions T, gravity off. pybullet's
    velocity update then obeys (M + hD + h²K)·q̇⁺ = h·(τ_cable − K·q); recover τ_cable from the
    q̇⁺ pybullet produced and compare it with the finite-difference virtual work."""
    b = make(gravity=False, control_timestep=0.01, physics_timestep=0.01)
    rng = np.random.default_rng(3)
    q = _random_pose(b, rng, scale=0.3)
    tensions = np.array([55.0, 10.0, 30.0])
    eps = 1e-6
    fd = _virtual_work_forces(b, q, tensions, eps)
    b.set_joint_state(q)
    mass = b.mass_matrix()
    b.apply_tensions(tensions)
    h, k, d = b.physics_timestep, b.stiffness, b.damping
    qd_new = b.joint_velocities
    np.testing.assert_allclose(b.joint_positions, q + h * qd_new, rtol=0, atol=1e-12)
    recovered = (mass + np.diag(h * d + h * h * k)) @ qd_new / h + k * q
    np.testing.assert_allclose(recovered, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


# ------------------------------------------------------------------------------------------
# statics and dynamics
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs", [{}, {"base_orientation": HORIZONTAL, "tip_payload": 0.02}])
def test_reset_gives_a_state_at_rest_that_the_dynamics_keep(make, kwargs):
    b = make(**kwargs)
    for tensions in ([0.0, 0.0, 0.0], [80.0, 0.0, 0.0], [30.0, 60.0, 5.0]):
        t = np.array(tensions)
        b.reset(t)
        tip, q = b.tip, b.joint_positions
        assert np.all(b.joint_velocities == 0.0)
        # the static equation holds: K q = τ_cable(q) + τ_gravity(q)
        residual = b.stiffness * q - b.cable_generalized_forces() - b.gravity_generalized_forces()
        assert np.abs(residual).max() < 1e-12
        for _ in range(50):
            b.apply_tensions(t)
        assert np.linalg.norm(b.tip - tip) < 1e-12
        assert np.abs(b.joint_velocities).max() < 1e-10


def test_reset_is_deterministic_whatever_happened_before(make):
    rng = np.random.default_rng(0)
    actions = rng.uniform(0.0, P.max_tension, (30, 3))
    start = np.array([20.0, 50.0, 0.0])

    def run(b):
        b.reset(start)
        out = []
        for t in actions:
            b.apply_tensions(t)
            out.append(np.concatenate([b.tip, b.cable_lengths, b.joint_velocities]))
        return np.array(out)

    fresh = make()
    reference = run(fresh)
    used = make()
    for t in rng.uniform(0.0, P.max_tension, (40, 3)):  # some history
        used.apply_tensions(t)
    np.testing.assert_array_equal(run(used), reference)
    np.testing.assert_array_equal(run(fresh), reference)
    assert used.time == pytest.approx(30 * used.control_timestep)


def test_interleaved_backends_give_exactly_what_each_gives_alone(make):
    rng = np.random.default_rng(1)
    seq_a, seq_b = rng.uniform(0.0, 80.0, (2, 40, 3))

    def alone(seq):
        b = make()
        out = []
        for t in seq:
            b.apply_tensions(t)
            out.append(b.tip)
        return np.array(out)

    ref_a, ref_b = alone(seq_a), alone(seq_b)
    a, b = make(), make()
    out_a, out_b = [], []
    for ta, tb in zip(seq_a, seq_b):
        a.apply_tensions(ta)
        b.apply_tensions(tb)
        out_b.append(b.tip)
        out_a.append(a.tip)
    np.testing.assert_array_equal(np.array(out_a), ref_a)
    np.testing.assert_array_equal(np.array(out_b), ref_b)


def test_dynamics_settle_to_the_static_equilibrium_within_a_second(make):
    b = make()
    t_settle, overshoot = settling_time(
        b, np.zeros(3), np.array([80.0, 0.0, 0.0]), tol=1e-4, duration=2.0
    )
    assert 0.2 < t_settle < 1.0  # measured 0.52 s (docs/bullet_backend.md)
    assert overshoot < 0.02
    b.reset(np.array([80.0, 0.0, 0.0]))
    final = b.tip
    b.reset(np.zeros(3))
    for _ in range(100):
        b.apply_tensions(np.array([80.0, 0.0, 0.0]))
    assert np.linalg.norm(b.tip - final) < 1e-9


def test_a_chain_at_rest_for_seconds_still_responds(make):
    """No sleeping: pybullet may deactivate bodies at rest; ours must never freeze."""
    b = make()
    for _ in range(200):  # 4 s at rest
        b.apply_tensions(np.zeros(3))
    b.apply_tensions(np.array([80.0, 0.0, 0.0]))
    b.apply_tensions(np.array([80.0, 0.0, 0.0]))
    assert b.tip[0] > 1e-3


def test_a_turned_base_without_gravity_changes_nothing_in_the_base_frame(make):
    up, turned = make(gravity=False), make(gravity=False, base_orientation=TILTED)
    for t in ([80.0, 0.0, 0.0], [10.0, 40.0, 70.0]):
        up.reset(np.array(t))
        turned.reset(np.array(t))
        np.testing.assert_allclose(turned.tip, up.tip, atol=1e-12)
        np.testing.assert_allclose(turned.backbone_points(), up.backbone_points(), atol=1e-12)
        world = turned.backbone_points(frame="world")
        np.testing.assert_allclose(world, up.backbone_points() @ turned._base_rot.T, atol=1e-12)
        np.testing.assert_allclose(turned.tip_world, turned._base_rot @ up.tip, atol=1e-12)


def test_divergence_raises_the_named_error_with_the_state(make):
    b = make()
    q = np.zeros(b.n_dof)
    q[5] = 2.0  # a 115° kink: an exploded state
    b.set_joint_state(q)
    with pytest.raises(SimulationDivergedError) as info:
        b.apply_tensions(np.zeros(3))
    state = info.value.state
    assert set(state) == {"joint_positions", "joint_velocities", "tensions", "time"}
    assert state["joint_positions"].shape == (b.n_dof,)
    assert isinstance(info.value, RuntimeError)
    # a non-finite state
    b.reset(np.zeros(3))
    b._pb.resetJointState(b._body, 3, float("nan"), 0.0, physicsClientId=b._client)
    b._q = b._qd = b._pose = None
    with pytest.raises(SimulationDivergedError) as info:
        b.apply_tensions(np.zeros(3))
    assert not np.all(np.isfinite(info.value.state["joint_positions"]))


def test_a_bowstringing_chain_raises_in_reset_and_in_the_dynamics(make, monkeypatch):
    """One disk: the cable runs straight from base to tip and its arm grows with the bend faster
    than the joint resists; there is no equilibrium, and both paths say so by the named error.
    (Such a robot is rejected at construction, its span buckles: the check is bypassed here to
    reach the guards behind it.)"""
    import cdcr_gym.backends.bullet.backend as backend_module

    monkeypatch.setattr(backend_module, "check_span_buckling", lambda params, links: None)
    b = make(RobotParams(n_disks=1))
    with pytest.raises(SimulationDivergedError, match="no static equilibrium"):
        b.reset(np.array([40.0, 0.0, 0.0]))
    b.reset(np.zeros(3))
    with pytest.raises(SimulationDivergedError, match="diverged"):
        for _ in range(200):
            b.apply_tensions(np.array([40.0, 0.0, 0.0]))


@pytest.mark.slow
def test_long_random_tension_runs_stay_finite_and_bounded():
    """100 000 control steps at default settings: uniform and bang-bang random tensions."""
    rng = np.random.default_rng(2024)
    b = BulletBackend()
    try:
        worst = 0.0
        for kind in ("uniform", "bang-bang"):
            b.reset(np.zeros(3))
            for _ in range(10):
                if kind == "uniform":
                    tensions = rng.uniform(0.0, P.max_tension, (5000, 3))
                else:
                    tensions = P.max_tension * rng.integers(0, 2, (5000, 3)).astype(float)
                for t in tensions:
                    b.apply_tensions(t)
                tip = b.tip
                assert np.all(np.isfinite(tip)) and np.all(np.isfinite(b.joint_velocities))
                worst = max(worst, float(np.max(np.abs(b.joint_positions))))
                assert np.linalg.norm(tip) <= ELL + 1e-9  # inextensible
        assert b.time == pytest.approx(50000 * b.control_timestep)
        assert worst < 0.5
    finally:
        b.close()


# ------------------------------------------------------------------------------------------
# physics against theory (gravity off unless stated)
# ------------------------------------------------------------------------------------------


def _deviation(tensions, params, **kw) -> float:
    return float(
        np.linalg.norm(settled_tip(tensions, params, **kw) - elastica_tip(tensions, params))
    )


CASES = [(10.0, 0.0, 0.0), (40.0, 0.0, 0.0), (80.0, 0.0, 0.0), (40.0, 40.0, 0.0)]


@pytest.mark.slow
def test_dense_disk_limit_converges_to_the_elastica():
    devs = {}
    for n in (9, 18, 36, 72):  # 72 disks exceed one pybullet body: the same model's statics
        pn = replace(P, n_disks=n)
        devs[n] = np.array([_deviation(np.array(t), pn) for t in CASES])
    for a, b in ((9, 18), (18, 36), (36, 72)):
        assert np.all(devs[b] < devs[a])
        assert np.all(devs[a] / devs[b] > 3.5)  # second order in the disk spacing
    assert np.all(devs[72] < 0.005 * ELL)
    # the largest chain pybullet holds (60 disks) *settles* there dynamically, within 0.5 % of ℓ
    p60 = replace(P, n_disks=60)
    b = BulletBackend(p60, gravity=False)
    try:
        for t in (np.array([80.0, 0.0, 0.0]), np.array([40.0, 40.0, 0.0])):
            b.reset(t)
            static_tip = b.tip
            b.reset(np.zeros(3))
            for _ in range(100):
                b.apply_tensions(t)
            assert np.linalg.norm(b.tip - static_tip) < 2e-5
            assert np.linalg.norm(b.tip - elastica_tip(t, p60)) < 0.005 * ELL
    finally:
        b.close()


@pytest.mark.parametrize("m", [1, 8])
def test_nine_disks_bend_beyond_the_elastica_by_the_discrete_routing_estimate(m):
    """Same sign and size as the estimate: the model's (1 + 2/m²) one exactly, the physical
    h²κ/12 one once the links per span are refined (m = 8: 9 % below it at 80 N)."""
    for t1 in (10.0, 40.0, 80.0):
        t = np.array([t1, 0.0, 0.0])
        theta0 = float(statics.arc_from_tensions(t, P)[0])
        excess = bending_angle_of_tip(settled_tip(t, P, links_per_span=m)) - theta0
        model = discrete_routing_theta(t, P, m) - theta0
        physical = discrete_routing_theta(t, P) - theta0
        assert excess > 0.0
        assert 0.9 < excess / model < 1.02
        if m == 8:
            assert 0.85 < excess / physical < 1.1


def test_links_per_span_refinement_converges_at_second_order():
    for t1, finest_change in ((40.0, 0.001), (80.0, 0.003)):
        t = np.array([t1, 0.0, 0.0])
        tips = {m: settled_tip(t, P, links_per_span=m) for m in (1, 2, 4, 8)}
        d = [np.linalg.norm(tips[m] - tips[2 * m]) for m in (1, 2, 4)]
        orders = [math.log2(d[0] / d[1]), math.log2(d[1] / d[2])]
        assert all(1.9 < o < 2.2 for o in orders), orders
        assert d[2] < finest_change * ELL  # 40 N: 0.052 % of ℓ; 80 N: 0.20 %
        # Richardson: the error of m = 8 against the converged model is d(4→8)/3
        assert d[2] / 3 < 0.001 * ELL


@pytest.mark.parametrize("routing", ["disk", "corrected"])
def test_pybullet_settles_where_the_numpy_statics_say(routing):
    """settled_tip switches to DiscreteBackbone beyond pybullet's size: they must agree."""
    t = np.array([60.0, 0.0, 20.0])
    chain = DiscreteBackbone(P, 4, gravity=False, routing=routing)
    q, converged = chain.static_equilibrium(t)
    assert converged
    b = BulletBackend(P, gravity=False, links_per_span=4, routing=routing)
    try:
        b.reset(np.zeros(3))
        for _ in range(100):
            b.apply_tensions(t)
        np.testing.assert_allclose(b.tip, chain.pose(q).stations[-1], atol=1e-9)
    finally:
        b.close()


def test_ccka_forward_kinematics_of_sensed_lengths_matches_the_simulated_tip(make):
    """The paper's check (CCKA vs simulation, 0–80 N on cable 1): within 1 % of ℓ (paper 0.77 %)."""
    b = make(gravity=False)
    errors = []
    for t1 in np.linspace(0.0, 80.0, 17):
        b.reset(np.array([t1, 0.0, 0.0]))
        fk = kinematics.forward_kinematics(b.cable_lengths, P.cable_radius)
        errors.append(np.linalg.norm(fk - b.tip))
    errors = np.array(errors)
    assert errors.max() < 0.01 * ELL  # measured: 0.12 % max, 0.04 % mean
    assert errors[-1] > errors[1]  # grows with the bend: the check is not vacuous


def test_upright_robot_does_not_sag_and_the_horizontal_cantilever_matches_beam_theory(make):
    up = make()
    np.testing.assert_allclose(up.tip, (0.0, 0.0, ELL), atol=1e-15)
    for payload in (0.0, 0.02):
        b = make(base_orientation=HORIZONTAL, tip_payload=payload)
        tip = b.tip_world
        sag = -tip[2]
        beam = beam_theory_sag(P, payload)
        assert abs(sag / beam - 1.0) < 0.05  # measured −0.7 % (no payload)
        assert abs(tip[1]) < 1e-12 and tip[0] > 0.99 * ELL
        # this base maps +X0 to −Z_world: in R0 gravity, and the sag, point along +X0
        assert b.tip[0] == pytest.approx(sag, abs=1e-12)


def test_gravity_moves_the_bent_upright_robot_down_and_out(make):
    on, off = make(), make(gravity=False)
    t = np.array([40.0, 0.0, 0.0])
    on.reset(t)
    off.reset(t)
    delta = on.tip - off.tip
    assert delta[2] < 0.0 and delta[0] > 0.0 and abs(delta[1]) < 1e-12
    assert 0.005 < np.linalg.norm(delta) < 0.03  # measured 14.4 mm


# ------------------------------------------------------------------------------------------
# rendering
# ------------------------------------------------------------------------------------------


def test_render_rgb_from_the_headless_renderer(make):
    b = make()
    b.reset(np.array([60.0, 20.0, 0.0]))
    with_goal = b.render_rgb(np.array([0.2, 0.1, 0.5]), 96, 64)
    without = b.render_rgb(None, 96, 64)
    assert with_goal.shape == (64, 96, 3) and with_goal.dtype == np.uint8
    assert with_goal.std() > 5  # not blank
    assert np.any(with_goal != without)  # the goal marker shows
    with pytest.raises(ValueError, match="width"):
        b.render_rgb(None, 0, 64)
    with pytest.raises(ValueError, match="goal"):
        b.render_rgb(np.array([np.nan, 0.0, 0.0]), 32, 32)


# ------------------------------------------------------------------------------------------
# the env on this backend
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["tension", "tension_delta"])
def test_bullet_reach_passes_gymnasium_and_sb3_check_env(mode):
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    import cdcr_gym  # noqa: F401

    env = gym.make("cdcr_gym/BulletReach-v0", action_mode=mode)
    try:
        assert isinstance(env.unwrapped.backend, BulletBackend)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            gym_check_env(env.unwrapped, skip_render_check=True)
            sb3_check_env(env.unwrapped, warn=True)
    finally:
        env.close()


@pytest.mark.parametrize("mode", ["tension", "tension_delta"])
def test_same_seed_gives_identical_bullet_trajectories(mode):
    import cdcr_gym  # noqa: F401

    def rollout():
        env = gym.make("cdcr_gym/BulletReach-v0", action_mode=mode, initial_state="random")
        try:
            obs, _ = env.reset(seed=123)
            env.action_space.seed(5)
            out = [obs]
            for _ in range(30):
                obs, reward, *_ = env.step(env.action_space.sample())
                out.append(np.append(obs, reward))
            return out
        finally:
            env.close()

    first, second = rollout(), rollout()
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a, b)


def test_interleaved_envs_give_exactly_what_each_gives_alone():
    import cdcr_gym  # noqa: F401

    rng = np.random.default_rng(11)
    actions = rng.uniform(-1.0, 1.0, (2, 40, 3)).astype(np.float32)

    def alone(seed, acts):
        env = gym.make("cdcr_gym/BulletReach-v0")
        try:
            out = [env.reset(seed=seed)[0]]
            out += [env.step(a)[0] for a in acts]
            return np.array(out)
        finally:
            env.close()

    ref = [alone(1, actions[0]), alone(2, actions[1])]
    envs = [gym.make("cdcr_gym/BulletReach-v0") for _ in range(2)]
    try:
        outs = [[env.reset(seed=seed)[0]] for env, seed in zip(envs, (1, 2))]
        for a0, a1 in zip(actions[0], actions[1]):
            outs[1].append(envs[1].step(a1)[0])
            outs[0].append(envs[0].step(a0)[0])
    finally:
        for env in envs:
            env.close()
    np.testing.assert_array_equal(np.array(outs[0]), ref[0])
    np.testing.assert_array_equal(np.array(outs[1]), ref[1])


def test_gym_make_kwargs_reach_the_backend():
    import cdcr_gym  # noqa: F401

    env = gym.make(
        "cdcr_gym/BulletReach-v0",
        gravity=False,
        links_per_span=2,
        physics_timestep=0.005,
        base_orientation=HORIZONTAL,
        tip_payload=0.01,
    )
    try:
        be = env.unwrapped.backend
        assert (be.gravity, be.links_per_span, be.physics_timestep, be.tip_payload) == (
            False,
            2,
            0.005,
            0.01,
        )
        assert be.base_orientation == pytest.approx(HORIZONTAL)
    finally:
        env.close()


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.slow
def test_make_close_cycles_leave_no_client_and_flat_memory():
    import cdcr_gym  # noqa: F401

    clients = []

    def cycle():
        env = gym.make("cdcr_gym/BulletReach-v0")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        clients.append(env.unwrapped.backend._client)
        pb = env.unwrapped.backend._pb
        env.close()
        return pb

    for _ in range(20):  # warm-up: imports, allocator pools
        pb = cycle()
    gc.collect()
    before = _rss_bytes()
    for _ in range(200):
        pb = cycle()
    gc.collect()
    grown = _rss_bytes() - before
    assert all(pb.getConnectionInfo(physicsClientId=c)["isConnected"] == 0 for c in clients)
    assert grown < 4 * 2**20, f"RSS grew by {grown / 2**20:.1f} MiB over 200 make/close cycles"


@pytest.mark.parametrize("gravity", [False, True])
@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_default_settles_within_half_a_percent_of_the_cosserat_rod(robot, gravity):
    """The default (one link per span, ``routing="corrected"``) against the committed converged
    Cosserat-rod tips (``cdcr-gym cosserat-reference``): within 0.5 % of ℓ on every case
    (measured 0.37/0.44 % on the paper robot, gravity off/on; 0.19/0.20 % on tdcr2), where the
    straight pinhole-to-pinhole routing is 4.7–5.1 % (paper) and 1.6–2.1 % (tdcr2) off."""
    from training.studies.bench_physics import REFERENCE_PATH, load_reference

    params, tensions, tips = load_reference(REFERENCE_PATH)[robot, gravity]
    assert len(tips) >= 6
    errors = {}
    for routing in ("corrected", "disk"):
        kwargs = {} if routing == "corrected" else {"routing": "disk"}
        b = BulletBackend(params, gravity=gravity, **kwargs)
        try:
            assert b.routing == routing
            errors[routing] = np.linalg.norm(b.equilibrium(tensions).tip - tips, axis=1).max()
        finally:
            b.close()
    assert errors["corrected"] <= 0.005 * params.length, errors
    assert errors["disk"] > 3.0 * errors["corrected"], errors  # the correction does the work
