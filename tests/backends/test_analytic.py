"""backends.analytic: N quasi-static PCC robots, batched; masks, equilibria, randomised robots."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams

PAPER = RobotParams()


def test_readings_are_the_models_statics_and_kinematics():
    robots = AnalyticBackend(PAPER, num_robots=4)
    t = np.random.default_rng(0).uniform(0, 80, (4, 3))
    robots.apply_tensions(t)
    r = robots.read()
    model = PCCModel(PAPER)
    w = model.bending_from_tensions(t)
    np.testing.assert_allclose(r.tip, model.tip_from_bending(w), rtol=0, atol=1e-15)
    np.testing.assert_allclose(r.tip_direction, model.tip_direction_from_bending(w), atol=1e-15)
    np.testing.assert_allclose(r.cable_lengths, model.lengths_from_bending(w), atol=1e-15)
    assert np.array_equal(r.tensions, t) and r.anchor_tensions is None


def test_one_robot_and_a_batch_give_the_same_numbers():
    """To the last bits: the statics' matrix product of one robot and of a batch may sum in
    another order (BLAS picks the kernel by shape); the kinematics are the same arithmetic."""
    t = np.random.default_rng(1).uniform(0, 80, (5, 3))
    batch = AnalyticBackend(PAPER, num_robots=5)
    batch.apply_tensions(t)
    for i in range(5):
        one = AnalyticBackend(PAPER)
        one.apply_tensions(t[i : i + 1])
        for a, b in zip(one.read()[:4], batch.read()[:4]):
            np.testing.assert_allclose(a[0], b[i], rtol=0, atol=1e-15)


def test_a_masked_reset_leaves_the_other_robots_alone():
    robots = AnalyticBackend(PAPER, num_robots=3)
    robots.apply_tensions(np.full((3, 3), 20.0))
    before = robots.read().tip.copy()
    robots.reset(np.zeros((3, 3)), np.array([False, True, False]))
    after = robots.read().tip
    assert np.array_equal(after[[0, 2]], before[[0, 2]])
    np.testing.assert_allclose(after[1], [0.0, 0.0, PAPER.length], atol=1e-15)


def test_equilibrium_does_not_change_the_state():
    robots = AnalyticBackend(PAPER, num_robots=2)
    robots.apply_tensions(np.full((2, 3), [10.0, 0.0, 5.0]))
    before = robots.read().tip.copy()
    eq = robots.equilibrium(np.random.default_rng(2).uniform(0, 80, (7, 3)))
    assert eq.tip.shape == (7, 3)
    assert np.array_equal(robots.read().tip, before)


def test_randomised_robots_bend_by_r_over_e():
    robots = AnalyticBackend(PAPER, num_robots=2)
    robots.set_randomized(
        np.array([1]), {"youngs_modulus": np.array([70e9]), "cable_radius": np.array([0.029])}
    )
    robots.apply_tensions(np.full((2, 3), [40.0, 0.0, 0.0]))
    w = robots.bending
    np.testing.assert_allclose(w[1], 0.5 * w[0], rtol=1e-14)


def test_length_commands_report_the_minimal_holding_tensions():
    robots = AnalyticBackend(PAPER)
    model = PCCModel(PAPER)
    w = model.bending_from_tensions(np.array([[30.0, 10.0, 0.0]]))
    robots.apply_cable_lengths(model.lengths_from_bending(w))
    # minimal: already one slack cable, so the same tensions
    np.testing.assert_allclose(robots.read().tensions, [[30.0, 10.0, 0.0]], atol=1e-9)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: AnalyticBackend(num_robots=0), "num_robots"),
        (lambda: AnalyticBackend(params="paper"), "params"),
        (lambda: AnalyticBackend().reset(np.full((1, 3), -1.0)), "tensions"),
        (lambda: AnalyticBackend().equilibrium(np.full((2, 3), 81.0)), "tensions"),
    ],
)
def test_bad_input_names_itself(call, name):
    with pytest.raises(ValueError, match=name):
        call()
