"""AnalyticBackend.apply_displacements: tendons driven by displacement on the CCKA backend."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.tendons import solve_displacement_statics, tendon_tensions
from tests.tolerances import close


@pytest.mark.parametrize("robot", ["paper", "tdcr2", "ftdcr_v4"])
def test_apply_displacements_matches_the_model_and_reports_the_sets(robot):
    p = RobotParams.preset(robot)
    backend = AnalyticBackend(p, num_robots=64)
    rng = np.random.default_rng(0)
    low, high = p.displacement_range
    d = rng.uniform(low, high, (64, p.n_cables)) * 0.5
    state = backend.apply_displacements(d)
    want = solve_displacement_statics(backend.model, d, p.cable_stiffness, p.cable_pretension)
    assert close(state.tensions, want.tensions, rtol=1e-9, atol=1e-9)
    assert np.array_equal(state.slack, want.slack)
    assert backend.tendon_state is state
    r = backend.read()
    assert close(r.tensions, state.tensions)
    assert close(r.tip, backend.model.tip_from_bending(state.bending))
    assert close(r.cable_lengths, backend.model.straight_lengths - state.shortening, atol=1e-15)
    # the tension-mode statics of the same tensions give the same robot
    backend.apply_tensions(state.tensions)
    assert close(backend.read().tip, r.tip) and backend.tendon_state is None


def test_warm_start_repeats_the_state():
    p = RobotParams.preset("tdcr2")
    backend = AnalyticBackend(p, num_robots=32)
    d = np.random.default_rng(1).uniform(-0.02, 0.02, (32, p.n_cables))
    first = backend.apply_displacements(d)
    again = backend.apply_displacements(d)
    assert close(again.tensions, first.tensions, rtol=1e-9, atol=1e-9)
    assert again.iterations <= 2


def test_randomised_robots_obey_the_law_at_their_own_shape():
    p = RobotParams()
    backend = AnalyticBackend(p, num_robots=4)
    backend.set_randomized(
        np.array([1, 3]), {"youngs_modulus": np.array([25e9, 45e9]), "cable_radius": [0.025, 0.033]}
    )
    d = np.tile([0.02, -0.01, 0.0], (4, 1))
    state = backend.apply_displacements(d, stiffness=5000.0, pretension=5.0)
    r = backend.read()
    shortening = backend.model.straight_lengths - r.cable_lengths
    law, slack, _ = tendon_tensions(d, shortening, 5000.0, 5.0, p.max_tension)
    assert np.allclose(law, state.tensions, atol=1e-9)
    assert np.array_equal(slack, state.slack)
    assert not close(r.tip[0], r.tip[1])  # the randomised robot bends differently
    # and its shape is its own tension statics under those tensions
    backend.apply_tensions(state.tensions)
    assert close(backend.read().tip, r.tip)


def test_bad_displacements_name_the_argument():
    backend = AnalyticBackend(RobotParams(), num_robots=2)
    with pytest.raises(ValueError, match="displacements"):
        backend.apply_displacements(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="displacements"):
        backend.apply_displacements(np.full((2, 3), np.nan))
    with pytest.raises(ValueError, match="stiffness"):
        backend.apply_displacements(np.zeros((2, 3)), stiffness=-1.0)
