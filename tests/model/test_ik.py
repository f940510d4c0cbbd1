"""model.ik: tension-limited IK (one section: closed form + projection; several: numerical)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tolerances import close

from cdcr_gym.model import arc, ik
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import bending_limit
from cdcr_gym.model.workspace import sample_arcs, sample_tensions

pytestmark = pytest.mark.filterwarnings("error")

PAPER = RobotParams()
TDCR2 = RobotParams.preset("tdcr2")
#: The legacy one-section model's outputs on fixed inputs (tests/data/write_legacy_arrays.py).
OLD = np.load(Path(__file__).parents[1] / "data" / "legacy_statics.npz")


def test_paper_goals_on_the_reachable_surface_equal_todays_ik():
    theta, phi = sample_arcs(np.random.default_rng(0), 500, PAPER)
    goals = OLD["ik_goals"]  # the legacy tip_from_arc(theta, phi)
    assert np.max(np.abs(arc.tip_from_arc(theta, phi, PAPER.length) - goals)) <= 1e-15
    sol = ik.solve_ik(goals, PAPER)
    t_old = OLD["ik_tensions"]  # the legacy tension IK of the legacy arc_from_tip(goals)
    assert np.max(np.abs(sol.tensions - t_old)) <= 1e-9
    assert np.max(sol.residual) <= 1e-12
    assert np.max(np.linalg.norm(sol.tip - goals, axis=-1)) <= 1e-12


def _brute_nearest_reachable(goal, n_theta=600, n_phi=1440):
    """Distance from goal to a dense mesh of the tension-reachable tips (paper robot)."""
    phi = np.linspace(-np.pi, np.pi, n_phi, endpoint=False)
    frac = np.linspace(0.0, 1.0, n_theta)
    theta = frac[:, None] * bending_limit(phi, PAPER)[None, :]
    tips = arc.tip_from_arc(theta, np.broadcast_to(phi, theta.shape), PAPER.length)
    return np.min(np.linalg.norm(tips - goal, axis=-1))


def test_paper_goals_off_the_region_project_within_the_tension_limit():
    goals = np.array(
        [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
            [10.0, 10.0, 10.0],
            [0.5, 0.0, 0.1],
            [-0.3, 0.2, 0.05],
            [0.0, 0.6, 0.3],
            [0.1, 0.1, 0.9],
        ]
    )
    sol = ik.solve_ik(goals, PAPER)
    assert np.all(sol.tensions >= 0.0) and np.all(sol.tensions <= PAPER.max_tension)
    model = PCCModel(PAPER)
    theta, phi = model.arcs_from_bending(sol.bending)
    assert np.all(theta[:, 0] <= bending_limit(phi[:, 0], PAPER) * (1 + 1e-12))
    assert np.allclose(sol.residual, np.linalg.norm(sol.tip - goals, axis=-1), atol=1e-15)
    # today's projection overshoots the limit for the first three (the examples)
    assert close(goals[:3], OLD["far_goals"])
    assert np.all(OLD["far_theta"] > OLD["far_limit"])
    step = PAPER.length * np.max(bending_limit(np.linspace(0, 7, 50), PAPER)) / 600
    for goal, res in zip(goals, sol.residual):
        brute = _brute_nearest_reachable(goal)
        assert res <= brute + 1e-12  # never worse than the dense mesh
        assert res >= brute - step  # and no better than the mesh resolution allows


def test_tdcr2_sampled_goals_are_reached_within_the_tension_box():
    model = PCCModel(TDCR2)
    box = sample_tensions(np.random.default_rng(11), TDCR2, 120)
    goals = model.tip_from_bending(model.bending_from_tensions(box))
    sol = ik.solve_ik(goals, TDCR2)
    assert np.max(sol.residual) < 1e-6
    assert np.all(sol.tensions >= 0.0) and np.all(sol.tensions <= TDCR2.max_tension)
    reached = model.tip_from_bending(model.bending_from_tensions(sol.tensions))
    assert np.max(np.linalg.norm(reached - goals, axis=-1)) < 1e-6
    # deterministic, and a batch gives the per-goal answers
    again = ik.solve_ik(goals[:5].reshape(5, 1, 3), TDCR2)
    assert np.allclose(again.tensions[:, 0], sol.tensions[:5], atol=1e-9)


def test_tdcr2_unreachable_goals_are_reported_by_the_residual():
    # beyond the straight tip, and on the axis below it (an S-bend cannot bring the tip back
    # to the axis that low within 6 N): residual > 0, and no worse than the best of 200 000
    # random tension samples
    goals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.3]])
    sol = ik.solve_ik(goals, TDCR2)
    assert sol.residual[0] == pytest.approx(0.6, abs=1e-6)  # the straight robot is 0.4 m long
    model = PCCModel(TDCR2)
    box = np.random.default_rng(0).uniform(0, TDCR2.max_tension, (200_000, 6))
    tips = model.tip_from_bending(model.bending_from_tensions(box))
    brute = np.min(np.linalg.norm(tips - goals[1], axis=-1))
    assert 0.05 < sol.residual[1] <= brute + 1e-9
    assert np.all(sol.tensions >= 0.0) and np.all(sol.tensions <= TDCR2.max_tension)


def test_tdcr2_pose_ik_reaches_sampled_poses():
    model = PCCModel(TDCR2)
    box = sample_tensions(np.random.default_rng(12), TDCR2, 60)
    tip, direction = model.tip_and_direction_from_bending(model.bending_from_tensions(box))
    sol = ik.solve_pose_ik(tip, direction, TDCR2)
    assert np.max(sol.residual) < 1e-6 and np.max(sol.angle_residual) < 1e-6
    assert np.all(sol.tensions >= 0.0) and np.all(sol.tensions <= TDCR2.max_tension)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: ik.solve_ik([0.0, np.nan, 0.3], PAPER), "goal"),
        (lambda: ik.solve_ik([0.0, 0.3], PAPER), "goal"),
        (lambda: ik.solve_ik([0.0, 0.0, 0.3], "paper"), "params"),
        (lambda: ik.solve_pose_ik([0.0, 0.0, 0.3], [0.0, 0.0, 0.0], TDCR2), "direction"),
        (lambda: ik.solve_pose_ik([0.0, np.inf, 0.3], [0.0, 0.0, 1.0], TDCR2), "position"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, name):
    with pytest.raises(ValueError, match=name):
        call()
