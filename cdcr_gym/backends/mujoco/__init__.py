"""The MuJoCo backend: the backbone as an MJCF chain of rigid links and elastic joints with one
spatial tendon per cable.

``mjcf`` (the model from ``RobotParams``) and ``backend`` (:class:`MuJoCoBackend`, N robots).
Importing this package imports ``mujoco`` only when a backend is built.
"""

from cdcr_gym.backends.base import SimulationDivergedError
from cdcr_gym.backends.mujoco.backend import MuJoCoBackend
from cdcr_gym.backends.mujoco.mjcf import JOINTS, build_mjcf
from cdcr_gym.model.discrete import ROUTINGS

__all__ = ["MuJoCoBackend", "SimulationDivergedError", "build_mjcf", "JOINTS", "ROUTINGS"]
