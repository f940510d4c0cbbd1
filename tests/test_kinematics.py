"""CCKA kinematics against independent derivations (numerical integration of the arc)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from cdcr_gym import kinematics as K
from cdcr_gym.params import CABLE_ANGLES, RobotParams

pytestmark = pytest.mark.filterwarnings("error")

P = RobotParams()
ELL, R = P.length, P.cable_radius

# Gauss–Legendre nodes on [0, 1]: exact to machine precision for these smooth integrands.
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(60)
_S = 0.5 * (_NODES + 1.0)
_W = 0.5 * _WEIGHTS


def _tangent(theta, phi, s):
    """Unit tangent of the constant-curvature backbone at arc fraction s: Rz(φ)Ry(θs)Rz(−φ)·ez."""
    a = theta[..., None] * s
    return np.stack(
        [np.sin(a) * np.cos(phi)[..., None], np.sin(a) * np.sin(phi)[..., None], np.cos(a)],
        axis=-1,
    )


def integrated_tip(theta, phi, length):
    """Tip by integrating the tangent along the arc (independent of eq. 1)."""
    return length * np.einsum("...ki,k->...i", _tangent(theta, phi, _S), _W)


def integrated_cable_length(theta, phi, length, r, beta):
    """Length of a cable fixed at radius r, angle β in each cross-section (no twist).

    The cable point is c(s) = p(s) + R(s)·(r cos β, r sin β, 0); its speed is integrated.
    """
    kappa = theta / length
    a = theta[..., None] * _S
    cp, sp = np.cos(phi)[..., None], np.sin(phi)[..., None]
    offset = r * np.cos(beta - phi)[..., None]  # component of the offset in the bending plane
    # d/ds of R(s)·offset: only the in-plane component rotates, at rate κ, along −tangent.
    speed_factor = 1.0 - kappa[..., None] * offset
    tangent = np.stack([np.sin(a) * cp, np.sin(a) * sp, np.cos(a)], axis=-1)
    velocity = tangent * speed_factor[..., None]
    return length * np.einsum("...k,k->...", np.linalg.norm(velocity, axis=-1), _W)


def random_arcs(n, seed=0):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, np.pi, n)
    theta[:5] = [0.0, 1e-12, 1e-6, 1e-3, np.pi]
    phi = rng.uniform(-np.pi, np.pi, n)
    return theta, phi


def test_straight_robot_tip_is_exact():
    tip = K.forward_kinematics(np.full(3, ELL), R)
    assert tip.tolist() == [0.0, 0.0, 0.641]
    assert K.tip_from_arc(0.0, 1.234, ELL).tolist() == [0.0, 0.0, 0.641]


def test_papers_eq5_as_printed_gives_twice_the_length_and_ours_does_not():
    # The printed Z line, (r L_sum / L_sqr) sin(2 L_sqr / 3r), tends to 4ℓ/... : at equal lengths
    # its limit is r·3ℓ·(2/3r) = 2ℓ = 1.282 m. The corrected form has the extra factor 1/2.
    lengths = np.full(3, ELL)
    lengths[0] -= 1e-9  # stay off the exact 0/0 to evaluate the printed formula
    l_sum = lengths.sum()
    l_sqr = np.sqrt(
        np.sum(lengths**2)
        - lengths[0] * lengths[1]
        - lengths[0] * lengths[2]
        - lengths[1] * lengths[2]
    )
    printed_z = R * l_sum / l_sqr * np.sin(2 * l_sqr / (3 * R))
    assert printed_z == pytest.approx(1.282, abs=1e-3)
    assert K.forward_kinematics(lengths, R)[2] == pytest.approx(0.641, abs=1e-9)


def test_tip_matches_integrated_arc_at_1000_configurations():
    theta, phi = random_arcs(1000)
    expected = integrated_tip(theta, phi, ELL)
    got = K.tip_from_arc(theta, phi, ELL)
    assert np.max(np.linalg.norm(got - expected, axis=-1)) <= 1e-9


def test_lengths_match_integrated_cable_paths():
    theta, phi = random_arcs(1000, seed=1)
    lengths = K.lengths_from_arc(theta, phi, ELL, R)
    for i, beta in enumerate(CABLE_ANGLES):
        expected = integrated_cable_length(theta, phi, ELL, R, beta)
        assert np.max(np.abs(lengths[:, i] - expected)) <= 1e-9


def test_forward_kinematics_matches_integrated_tip():
    theta, phi = random_arcs(1000, seed=2)
    lengths = K.lengths_from_arc(theta, phi, ELL, R)
    got = K.forward_kinematics(lengths, R)
    expected = integrated_tip(theta, phi, ELL)
    assert np.max(np.linalg.norm(got - expected, axis=-1)) <= 1e-9


def test_arc_round_trip_and_phi_in_all_four_quadrants():
    for phi in np.radians([30.0, 120.0, -150.0, -60.0, 0.0, 90.0, 180.0, -90.0]):
        lengths = K.lengths_from_arc(0.8, phi, ELL, R)
        theta_back, phi_back, kappa = K.arc_from_lengths(lengths, R)
        assert theta_back == pytest.approx(0.8, abs=1e-12)
        assert np.angle(np.exp(1j * (phi_back - phi))) == pytest.approx(0.0, abs=1e-12)
        assert kappa == pytest.approx(0.8 / ELL, rel=1e-12)
        tip = K.forward_kinematics(lengths, R)
        assert np.arctan2(tip[1], tip[0]) == pytest.approx(
            np.arctan2(np.sin(phi), np.cos(phi)), abs=1e-12
        )


def test_equal_lengths_give_phi_zero_and_theta_zero():
    theta, phi, kappa = K.arc_from_lengths(np.full((4, 3), 0.5), R)
    assert np.all(theta == 0.0) and np.all(phi == 0.0) and np.all(kappa == 0.0)


def test_inverse_kinematics_round_trip():
    theta, phi = random_arcs(1000, seed=3)
    theta = theta * (np.pi - 1e-6) / np.pi  # θ = π exactly folds the tip onto the base plane
    tips = K.tip_from_arc(theta, phi, ELL)
    lengths, residual = K.inverse_kinematics(tips, ELL, R, return_residual=True)
    assert np.max(residual) <= 1e-9
    back = K.forward_kinematics(lengths, R)
    assert np.max(np.linalg.norm(back - tips, axis=-1)) <= 1e-9


def test_inverse_kinematics_off_surface_returns_nearest_arc():
    rng = np.random.default_rng(4)
    points = rng.uniform([-0.6, -0.6, -0.2], [0.6, 0.6, 0.7], size=(200, 3))
    lengths, residual = K.inverse_kinematics(points, ELL, R, return_residual=True)
    reached = K.forward_kinematics(lengths, R)
    assert np.allclose(np.linalg.norm(reached - points, axis=-1), residual, atol=1e-12)
    # brute force over a dense grid of the surface
    th = np.linspace(0.0, np.pi, 4001)
    for p, res in zip(points, residual):
        ph = np.arctan2(p[1], p[0]) + np.array([0.0, np.pi])
        surface = K.tip_from_arc(th[:, None], ph[None, :], ELL)
        brute = np.min(np.linalg.norm(surface - p, axis=-1))
        assert res <= brute + 1e-12
        assert res >= brute - ELL * (np.pi / 4000) / 2  # a grid point lies within half a step


def test_batched_equals_per_row():
    theta, phi = random_arcs(50, seed=5)
    lengths = K.lengths_from_arc(theta, phi, ELL, R).reshape(5, 10, 3)
    batched_tip = K.forward_kinematics(lengths, R)
    batched_arc = K.arc_from_lengths(lengths, R)
    batched_ik = K.inverse_kinematics(batched_tip, ELL, R)
    for i in range(5):
        for j in range(10):
            assert np.array_equal(K.forward_kinematics(lengths[i, j], R), batched_tip[i, j])
            row = K.arc_from_lengths(lengths[i, j], R)
            assert all(np.array_equal(a, b[i, j]) for a, b in zip(row, batched_arc))
            assert np.allclose(
                K.inverse_kinematics(batched_tip[i, j], ELL, R),
                batched_ik[i, j],
                atol=1e-15,
                rtol=0,
            )


def test_no_warnings_near_the_singularity():
    theta = np.concatenate([[0.0, 1e-300, 1e-12, 1e-6], np.linspace(0, np.pi, 101)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lengths = K.lengths_from_arc(theta, 0.3, ELL, R)
        out = [
            K.tip_from_arc(theta, 0.3, ELL),
            K.forward_kinematics(lengths, R),
            *K.arc_from_lengths(lengths, R),
            K.inverse_kinematics(K.tip_from_arc(theta, 0.3, ELL), ELL, R),
            K.tip_pose(theta, 0.3, ELL),
            K.backbone_points(theta, 0.3, ELL, 7),
        ]
    assert all(np.all(np.isfinite(o)) for o in out)


def test_tip_pose_is_a_rotation_with_the_arc_tangent():
    theta, phi = random_arcs(100, seed=6)
    pose = K.tip_pose(theta, phi, ELL)
    rot = pose[:, :3, :3]
    assert np.allclose(rot @ np.swapaxes(rot, -1, -2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(rot), 1.0)
    assert np.allclose(rot[:, :, 2], _tangent(theta, phi, np.array([1.0]))[:, 0], atol=1e-12)
    assert np.allclose(pose[:, :3, 3], K.tip_from_arc(theta, phi, ELL))


def test_backbone_points_run_from_base_to_tip_with_equal_spacing():
    pts = K.backbone_points(1.1, 0.4, ELL, 11)
    assert np.allclose(pts[0], 0.0) and np.allclose(pts[-1], K.tip_from_arc(1.1, 0.4, ELL))
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=-1)
    assert np.allclose(chords, chords[0])


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: K.arc_from_lengths([0.6, 0.6, np.nan], R), "lengths"),
        (lambda: K.arc_from_lengths([0.6, 0.6], R), "lengths"),
        (lambda: K.arc_from_lengths([0.6, 0.6, 0.6], -1.0), "r"),
        (lambda: K.tip_from_arc(0.1, 0.2, 0.0), "length"),
        (lambda: K.inverse_kinematics([0.1, np.inf, 0.3], ELL, R), "tip"),
        (lambda: K.backbone_points(0.1, 0.2, ELL, 1), "n"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call()
