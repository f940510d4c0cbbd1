"""The capstan tension profile (cdcr_gym.model.friction)."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym.model import friction as F
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams


def _paper_pinholes(theta: float, phi: float = 0.0, cable: int = 0) -> np.ndarray:
    params = RobotParams()
    model = PCCModel(params)
    w = np.array([[theta * np.cos(phi), theta * np.sin(phi)]])  # (S=1, 2)
    centres, rotations = model.disk_frames(w)
    return F.pinhole_positions(
        centres, rotations, params.cable_radii[cable], params.cable_angles[cable]
    )


def test_static_decay_across_one_disk_is_the_capstan_factor():
    rng = np.random.default_rng(0)
    for _ in range(20):
        mu, alpha, t0 = rng.uniform(0.01, 0.5), rng.uniform(0.0, 1.5), rng.uniform(1.0, 80.0)
        pulled = F.tension_profile(t0, [alpha], mu, slip=1.0)
        released = F.tension_profile(t0, [alpha], mu, slip=-1.0)
        assert pulled[-1] / t0 == pytest.approx(np.exp(-mu * alpha), rel=1e-14)
        assert released[-1] / t0 == pytest.approx(np.exp(mu * alpha), rel=1e-14)


def test_zero_friction_keeps_the_tension_constant_along_the_cable():
    wraps = _paper_wraps(1.2)
    profile = F.tension_profile(np.array([10.0, 55.5]), np.stack([wraps, wraps]), 0.0, slip=1.0)
    assert np.array_equal(profile, np.broadcast_to([[10.0], [55.5]], profile.shape))


def _paper_wraps(theta: float) -> np.ndarray:
    return F.wrap_angles(_paper_pinholes(theta))


def test_profile_is_monotone_in_the_sliding_direction():
    wraps = _paper_wraps(1.0)
    assert np.all(wraps > 0)
    pulled = F.tension_profile(40.0, wraps, 0.2, slip=1.0)
    released = F.tension_profile(40.0, wraps, 0.2, slip=-1.0)
    stick = F.tension_profile(40.0, wraps, 0.2, slip=0.3)
    assert np.all(np.diff(pulled) < 0) and pulled[0] < 40.0
    assert np.all(np.diff(released) > 0) and released[0] > 40.0
    # any |s| <= 1 stays inside the stick band of every disk
    ratios = np.concatenate([[stick[0] / 40.0], stick[1:] / stick[:-1]])
    assert np.all(ratios >= np.exp(-0.2 * wraps) - 1e-15)
    assert np.all(ratios <= np.exp(0.2 * wraps) + 1e-15)


def test_wrap_angles_of_an_arc_add_up_to_its_bend_less_half_a_span():
    # chords of a circular arc turn by θ/n per disk; the base disk sees half of that from +Z0,
    # the anchor none: Σα = θ (1 − 1/(2n)) for any cable, in any bending plane
    n = RobotParams().n_disks
    for theta, phi, cable in [(0.3, 0.0, 0), (1.4, 0.7, 1), (2.5, -2.0, 2)]:
        wraps = F.wrap_angles(_paper_pinholes(theta, phi, cable))
        assert wraps.shape == (n,)
        assert wraps.sum() == pytest.approx(theta * (1 - 1 / (2 * n)), rel=1e-9)
        assert np.allclose(wraps[1:], theta / n, rtol=1e-9)


def test_straight_cable_has_no_wrap_and_spec_example():
    assert np.array_equal(_paper_wraps(0.0), np.zeros(RobotParams().n_disks))
    # SPEC §7: μ = 0.2, θ = 80°, pulling: the anchor sees ≈ 24 % less than the actuator
    ratio = F.anchor_tension(1.0, _paper_wraps(np.radians(80.0)), 0.2) / 1.0
    assert 0.74 < ratio < 0.78


def test_batched_shapes():
    p = np.stack([_paper_pinholes(t) for t in (0.1, 0.5, 1.0)])  # (3, D+1, 3)
    wraps = F.wrap_angles(p)
    assert wraps.shape == (3, RobotParams().n_disks)
    prof = F.tension_profile(np.full(3, 20.0), wraps, np.array([0.0, 0.1, 0.3]), np.ones(3))
    assert prof.shape == wraps.shape
    assert np.all(prof[0] == 20.0)
    assert prof[2, -1] < prof[1, -1] < 20.0


def test_slip_laws():
    assert F.slip_from_speed(0.0, 1e-3) == 0.0
    assert F.slip_from_speed(1e-3, 1e-3) == pytest.approx(np.tanh(1.0))
    s = F.update_slip(0.0, np.array([1e-4, -1e-4, 0.0]), 1e-4)
    assert s == pytest.approx([1 - np.exp(-1), -(1 - np.exp(-1)), 0.0])
    # memory: a stopped cable keeps its state; long sliding saturates at the Coulomb limit
    assert F.update_slip(0.42, 0.0, 1e-4) == 0.42
    assert F.update_slip(-1.0, 1.0, 1e-4) == pytest.approx(1.0)
    # composition: two half steps equal one full step (exact solution of the ODE)
    half = F.update_slip(F.update_slip(-0.5, 3e-5, 1e-4), 3e-5, 1e-4)
    assert half == pytest.approx(F.update_slip(-0.5, 6e-5, 1e-4), rel=1e-14)


@pytest.mark.parametrize("bad", [-0.1, np.nan, np.inf, "0.2", True])
def test_bad_friction_coefficient_is_named(bad):
    with pytest.raises(ValueError, match="friction_coefficient"):
        F.tension_profile(10.0, [0.1], bad)


def test_bad_inputs_are_named():
    with pytest.raises(ValueError, match="slip"):
        F.tension_profile(10.0, [0.1], 0.1, slip=1.5)
    with pytest.raises(ValueError, match="wraps"):
        F.tension_profile(10.0, [-0.1], 0.1)
    with pytest.raises(ValueError, match="velocity_scale"):
        F.slip_from_speed(1.0, 0.0)
    with pytest.raises(ValueError, match="slip_length"):
        F.update_slip(0.0, 1.0, -1.0)
    with pytest.raises(ValueError, match="pinholes"):
        F.wrap_angles(np.zeros((1, 3)))
