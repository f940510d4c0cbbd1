"""Robot models behind the env core. ``BulletBackend`` lives in ``cdcr_gym.backends.bullet``
(imported on demand, so that pybullet is only loaded when used)."""

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.base import Backend, Readings

__all__ = ["Backend", "Readings", "AnalyticBackend"]
