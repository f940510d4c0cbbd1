"""The pybullet backend with several sections: cable routing and loads, the dense-disk limit,
the envs on tdcr2, goals from its own statics, the span-buckling limit and bad input."""

from __future__ import annotations

import math
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet import MAX_JOINTS, BulletBackend
from cdcr_gym.model.discrete import DiscreteBackbone, span_buckling_loads
from cdcr_gym.model.workspace import sample_tensions_each
from cdcr_gym.params import RobotParams, SectionParams
from experiments.verification import linearised_critical_load

pytestmark = pytest.mark.filterwarnings("error")

DEG = math.pi / 180.0
TDCR2 = RobotParams.preset("tdcr2")
#: two sections with different lengths, disk counts, radii and cable counts/angles
MIXED2 = replace(
    TDCR2,
    sections=(
        SectionParams(0.22, 8, 0.011, (10 * DEG, 100 * DEG, 190 * DEG, 280 * DEG)),
        SectionParams(0.15, 6, 0.008, (45 * DEG, 165 * DEG, 285 * DEG)),
    ),
    length=None,
    n_disks=None,
    cable_radius=None,
)
#: three sections, 4, 3 and 5 cables at other angles
THREE = replace(
    TDCR2,
    sections=(
        SectionParams(0.15, 20, 0.011, (0.0, 90 * DEG, 180 * DEG, 270 * DEG)),
        SectionParams(0.15, 20, 0.010, (30 * DEG, 150 * DEG, 270 * DEG)),
        SectionParams(0.10, 20, 0.008, (10 * DEG, 100 * DEG, 200 * DEG, 300 * DEG, 350 * DEG)),
    ),
    max_tension=4.0,
    length=None,
    n_disks=None,
    cable_radius=None,
)


def with_disks(params: RobotParams, n_disks: int) -> RobotParams:
    """``params`` with ``n_disks`` disks in every section."""
    sections = tuple(replace(s, n_disks=n_disks) for s in params.sections)
    return replace(params, sections=sections, length=None, n_disks=None, cable_radius=None)


@pytest.fixture
def make():
    made = []

    def _make(*args, **kwargs):
        backend = BulletBackend(*args, **kwargs)
        made.append(backend)
        return backend

    yield _make
    for backend in made:
        backend.close()


# -- routing and loads ------------------------------------------------------------------------


@pytest.mark.parametrize("m", [1, 2])
@pytest.mark.parametrize("params", [TDCR2, MIXED2, RobotParams()], ids=["tdcr2", "mixed2", "paper"])
def test_cable_loads_are_minus_the_gradient_of_the_cable_potential(make, params, m):
    """τ = −∂(Σ T_i l_i)/∂q by central differences of the sensed lengths at a random pose,
    distal cables' runs through the proximal sections included."""
    b = make(params, links_per_span=m, gravity=False)
    rng = np.random.default_rng(7)
    q = rng.normal(0.0, 0.05, b.n_dof)
    tensions = rng.uniform(0.0, params.max_tension, params.n_cables)
    b.set_joint_state(q)
    tau = b.cable_generalized_forces(tensions)
    eps = 1e-6
    fd = np.empty(b.n_dof)
    for k in range(b.n_dof):
        dq = np.zeros(b.n_dof)
        dq[k] = eps
        b.set_joint_state(q + dq)
        plus = tensions @ b.cable_lengths
        b.set_joint_state(q - dq)
        minus = tensions @ b.cable_lengths
        fd[k] = -(plus - minus) / (2 * eps)
    scale = np.max(np.abs(tau))
    assert scale > 1e-3
    np.testing.assert_allclose(tau, fd, rtol=0.0, atol=1e-6 * scale)


def test_a_cable_crosses_exactly_the_spans_of_its_own_and_the_proximal_sections():
    chain = DiscreteBackbone(MIXED2)
    expected = np.zeros((14, 7), dtype=bool)
    expected[:, :4] = np.arange(14)[:, None] < 8  # section 1's cables end at disk 8
    expected[:, 4:] = True  # section 2's cables run base to tip
    np.testing.assert_array_equal(chain.routed, expected)


