"""envs.actuation: actions (N, C) in [−1, 1] → tension or cable-length commands."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym import defaults
from cdcr_gym.envs.actuation import ACTION_MODES, Actuation
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams

PAPER = RobotParams()
TDCR2 = RobotParams.preset("tdcr2")


def test_absolute_tensions_map_minus_one_to_zero_and_one_to_max():
    act = Actuation("tension", PAPER)
    t = act.tensions(np.array([[-1.0, 0.0, 1.0]]), np.zeros((1, 3)))
    assert t.tolist() == [[0.0, 40.0, 80.0]]


def test_tension_increments_are_bounded_and_clipped_to_the_box():
    act = Actuation("tension_delta", PAPER, tension_step=0.1)
    held = np.array([[0.0, 40.0, 79.0], [5.0, 5.0, 5.0]])
    t = act.tensions(np.array([[-1.0, 0.5, 1.0], [0.0, 1.0, -1.0]]), held)
    assert t.tolist() == [[0.0, 44.0, 80.0], [5.0, 13.0, 0.0]]


@pytest.mark.parametrize("params", [PAPER, TDCR2], ids=["paper", "tdcr2"])
def test_length_increments_give_the_lengths_of_a_reachable_shape(params):
    act = Actuation("length_delta", params, length_step=0.01)
    model = PCCModel(params)
    held = np.tile(model.straight_lengths, (50, 1))
    rng = np.random.default_rng(0)
    for _ in range(30):
        held = act.lengths(rng.uniform(-1, 1, held.shape), held)
    w = model.bending_from_lengths(held)
    # consistent: the lengths are those of the shape they encode, and within the tension limits
    assert np.allclose(model.lengths_from_bending(w), held, atol=1e-12)
    from cdcr_gym.model.statics import reachable_scale

    assert np.all(reachable_scale(model, w) >= 1.0 - 1e-9)


def test_defaults_come_from_one_place():
    act = Actuation(defaults.ACTION_MODE, PAPER)
    assert act.mode == "tension_delta" and defaults.ACTION_MODE in ACTION_MODES
    assert act.tension_step == defaults.TENSION_STEP and act.length_step == defaults.LENGTH_STEP
    assert act.commands_lengths is False


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"mode": "force"}, "action_mode"),
        ({"tension_step": 0.0}, "tension_step"),
        ({"tension_step": 1.5}, "tension_step"),
        ({"length_step": -1.0}, "length_step"),
        ({"length_step": 10.0}, "length_step"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    args = {"mode": "tension_delta", **kwargs}
    with pytest.raises(ValueError, match=name):
        Actuation(args.pop("mode"), PAPER, **args)
