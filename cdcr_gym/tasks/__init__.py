"""Tasks: what the agent must do on the env core (goals, observation fields, reward, success)."""

from cdcr_gym.tasks.base import Task
from cdcr_gym.tasks.reach import Reach

__all__ = ["Task", "Reach"]