def test_straight_lengths_are_the_run_lengths_and_a_distal_pull_shortens_proximal_runs(make):
    b = make(TDCR2, gravity=False)
    np.testing.assert_allclose(b.cable_lengths, TDCR2.cable_run_lengths, rtol=0, atol=1e-12)
    t = np.zeros(6)
    t[3] = TDCR2.max_tension  # a distal cable: bends both sections towards it
    b.reset(t)
    lengths = b.cable_lengths
    run = np.asarray(TDCR2.cable_run_lengths)
    assert lengths[3] < run[3] - 1e-3  # the pulled cable shortens over its whole run
    assert lengths[0] < run[0] - 1e-4  # the proximal cable at the same angle shortens too
    # the tip leans towards the pulled cable's angle (90°: +y)
    assert b.tip[1] > 0.05 and abs(b.tip[0]) < 1e-9


def test_tdcr2_settles_to_its_equilibrium(make):
    b = make(TDCR2, gravity=False)
    rng = np.random.default_rng(1)
    t = rng.uniform(0.0, TDCR2.max_tension, 6)
    for _ in range(150):  # 3 s
        b.apply_tensions(t)
    eq = b.equilibrium(t[None])
    np.testing.assert_allclose(b.tip, eq.tip[0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(b.cable_lengths, eq.cable_lengths[0], rtol=0, atol=1e-7)
    assert np.max(np.abs(b.joint_velocities)) < 1e-5


# -- the dense-disk limit -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "params, n_disks", [(TDCR2, 100), (THREE, 80)], ids=["tdcr2x100", "three-sections-x80"]
)
def test_dense_disks_converge_to_the_pcc_model(params, n_disks):
    """Gravity off, many disks: the settled tip (the chain's statics, which the simulation
    settles to; longer chains than one pybullet body holds) is the PCC tip within 0.5 % of ℓ."""
    dense = with_disks(params, n_disks)
    chain = DiscreteBackbone(dense, gravity=False)
    analytic = AnalyticBackend(dense)
    rng = np.random.default_rng(0)
    tensions = rng.uniform(0.0, params.max_tension, (5, params.n_cables))
    pcc = analytic.equilibrium(tensions).tip
    for t, want in zip(tensions, pcc):
        q, converged = chain.static_equilibrium(t)
        assert converged
        err = np.linalg.norm(chain.pose(q).stations[-1] - want)
        assert err < 0.005 * dense.length, (t, err)
        assert np.linalg.norm(want - (0.0, 0.0, dense.length)) > 0.05 * dense.length  # bent


def test_the_pybullet_backend_converges_to_pcc_at_second_order_in_the_disk_spacing(make):
    """tdcr2 with 10 and with 30 disks per section (60 joints, the most one body holds):
    the tip error against PCC falls by ≈ (30/10)² = 9."""
    rng = np.random.default_rng(0)
    tensions = rng.uniform(0.0, TDCR2.max_tension, (3, 6))
    errors = []
    for n in (10, 30):
        p = with_disks(TDCR2, n)
        b = make(p, gravity=False)
        tips = b.equilibrium(tensions).tip
        errors.append(np.linalg.norm(tips - AnalyticBackend(p).equilibrium(tensions).tip, axis=1))
    ratio = errors[1] / errors[0]
    assert np.all((ratio > 1 / 12) & (ratio < 1 / 6)), ratio


# -- envs ---------------------------------------------------------------------------------------


def test_bullet_goals_come_from_the_bullet_statics_not_from_ccka():
    """The goal of a seeded reset is the bullet backend's equilibrium under the tensions the
    env draws (gravity on: visibly not the CCKA tip of the same tensions)."""
    env = gym.make("cdcr_gym/BulletReach-v0", robot="tdcr2")
    _, info = env.reset(seed=11)
    rng = seeding.np_random(11)[0]
    t = sample_tensions_each([rng], TDCR2)
    own = env.unwrapped.backend.equilibrium(t).tip[0]
    np.testing.assert_allclose(info["goal"], own, rtol=0, atol=1e-12)
    ccka = AnalyticBackend(TDCR2).equilibrium(t).tip[0]
    assert np.linalg.norm(own - ccka) > 1e-3
    env.close()


def test_random_starts_are_bullet_equilibria():
    env = gym.make("cdcr_gym/BulletReach-v0", robot="tdcr2", initial_state="random")
    _, info = env.reset(seed=4)
    backend = env.unwrapped.backend
    eq = backend.equilibrium(info["tensions"][None])
    np.testing.assert_allclose(info["tip"], eq.tip[0], rtol=0, atol=1e-12)
    assert np.any(info["tensions"] > 0)
    env.close()


def test_tdcr2_action_is_one_tension_per_cable_section_by_section():
    env = gym.make("cdcr_gym/BulletReach-v0", robot="tdcr2", action_mode="tension", gravity=False)
    env.reset(seed=0)
    action = np.full(6, -1.0, dtype=np.float32)
    action[4] = 1.0  # section 2's second cable (−30°)
    _, _, _, _, info = env.step(action)
    np.testing.assert_allclose(info["tensions"], [0, 0, 0, 0, TDCR2.max_tension, 0])
    assert info["tip"][0] > 0 and info["tip"][1] < 0  # towards −30°
    env.close()


# -- the span-buckling limit (issue 14 item 7) -------------------------------------------------


def test_span_buckling_load_is_where_the_straight_chain_loses_stability():
    """The closed form (4EI/Δ²)·sin²(π/2m) equals the zero of the linearised chain's tangent
    stiffness, and stays below Euler's load of the real span."""
    for n, m in ((3, 1), (5, 1), (3, 2), (4, 3)):
        p = replace(RobotParams(), n_disks=n, max_tension=1.0)
        crit = span_buckling_loads(p, m)[0][0]
        assert crit == pytest.approx(linearised_critical_load(p, m), rel=1e-5)
        assert crit < math.pi**2 * p.bending_stiffness / p.disk_spacing**2


def test_three_disks_at_80_newton_are_rejected_as_buckling(make):
    """The issue's reproduction: n_disks=3 diverged holding 80/80/80 N after ≈ 1.7 s."""
    with pytest.raises(ValueError, match=r"params\.sections\[0\] \(n_disks=3.*buckles"):
        make(RobotParams(n_disks=3))
    with pytest.raises(ValueError, match="buckles"):
        gym.make("cdcr_gym/BulletReach-v0", params=RobotParams(n_disks=3))


def test_a_robot_just_inside_the_limit_holds_every_cable_at_max_tension(make):
    """3 disks with max_tension at 90 % of the bound: 4 s at the maximum, straight and still."""
    crit = span_buckling_loads(RobotParams(n_disks=3), 1)[0][0]
    p = RobotParams(n_disks=3, max_tension=0.9 * crit / 3)
    b = make(p, gravity=False)
    for _ in range(200):
        b.apply_tensions(np.full(3, p.max_tension))
    assert np.max(np.abs(b.joint_positions)) < 1e-6
    with pytest.raises(ValueError, match="buckles"):
        make(RobotParams(n_disks=3, max_tension=1.01 * crit / 3))


# -- bad input ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"params": with_disks(TDCR2, 31)}, "params"),  # 62 joints
        ({"params": TDCR2, "links_per_span": 4}, "links_per_span"),  # 80 joints
        ({"params": TDCR2, "links_per_span": 0}, "links_per_span"),
        ({"params": "tdcr2"}, "params"),
    ],
)
def test_bad_construction_raises_value_error_naming_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        BulletBackend(**kwargs)


