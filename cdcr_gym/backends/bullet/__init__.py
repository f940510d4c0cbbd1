"""The pybullet backend: the backbone as a pybullet multibody of rigid links and elastic joints.

``chain`` (the discretised model in numpy), ``multibody`` (its pybullet body), ``integrator``
(the physics step), ``client`` (connection handling) and ``backend`` (:class:`BulletBackend`).
Importing this package imports pybullet only when a backend is built.
"""

from cdcr_gym.backends.bullet.backend import BulletBackend
from cdcr_gym.backends.bullet.chain import (
    ChainPose,
    DiscreteBackbone,
    check_span_buckling,
    span_buckling_loads,
)
from cdcr_gym.backends.bullet.integrator import SimulationDivergedError
from cdcr_gym.backends.bullet.multibody import MAX_JOINTS

__all__ = [
    "BulletBackend",
    "SimulationDivergedError",
    "MAX_JOINTS",
    "DiscreteBackbone",
    "ChainPose",
    "check_span_buckling",
    "span_buckling_loads",
]
