"""The CCKA backend: the constant-curvature model plus the pure-moment statics, no simulator.

Quasi-static: every command moves the robot straight to the equilibrium shape (no dynamics, no
gravity). Tension commands bend it by ``statics.arc_from_tensions``; cable-length commands set
the arc by ``kinematics.arc_from_lengths`` and report the minimal tensions that hold it
(``statics.tensions_from_arc``).
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import kinematics, statics
from cdcr_gym.backends.base import Backend
from cdcr_gym.params import RobotParams

__all__ = ["AnalyticBackend"]


class AnalyticBackend(Backend):
    """Constant-curvature robot driven by cable tensions or cable lengths.

    Args:
        params: the robot (default: the paper's Table 1 with E = 35 GPa).
    """

    control_timestep = 0.0
    supports_length_control = True

    def __init__(self, params: RobotParams | None = None) -> None:
        if params is None:
            params = RobotParams()
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self._set_from_tensions(np.zeros(3))

    # -- state updates --------------------------------------------------------------------------
    def _set_arc(self, theta: float, phi: float) -> None:
        p = self.params
        self.theta = float(theta)
        self.phi = float(phi)
        self._lengths = kinematics.lengths_from_arc(theta, phi, p.length, p.cable_radius)
        self._tip = kinematics.tip_from_arc(theta, phi, p.length)

    def _set_from_tensions(self, tensions: np.ndarray) -> None:
        self._tensions = np.array(tensions, dtype=np.float64)
        theta, phi = statics.arc_from_tensions(self._tensions, self.params)
        self._set_arc(theta, phi)

    def reset(self, tensions: np.ndarray) -> None:
        self._set_from_tensions(tensions)

    def apply_tensions(self, tensions: np.ndarray) -> None:
        self._set_from_tensions(tensions)

    def apply_cable_lengths(self, lengths: np.ndarray) -> None:
        theta, phi, _ = kinematics.arc_from_lengths(lengths, self.params.cable_radius)
        self._set_arc(theta, phi)
        self._tensions = statics.tensions_from_arc(theta, phi, self.params)[0]

    # -- readings -------------------------------------------------------------------------------
    @property
    def tip(self) -> np.ndarray:
        return self._tip.copy()

    @property
    def cable_lengths(self) -> np.ndarray:
        return self._lengths.copy()

    @property
    def tensions(self) -> np.ndarray:
        return self._tensions.copy()

    def backbone_points(self) -> np.ndarray:
        """(4·n_disks + 1, 3) points, m: every disk station and three points between each pair."""
        return kinematics.backbone_points(
            self.theta, self.phi, self.params.length, n=4 * self.params.n_disks + 1
        )
