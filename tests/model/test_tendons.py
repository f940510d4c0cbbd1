"""Tendons driven by displacement (cdcr_gym.model.tendons, SPEC §8)."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym import kinematics as K
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import arc_from_tensions
from cdcr_gym.model.tendons import (
    TendonState,
    shortening_matrix,
    solve_displacement_statics,
    tendon_tensions,
)
from tests.tolerances import close

PAPER = RobotParams()
MODEL = PCCModel(PAPER)
TDCR2 = PCCModel(RobotParams.preset("tdcr2"))


def _paper_commands(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacements d = ℓ − l(θ, φ) of arcs with θ ≤ 0.5 rad, and those θ, φ."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, 0.5, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    lengths = K.lengths_from_arc(theta, phi, PAPER.length, PAPER.cable_radius)
    return PAPER.length - lengths, theta, phi


# -- the law ---------------------------------------------------------------------------------------
def test_tendon_law_elementwise():
    d = np.array([0.001, -0.002, 0.0, 0.05])
    s = np.array([0.0, 0.0, 0.0, 0.0])
    t, slack, sat = tendon_tensions(d, s, 1000.0, [2.0, 2.0, 0.0, 2.0], max_tension=40.0)
    assert close(t, [3.0, 0.0, 0.0, 40.0])
    assert slack.tolist() == [False, True, True, False]  # raw −0 and 0: slack (exactly 0 N)
    assert sat.tolist() == [False, False, False, True]
    # inextensible: T0 where d = s, the limit where d > s, 0 where d < s
    t, slack, sat = tendon_tensions([0.0, 1e-9, -1e-9], [0.0, 0.0, 0.0], np.inf, 3.0, 10.0)
    assert t.tolist() == [3.0, 10.0, 0.0]
    assert slack.tolist() == [False, False, True] and sat.tolist() == [False, True, False]


# -- rigid, non-slack: the paper's eq. 2–5 -----------------------------------------------------------
@pytest.mark.parametrize("stiffness, atol", [(1e9, 1e-5), (np.inf, 1e-12)])
def test_rigid_displacement_mode_is_the_papers_eq_2_to_5(stiffness, atol):
    d, theta, phi = _paper_commands(200)
    state = solve_displacement_statics(MODEL, d, stiffness, 40.0)
    assert isinstance(state, TendonState)
    assert not state.slack.any() and not state.saturated.any()
    lengths = PAPER.length - d  # lengths in
    th_paper, ph_paper, _ = K.arc_from_lengths(lengths, PAPER.cable_radius)  # eq. 2–4
    th, ph = MODEL.arcs_from_bending(state.bending)
    assert np.allclose(th[:, 0], th_paper, atol=atol, rtol=0)
    assert np.allclose(th[:, 0], theta, atol=atol, rtol=0)
    dphi = np.angle(np.exp(1j * (ph[:, 0] - ph_paper)))
    assert np.all(np.abs(dphi * th_paper) <= atol * 10)
    tip_paper = K.forward_kinematics(lengths, PAPER.cable_radius)  # eq. 5 (corrected)
    assert np.allclose(MODEL.tip_from_bending(state.bending), tip_paper, atol=atol, rtol=0)
    # the tendons' shortenings equal the commands (rigid)
    assert np.allclose(state.shortening, d, atol=atol * PAPER.cable_radius, rtol=0)


def test_inextensible_limit_is_the_least_squares_shape_and_limit_of_stiff():
    d, _, _ = _paper_commands(20, seed=1)
    pulled = d + 0.004  # a common-mode pull cannot change an inextensible robot's shape
    exact = solve_displacement_statics(MODEL, pulled, np.inf, 40.0, max_tension=np.inf)
    want = MODEL.bending_from_lengths(MODEL.straight_lengths - pulled)
    assert close(exact.bending, want)
    # the tensions are the k → ∞ limit: nearest the pretension among those holding the shape
    stiff = solve_displacement_statics(MODEL, d, 1e10, 40.0)
    limit = solve_displacement_statics(MODEL, d, np.inf, 40.0)
    assert np.allclose(stiff.tensions, limit.tensions, atol=1e-4, rtol=0)
    assert np.allclose(limit.tensions.mean(axis=-1), 40.0, atol=1e-9)  # common mode kept at T0


@pytest.mark.parametrize("model", [MODEL, TDCR2])
def test_inextensible_tensions_are_the_limit_of_stiff_tendons_with_slack(model):
    """k = inf with slack tendons: the shape is unique, the tensions are the k → ∞ limit."""
    rng = np.random.default_rng(6)
    d = rng.uniform(-0.01, 0.01, (200, model.n_cables))
    limit = solve_displacement_statics(model, d, np.inf, 1.0, max_tension=np.inf)
    assert limit.slack.any()
    consistent = limit.shortening  # commands a shape can have: finite k converges
    errors = []
    for k in (1e8, 1e10):
        stiff = solve_displacement_statics(model, consistent, k, 1.0, max_tension=np.inf)
        errors.append(np.max(np.abs(stiff.tensions - limit.tensions)))
    assert errors[1] < 1e-4 and errors[1] < errors[0] / 50  # ∝ 1/k


# -- slack ---------------------------------------------------------------------------------------
def test_slack_tendon_carries_zero_and_acts_as_if_absent():
    k, t0 = 2000.0, 5.0
    d = np.array([-0.05, 0.001, 0.0])
    state = solve_displacement_statics(MODEL, d, k, t0)
    assert state.slack.tolist() == [True, False, False]
    assert state.tensions[0] == 0.0  # exactly
    assert np.all(state.tensions[1:] > 0.0)
    # the shape is the tension-mode statics with that tendon at 0 N
    theta, phi = arc_from_tensions(state.tensions, PAPER)
    th, ph = MODEL.arcs_from_bending(state.bending)
    assert close(th[0], theta) and close(ph[0], phi)
    # ... and the two-tendon problem with tendon 1 removed: (M_FF + I/k) T_F = d_F + T0/k
    m = shortening_matrix(MODEL)[1:, 1:]
    t_two = np.linalg.solve(m + np.eye(2) / k, d[1:] + t0 / k)
    assert close(state.tensions[1:], t_two)
    # releasing it further changes nothing
    further = solve_displacement_statics(MODEL, d - [0.05, 0.0, 0.0], k, t0)
    assert close(further.tensions, state.tensions) and close(further.bending, state.bending)
    # the law holds at the shape: raw value of tendon 1 is <= 0
    assert t0 + k * (d[0] - state.shortening[0]) <= 0.0


# -- saturation ------------------------------------------------------------------------------------
def test_saturation_at_max_tension_is_reported():
    d = np.array([0.05, 0.0, 0.0])  # 5 cm at 5 kN/m asks for ~250 N
    state = solve_displacement_statics(MODEL, d, 5000.0, 10.0)
    assert state.saturated.tolist() == [True, False, False]
    assert state.tensions[0] == PAPER.max_tension
    assert close(state.bending, MODEL.bending_from_tensions(state.tensions))
    # the robot's limit is the default; a higher explicit limit lifts it
    higher = solve_displacement_statics(MODEL, d, 5000.0, 10.0, max_tension=1000.0)
    assert not higher.saturated.any() and higher.tensions[0] > PAPER.max_tension


# -- the law holds at the solution, batched equals row by row -----------------------------------------
@pytest.mark.parametrize(
    "model, scale, k, t0",
    [(MODEL, 0.02, 5000.0, 10.0), (MODEL, 0.02, 1e9, 10.0), (TDCR2, 0.01, 1e5, 1.0)],
)
def test_solution_satisfies_the_law_with_slack_and_saturation(model, scale, k, t0):
    rng = np.random.default_rng(3)
    d = rng.uniform(-scale, scale, (500, model.n_cables))
    state = solve_displacement_statics(model, d, k, t0)
    assert state.slack.any() and state.saturated.any()  # the test covers both sets
    law, slack, sat = tendon_tensions(d, state.shortening, k, t0, model.params.max_tension)
    size = 1.0 + np.abs(t0 + k * d)
    assert np.all(np.abs(law - state.tensions) <= 1e-12 * size * model.n_cables)
    assert np.array_equal(slack, state.slack) and np.array_equal(sat, state.saturated)
    lengths = model.lengths_from_bending(state.bending)
    assert close(state.shortening, model.straight_lengths - lengths, atol=1e-15)
    assert close(state.bending, model.bending_from_tensions(state.tensions))


@pytest.mark.parametrize("model, k", [(MODEL, 3000.0), (TDCR2, 2e4), (TDCR2, np.inf)])
def test_batched_equals_row_by_row(model, k):
    rng = np.random.default_rng(4)
    d = rng.uniform(-0.01, 0.01, (4, 5, model.n_cables))
    t0 = rng.uniform(0.5, 3.0, model.n_cables)
    batch = solve_displacement_statics(model, d, k, t0)
    assert batch.tensions.shape == (4, 5, model.n_cables)
    assert batch.bending.shape == (4, 5, model.n_sections, 2)
    for i in range(4):
        for j in range(5):
            row = solve_displacement_statics(model, d[i, j], k, t0)
            assert row.tensions.shape == (model.n_cables,)
            assert close(row.tensions, batch.tensions[i, j], rtol=1e-9, atol=1e-9)
            assert close(row.bending, batch.bending[i, j], rtol=1e-9, atol=1e-12)
            assert np.array_equal(row.slack, batch.slack[i, j])
            assert np.array_equal(row.saturated, batch.saturated[i, j])


def test_per_cable_parameters_and_warm_start():
    rng = np.random.default_rng(5)
    d = rng.uniform(-0.01, 0.01, (50, 6))
    k = np.linspace(1e4, 5e4, 6)
    cold = solve_displacement_statics(TDCR2, d, k, np.full(6, 1.5))
    warm = solve_displacement_statics(TDCR2, d, k, 1.5, initial_tensions=cold.tensions)
    assert close(warm.tensions, cold.tensions, rtol=1e-9, atol=1e-9)
    assert warm.iterations <= 2
    # (..., C) stiffness: one robot with a different drive gives that robot's answer
    k_rows = np.broadcast_to(k, (50, 6)).copy()
    k_rows[7] = 1e3
    mixed = solve_displacement_statics(TDCR2, d, k_rows, 1.5)
    alone = solve_displacement_statics(TDCR2, d[7], 1e3, 1.5)
    assert close(mixed.tensions[7], alone.tensions, rtol=1e-9, atol=1e-9)
    assert close(mixed.tensions[:7], cold.tensions[:7], rtol=1e-9, atol=1e-9)


# -- bad input -------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"stiffness": -1.0}, "stiffness"),
        ({"stiffness": 0.0}, "stiffness"),
        ({"stiffness": np.nan}, "stiffness"),
        ({"stiffness": [1e3, 1e3]}, "stiffness"),
        ({"stiffness": [1e3, np.inf, 1e3]}, "stiffness"),
        ({"pretension": -1.0}, "pretension"),
        ({"pretension": np.inf}, "pretension"),
        ({"displacements": [0.0, np.nan, 0.0]}, "displacements"),
        ({"displacements": [0.0, 0.0]}, "displacements"),
        ({"displacements": 0.0}, "displacements"),
        ({"max_tension": -5.0}, "max_tension"),
        ({"initial_tensions": [1.0, 2.0]}, "initial_tensions"),
        ({"max_iter": 0}, "max_iter"),
    ],
)
def test_bad_input_names_the_argument(kwargs, name):
    args = {"displacements": [0.0, 0.001, 0.0], "stiffness": 1e3, "pretension": 1.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        solve_displacement_statics(MODEL, **args)


@pytest.mark.parametrize(
    "args, name",
    [
        (([0.0, 0.0], [0.0, 0.0], -1.0, 1.0), "stiffness"),
        (([0.0, np.nan], [0.0, 0.0], 1.0, 1.0), "displacements"),
        (([0.0, 0.0], [0.0, 0.0, 0.0], 1.0, 1.0), "shortening"),
        (([0.0, 0.0], [0.0, 0.0], 1.0, -1.0), "pretension"),
    ],
)
def test_tendon_tensions_bad_input(args, name):
    with pytest.raises(ValueError, match=name):
        tendon_tensions(*args)


def test_model_must_be_a_pccmodel():
    with pytest.raises(ValueError, match="model"):
        solve_displacement_statics(PAPER, [0.0, 0.0, 0.0], 1e3, 1.0)
