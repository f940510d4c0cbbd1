"""Pure-moment statics: tensions -> bending, tension IK, the reachable bending limit."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym.model import statics as S
from cdcr_gym.params import CABLE_ANGLES, RobotParams

pytestmark = pytest.mark.filterwarnings("error")

P = RobotParams()


@pytest.mark.parametrize("cable", [0, 1, 2])
@pytest.mark.parametrize("tension", [1.0, 10.0, 40.0, 80.0])
def test_single_cable_bends_by_trl_over_ei_towards_that_cable(cable, tension):
    tensions = np.zeros(3)
    tensions[cable] = tension
    theta, phi = S.arc_from_tensions(tensions, P)
    assert theta == pytest.approx(tension * P.cable_radius * P.length / P.bending_stiffness)
    assert np.angle(np.exp(1j * (phi - CABLE_ANGLES[cable]))) == pytest.approx(0.0, abs=1e-12)


def test_common_mode_tension_does_not_bend():
    rng = np.random.default_rng(0)
    tensions = rng.uniform(0, 40, size=(100, 3))
    extra = rng.uniform(0, 40, size=(100, 1))
    t1, p1 = S.arc_from_tensions(tensions, P)
    t2, p2 = S.arc_from_tensions(tensions + extra, P)
    assert np.allclose(t1, t2, atol=1e-12)
    assert np.allclose(np.exp(1j * p1), np.exp(1j * p2), atol=1e-9)
    assert S.arc_from_tensions(np.full(3, 55.0), P)[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("pretension", [0.0, 5.0])
def test_tension_ik_reproduces_the_wanted_arc_with_non_negative_tensions(pretension):
    rng = np.random.default_rng(1)
    phi = rng.uniform(-np.pi, np.pi, 500)
    theta = rng.uniform(0, 1, 500) * S.bending_limit(phi, P, pretension)
    tensions, clipped = S.tensions_from_arc(theta, phi, P, pretension=pretension)
    assert not clipped.any()
    assert np.all(tensions >= pretension - 1e-12) and np.all(tensions <= P.max_tension + 1e-9)
    # minimal: the cable opposite the bend carries only the pretension
    assert np.allclose(tensions.min(axis=-1), pretension, atol=1e-9)
    theta_back, phi_back = S.arc_from_tensions(tensions, P)
    assert np.allclose(theta_back, theta, atol=1e-12)
    assert np.allclose(np.exp(1j * phi_back), np.exp(1j * phi), atol=1e-9)


def test_tension_ik_clips_and_reports_it():
    tensions, clipped = S.tensions_from_arc(2.0, 0.0, P)  # beyond the 79° limit
    assert clipped and tensions.max() == P.max_tension
    _, clipped = S.tensions_from_arc(1.0, 0.0, P)
    assert not clipped


def test_bending_limit_matches_brute_force_over_the_tension_cube():
    grid = np.linspace(0, P.max_tension, 41)
    tensions = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), axis=-1).reshape(-1, 3)
    theta, phi = S.arc_from_tensions(tensions, P)
    limit = S.bending_limit(phi, P)
    assert np.all(theta <= limit + 1e-9)  # no tension combination exceeds the limit
    # the limit is attained at the hexagon's vertices (one or two cables at the maximum)
    for k in range(6):
        vertex = np.radians(60 * k)
        assert S.bending_limit(vertex, P) == pytest.approx(P.max_bending_angle)
        assert S.bending_limit(vertex + np.radians(30), P) == pytest.approx(
            P.max_bending_angle * np.cos(np.radians(30))
        )


def test_bad_input():
    with pytest.raises(ValueError, match="tensions"):
        S.arc_from_tensions([1.0, np.nan, 0.0], P)
    with pytest.raises(ValueError, match="pretension"):
        S.tensions_from_arc(0.5, 0.0, P, pretension=-1.0)
    with pytest.raises(ValueError, match="pretension"):
        S.bending_limit(0.0, P, pretension=80.0)