def test_too_many_joints_names_the_limit():
    with pytest.raises(ValueError, match=f"at most {MAX_JOINTS}"):
        BulletBackend(with_disks(TDCR2, 31))


@pytest.mark.parametrize(
    "tensions",
    [
        np.zeros(3),  # one section's worth
        np.zeros((2, 3)),
        np.array([1.0, 1.0, -0.1, 0.0, 0.0, 0.0]),
        np.array([1.0, 1.0, np.nan, 0.0, 0.0, 0.0]),
        np.full(6, TDCR2.max_tension + 0.1),
        "abc",
    ],
)
def test_bad_tensions_raise_value_error_naming_tensions(make, tensions):
    b = make(TDCR2, gravity=False)
    for call in (b.reset, b.apply_tensions, b.equilibrium):
        with pytest.raises(ValueError, match="tensions"):
            call(tensions)


def test_disk_frames_carry_every_routed_pinhole(make):
    """Base-interface contract: pinhole = centre_k + R_k (r cos β, r sin β, 0) on every disk a
    cable passes (MIXED2: different spacings per section, m = 2)."""
    b = make(MIXED2, links_per_span=2, gravity=True)
    b.reset(np.linspace(0.0, MIXED2.max_tension, MIXED2.n_cables))
    centres, rots = b.disk_frames()
    pins = b.pinhole_positions()
    local = b.chain.disk_pinholes
    want = centres[:, None, :] + np.einsum("kij,kcj->kci", rots, local)
    np.testing.assert_allclose(pins, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(centres[-1], b.tip, rtol=0, atol=1e-15)
    assert b.backbone_points().shape == (2 * b.n_links + 1, 3)


def test_gui_without_a_display_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="display"):
        BulletBackend(TDCR2, gui=True)
