"""The pybullet backend: the backbone as a pybullet multibody of rigid links and elastic joints.

The discretised model it simulates is ``cdcr_gym.model.discrete`` (pure numpy, shared with the
MuJoCo backend); here: ``multibody`` (its pybullet body), ``integrator``
(the physics step), ``client`` (connection handling) and ``backend`` (:class:`BulletBackend`).
Importing this package imports pybullet only when a backend is built.
"""

from cdcr_gym.backends.base import SimulationDivergedError
from cdcr_gym.backends.bullet.backend import BulletBackend
from cdcr_gym.backends.bullet.multibody import MAX_JOINTS

__all__ = ["BulletBackend", "SimulationDivergedError", "MAX_JOINTS"]
