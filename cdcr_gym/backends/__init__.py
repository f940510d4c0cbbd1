"""Robot models behind the reach task. ``BulletBackend`` lives in ``cdcr_gym.backends.bullet``
(imported on demand, so that pybullet is only loaded when used)."""

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.base import Backend

__all__ = ["Backend", "AnalyticBackend"]
