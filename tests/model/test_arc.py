"""model.arc: the same results as today's cdcr_gym.kinematics, exact at θ = 0, strict inputs."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from tolerances import close

from cdcr_gym.model import arc as A
from cdcr_gym.model.params import RobotParams

#: The legacy one-section model's outputs on fixed inputs (tests/data/write_legacy_arrays.py).
OLD = np.load(Path(__file__).parents[1] / "data" / "legacy_kinematics.npz")

pytestmark = pytest.mark.filterwarnings("error")

P = RobotParams()
ELL, R = P.length, P.cable_radius


def _arcs(n, seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, np.pi, n)
    theta[:5] = [0.0, 1e-300, 1e-12, 1e-6, np.pi]
    return theta, rng.uniform(-np.pi, np.pi, n)


def test_public_functions_equal_todays_kinematics():
    theta, phi = _arcs(2000, 0)
    assert close(theta, OLD["theta"]) and close(phi, OLD["phi"])
    lengths = OLD["lengths_from_arc"]
    assert np.max(np.abs(A.lengths_from_arc(theta, phi, ELL, R) - lengths)) <= 1e-15
    assert np.max(np.abs(A.tip_from_arc(theta, phi, ELL) - OLD["tip_from_arc"])) <= 1e-15
    assert np.max(np.abs(A.forward_kinematics(lengths, R) - OLD["forward_kinematics"])) <= 1e-15
    for i, a in enumerate(A.arc_from_lengths(lengths, R)):
        assert np.allclose(a, OLD[f"arc_from_lengths_{i}"], rtol=0, atol=1e-12)
    assert np.max(np.abs(A.tip_rotation(theta, phi) - OLD["tip_rotation"])) <= 1e-15
    assert np.max(np.abs(A.tip_pose(theta, phi, ELL) - OLD["tip_pose"])) <= 1e-15
    points_50 = A.backbone_points(theta[:50], phi[:50], ELL, 9)
    assert np.max(np.abs(points_50 - OLD["backbone_points_50_9"])) <= 1e-15
    points = np.random.default_rng(1).uniform([-0.6, -0.6, -0.2], [0.6, 0.6, 0.7], (300, 3))
    assert close(points, OLD["points"][:300])
    points = OLD["points"]
    for i, a in enumerate(A.arc_from_tip(points, ELL)):
        assert np.allclose(a, OLD[f"arc_from_tip_{i}"], rtol=0, atol=1e-12)
    got = A.inverse_kinematics(points, ELL, R, return_residual=True)
    assert all(
        np.allclose(a, OLD[f"inverse_kinematics_{i}"], rtol=0, atol=1e-12)
        for i, a in enumerate(got)
    )


def test_arc_profile_is_exact_at_zero_and_matches_the_definition():
    f, g = A.arc_profile(np.array([0.0, -0.0, 1e-300]))
    assert f.tolist() == [0.5, 0.5, 0.5] and g.tolist() == [1.0, 1.0, 1.0]
    theta = np.linspace(0.1, np.pi, 200)
    f, g = A.arc_profile(theta)
    assert np.allclose(f, 2 * np.sin(theta / 2) ** 2 / theta**2, rtol=1e-14, atol=0)
    assert np.allclose(g, np.sin(theta) / theta, rtol=1e-13, atol=1e-16)
    assert np.array_equal(A.arc_profile(-theta)[0], f)  # even
    assert A.tip_from_arc(0.0, 1.234, ELL).tolist() == [0.0, 0.0, ELL]


def test_no_warnings_near_the_singularity():
    theta = np.concatenate([[0.0, 1e-300, 1e-12, 1e-6], np.linspace(0, np.pi, 101)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lengths = A.lengths_from_arc(theta, 0.3, ELL, R)
        out = [
            A.tip_from_arc(theta, 0.3, ELL),
            A.forward_kinematics(lengths, R),
            *A.arc_from_lengths(lengths, R),
            A.tip_pose(theta, 0.3, ELL),
            A.backbone_points(theta, 0.3, ELL, 7),
            A.inverse_kinematics(A.tip_from_arc(theta, 0.3, ELL), ELL, R),
        ]
    assert all(np.all(np.isfinite(o)) for o in out)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: A.tip_from_arc(np.nan, 0.2, ELL), "theta"),
        (lambda: A.tip_from_arc(0.1, np.nan, ELL), "phi"),
        (lambda: A.tip_from_arc(0.1, 0.2, 0.0), "length"),
        (lambda: A.tip_from_arc(3.5, 0.2, ELL), "theta"),
        (lambda: A.tip_from_arc(-0.1, 0.2, ELL), "theta"),
        (lambda: A.lengths_from_arc([0.1, np.nan], 0.2, ELL, R), "theta"),
        (lambda: A.lengths_from_arc(0.1, 0.2, ELL, -R), "r"),
        (lambda: A.backbone_points(np.nan, 0.2, ELL, 5), "theta"),
        (lambda: A.backbone_points(0.1, 0.2, ELL, 1), "n"),
        (lambda: A.tip_rotation(np.nan, 0.2), "theta"),
        (lambda: A.tip_rotation(0.1, np.inf), "phi"),
        (lambda: A.tip_pose(0.1, np.nan, ELL), "phi"),
        (lambda: A.arc_from_lengths([0.6, 0.6, np.nan], R), "lengths"),
        (lambda: A.arc_from_lengths([0.6, 0.6], R), "lengths"),
        (lambda: A.arc_from_lengths([0.6, -0.1, 0.6], R), "lengths"),
        (lambda: A.forward_kinematics([0.6, -0.1, 0.6], R), "lengths"),
        (lambda: A.inverse_kinematics([0.1, np.inf, 0.3], ELL, R), "tip"),
        (lambda: A.arc_from_tip([0.1, 0.3], ELL), "tip"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call()
