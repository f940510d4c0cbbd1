"""Oracles as policy objects: the baselines every learned result is judged against."""

from cdcr_gym.controllers.ik import AnalyticIKController

__all__ = ["AnalyticIKController"]
