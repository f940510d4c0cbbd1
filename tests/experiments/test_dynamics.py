"""The committed bending-frequency reference (experiments/dynamics/reference.json) and the
backends' frequencies and damping against it (experiments.dynamics_reference, .dynamics_check)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams
from experiments import dynamics_check as dc
from experiments import dynamics_reference as dr

REF = json.loads(dc.REFERENCE.read_text())


def _ref(name: str, case: str) -> list[float]:
    return REF["robots"][name]["cases"][case]["frequencies_hz"]


def test_reference_covers_every_robot_and_case():
    assert set(REF["robots"]) == set(dr.ROBOTS)
    for robot in REF["robots"].values():
        assert set(robot["cases"]) == {
            f"{c}_gravity_{g}" for c in ("slack", "taut") for g in ("on", "off")
        }
        for case in robot["cases"].values():
            f1, f2 = case["frequencies_hz"]
            assert 0.0 < f1 < f2
            assert case["last_refinement_rel_change"] < 1e-4  # converged


def test_reference_analytic_checks_within_one_percent():
    """The committed FE frequencies of a uniform clamped-free beam (λ₁ = 1.875) and of one
    with a tip mass equal the analytic roots within 1 %."""
    checks = REF["analytic_checks"]
    assert len(checks) == 2
    for chk in checks.values():
        np.testing.assert_allclose(chk["fe_hz"], chk["analytic_hz"], rtol=0.01)
    bare = checks["uniform_beam_tip_mass_0kg"]
    ei, mu, length = (
        bare["bending_stiffness_Nm2"],
        bare["linear_density_kg_per_m"],
        bare["length_m"],
    )
    omega1 = 1.875104**2 * math.sqrt(ei / (mu * length**4))
    assert bare["fe_hz"][0] == pytest.approx(omega1 / (2 * math.pi), rel=1e-4)


def test_beam_solver_matches_analytic_tip_mass_live():
    p = RobotParams.preset("paper")
    ei, mu, length = p.bending_stiffness, p.backbone_linear_density, p.length
    fe = dr.beam_frequencies(
        [(length / 3, 3)], ei, mu, 0.0, [(0.0, 0.0), (0.0, 0.0), (0.1, 0.0)], [0.0] * 3, 4
    )
    np.testing.assert_allclose(fe, dr.uniform_beam_frequencies(length, ei, mu, 0.1), rtol=1e-5)


def test_reference_reproduces_from_robot_params():
    """A coarse re-solve from today's RobotParams gives the committed numbers (the reference
    describes the same robot)."""
    p = RobotParams.preset("paper")
    model = dr._robot_model(p, 0.5 * p.max_tension)
    got = dr.beam_frequencies(**model, elements_per_span=4, gravity=STANDARD_GRAVITY)
    np.testing.assert_allclose(got, _ref("paper", "taut_gravity_on"), rtol=1e-4)


def test_gravity_and_tension_lower_the_frequencies():
    for name in dr.ROBOTS:
        slack = _ref(name, "slack_gravity_off")
        assert _ref(name, "slack_gravity_on")[0] < slack[0]
        assert _ref(name, "taut_gravity_off")[0] < slack[0]


@pytest.mark.parametrize("case", ["slack_gravity_off", "slack_gravity_on", "taut_gravity_on"])
def test_mujoco_linearised_paper_robot_within_3_percent(case):
    p = RobotParams.preset("paper")
    tension = 0.5 * p.max_tension if case.startswith("taut") else 0.0
    got = dc.mujoco_linearised("paper", case.endswith("on"), tension)
    np.testing.assert_allclose(got, _ref("paper", case), rtol=0.03)


def test_bullet_linearised_paper_robot_within_3_percent():
    got = dc.bullet_linearised("paper", True, 0.0)
    np.testing.assert_allclose(got, _ref("paper", "slack_gravity_on"), rtol=0.03)


def test_fit_damped_sinusoid_recovers_a_known_signal():
    t = np.arange(0.0, 3.0, 0.002)
    w, z = 2 * math.pi * 3.0, 0.1
    x = 0.01 * np.exp(-z * w * t) * np.cos(w * math.sqrt(1 - z * z) * t + 0.3) + 0.002
    got_w, got_z = dc.fit_damped_sinusoid(t, x)
    assert got_w == pytest.approx(w, rel=1e-6)
    assert got_z == pytest.approx(z, rel=1e-6)


def test_mujoco_damping_ratio_is_the_first_modes_within_10_percent():
    """A released tip decays with the set ζ (fine timestep: the model, not the integrator) at
    the reference frequency."""
    res = dc.free_vibration("mujoco", "paper", 0.2, physics_timestep=0.002, duration=1.5)
    assert res["damping_ratio_fit"] == pytest.approx(0.2, rel=0.10)
    assert res["frequency_hz"] == pytest.approx(_ref("paper", "slack_gravity_off")[0], rel=0.03)


def test_bullet_damping_is_the_set_ratio_despite_backward_euler():
    """bullet's backward-Euler step adds ≈ h·ω₁/2 to the first mode's damping ratio; the
    backend lowers β by that (``backends/bullet/damping.py``): the released tip decays with
    the set ζ within 10 %, at the reference frequency within 3 %."""
    h, zeta = 0.005, 0.2
    res = dc.free_vibration("bullet", "paper", zeta, physics_timestep=h, duration=1.5)
    omega1 = 2 * math.pi * _ref("paper", "slack_gravity_off")[0]
    assert res["damping_ratio_fit"] == pytest.approx(zeta, rel=0.10)
    assert res["frequency_hz"] == pytest.approx(omega1 / (2 * math.pi), rel=0.03)


def test_gravity_keeps_the_first_modes_damping_ratio():
    """Gravity softens the first mode to ω₁ᵍ (tdcr2: ω₁/ω₁ᵍ = 1.10) while D = β·K damps the
    elastic stiffness only; β is taken for the mode with gravity, so ζ₁ stays the set one."""
    zeta = 0.05
    res = dc.free_vibration(
        "mujoco", "tdcr2", zeta, physics_timestep=0.001, gravity=True, duration=4.0
    )
    assert res["damping_ratio_fit"] == pytest.approx(zeta, rel=0.03)
    assert res["frequency_hz"] == pytest.approx(_ref("tdcr2", "slack_gravity_on")[0], rel=0.03)
