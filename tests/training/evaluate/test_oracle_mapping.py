"""Each task's oracle comes from one table, ``cdcr_gym.controllers.ORACLES``, which training
uses (no task table of its own)."""

from __future__ import annotations

import gymnasium as gym
import pytest

import cdcr_gym  # noqa: F401
from cdcr_gym import controllers
from cdcr_gym.tasks.reach import Reach
from training.evaluate import oracles
from training.run.metrics import oracle_for

EXPECTED = {
    "Reach": controllers.AnalyticIKController,
    "Track": controllers.TrackingIKController,
    "Pose": controllers.PoseIKController,
    "Obstacle": controllers.ObstaclePlanner,
}


@pytest.mark.parametrize("task", sorted(EXPECTED))
def test_every_ccka_task_gets_its_oracle_from_the_controllers_table(task):
    env = gym.make(f"cdcr_gym/CCKA{task}-v0")
    try:
        assert controllers.oracle_for(env.unwrapped.task) is EXPECTED[task]
        assert type(oracle_for(env)) is EXPECTED[task]
        assert type(oracle_for(env, "reach_ik")) is controllers.AnalyticIKController
    finally:
        env.close()


def test_a_subclass_inherits_its_tasks_oracle_and_an_unknown_task_is_named():
    class MyReach(Reach):
        pass

    assert controllers.oracle_for(MyReach) is controllers.AnalyticIKController
    with pytest.raises(ValueError, match="'int' has no oracle"):
        controllers.oracle_for(3)


def test_the_oracles_command_offers_exactly_the_tasks_with_an_oracle():
    assert set(oracles.TASKS.values()) == {t.__name__ for t in controllers.ORACLES}


def test_an_unknown_kind_is_named():
    env = gym.make("cdcr_gym/CCKAReach-v0")
    with pytest.raises(ValueError, match="'open'"):
        oracle_for(env, "open")
    env.close()
