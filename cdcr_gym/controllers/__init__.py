"""Oracles as policy objects: the baselines every learned result is judged against."""

from cdcr_gym.controllers.ik import AnalyticIKController
from cdcr_gym.controllers.planner import ObstaclePlanner
from cdcr_gym.controllers.tracking import PoseIKController, TrackingIKController

__all__ = ["AnalyticIKController", "TrackingIKController", "PoseIKController", "ObstaclePlanner"]
