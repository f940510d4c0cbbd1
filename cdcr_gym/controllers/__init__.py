"""Oracles as policy objects: the baselines every learned result is judged against.

:data:`ORACLES` maps each task class to its oracle's controller class; :func:`oracle_for` looks
a task (class or instance, subclasses included) up in it. Every controller has
``from_env(env, feedback=..., **options)``.
"""

from __future__ import annotations

from typing import Any

from cdcr_gym.controllers.ik import AnalyticIKController
from cdcr_gym.controllers.planner import ObstaclePlanner
from cdcr_gym.controllers.tracking import PoseIKController, TrackingIKController
from cdcr_gym.tasks.obstacle import Obstacle
from cdcr_gym.tasks.pose import Pose
from cdcr_gym.tasks.reach import Reach
from cdcr_gym.tasks.track import Track

__all__ = [
    "AnalyticIKController",
    "TrackingIKController",
    "PoseIKController",
    "ObstaclePlanner",
    "ORACLES",
    "oracle_for",
]

#: task class -> the controller class of its oracle
ORACLES: dict[type, type] = {
    Reach: AnalyticIKController,
    Track: TrackingIKController,
    Pose: PoseIKController,
    Obstacle: ObstaclePlanner,
}


def oracle_for(task: Any) -> type:
    """The oracle's controller class for ``task`` (a task class or instance; a subclass of a
    task in :data:`ORACLES` gets its base's oracle). Raises ValueError naming the task if it
    has none."""
    cls = task if isinstance(task, type) else type(task)
    for base in cls.__mro__:
        if base in ORACLES:
            return ORACLES[base]
    raise ValueError(
        f"task {cls.__name__!r} has no oracle; known tasks: {[t.__name__ for t in ORACLES]}"
    )
