"""The CCKA backend: the constant-curvature model plus the pure-moment statics, no simulator.

Quasi-static: every command moves the robot straight to the equilibrium shape (no dynamics, no
gravity). Tension commands bend it by ``statics.arc_from_tensions``; cable-length commands set
the arc by ``kinematics.arc_from_lengths`` and report the minimal tensions that hold it
(``statics.tensions_from_arc``).

The model's update is written once, in :func:`shape_from_tensions` and
:func:`shape_from_lengths`, on *components* (Python floats or numpy arrays of any shape; see the
kernels in ``cdcr_gym.kinematics``): :class:`AnalyticBackend` calls them with floats for one robot,
the batched env (``cdcr_gym.envs.vector``) with arrays for all robots at once.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from cdcr_gym import kinematics
from cdcr_gym.backends.base import Backend
from cdcr_gym.kinematics import (
    _bending_angle,
    _bending_from_lengths,
    _lengths_from_bending,
    _minimum,
    _tip_from_bending,
)
from cdcr_gym.params import RobotParams
from cdcr_gym.statics import _bending_from_tensions, _tensions_from_bending
from cdcr_gym.validation import three_finite_floats

__all__ = ["AnalyticBackend", "ModelConstants", "shape_from_tensions", "shape_from_lengths"]


class ModelConstants(NamedTuple):
    """The robot constants the model's update needs, precomputed once (SI units, floats)."""

    length: float  #: backbone length ℓ (m)
    cable_radius: float  #: r (m)
    compliance: float  #: r ℓ / EI (rad of bending per N of tension)
    stiffness: float  #: EI / (r ℓ) (N per rad)
    max_tension: float  #: T_max (N)

    @classmethod
    def from_params(cls, params: RobotParams) -> ModelConstants:
        r, ell, ei = params.cable_radius, params.length, params.bending_stiffness
        return cls(float(ell), float(r), r * ell / ei, ei / (r * ell), float(params.max_tension))


class Shape(NamedTuple):
    """The robot's equilibrium shape; each entry a float or an array (all envs at once)."""

    theta: object  #: bending angle θ (rad)
    bending: tuple  #: bending vector w = θ·(cos φ, sin φ) (rad), (wx, wy)
    tip: tuple  #: tip (x, y, z) in R0 (m)
    lengths: tuple  #: cable lengths (l1, l2, l3) (m)
    tensions: tuple  #: cable tensions (T1, T2, T3) (N)


def _shape_from_bending(wx, wy, tensions: tuple, c: ModelConstants) -> Shape:
    theta = _bending_angle(wx, wy)
    return Shape(
        theta,
        (wx, wy),
        _tip_from_bending(theta, wx, wy, c.length),
        _lengths_from_bending(wx, wy, c.length, c.cable_radius),
        tensions,
    )


def shape_from_tensions(tensions: tuple, c: ModelConstants) -> Shape:
    """Equilibrium under cable tensions (T1, T2, T3) (N): ``statics.arc_from_tensions``, then
    the arc's tip and cable lengths (``kinematics.tip_from_arc``, ``lengths_from_arc``)."""
    wx, wy = _bending_from_tensions(*tensions, c.compliance)
    return _shape_from_bending(wx, wy, tensions, c)


def shape_from_lengths(lengths: tuple, c: ModelConstants) -> Shape:
    """The arc set by cable lengths (l1, l2, l3) (m) (``kinematics.arc_from_lengths``), held by
    its minimal tensions clipped to T_max (``statics.tensions_from_arc``, no pretension). The
    lengths reported are the arc's (``lengths_from_arc`` with the backbone length ℓ)."""
    wx, wy = _bending_from_lengths(*lengths, c.cable_radius)
    t1, t2, t3 = _tensions_from_bending(wx, wy, c.stiffness)
    t_max = c.max_tension
    tensions = (_minimum(t1, t_max), _minimum(t2, t_max), _minimum(t3, t_max))
    return _shape_from_bending(wx, wy, tensions, c)


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
        self.constants = ModelConstants.from_params(params)
        self._shape = shape_from_tensions((0.0, 0.0, 0.0), self.constants)

    # -- state updates --------------------------------------------------------------------------
    @property
    def theta(self) -> float:
        """Bending angle θ (rad) of the current shape."""
        return self._shape.theta

    @property
    def phi(self) -> float:
        """Bending-plane angle φ (rad) of the current shape (0 when straight)."""
        wx, wy = self._shape.bending
        return math.atan2(wy, wx) + 0.0 if self._shape.theta != 0.0 else 0.0

    def reset(self, tensions: np.ndarray) -> None:
        self._shape = shape_from_tensions(three_finite_floats(tensions, "tensions"), self.constants)

    def apply_tensions(self, tensions: np.ndarray) -> None:
        self._shape = shape_from_tensions(three_finite_floats(tensions, "tensions"), self.constants)

    def apply_cable_lengths(self, lengths: np.ndarray) -> None:
        self._shape = shape_from_lengths(three_finite_floats(lengths, "lengths"), self.constants)

    # -- readings -------------------------------------------------------------------------------
    @property
    def tip(self) -> np.ndarray:
        return np.array(self._shape.tip)

    @property
    def cable_lengths(self) -> np.ndarray:
        return np.array(self._shape.lengths)

    @property
    def tensions(self) -> np.ndarray:
        return np.array(self._shape.tensions)

    def backbone_points(self) -> np.ndarray:
        """(4·n_disks + 1, 3) points, m: every disk station and three points between each pair."""
        return kinematics.backbone_points(
            self.theta, self.phi, self.params.length, n=4 * self.params.n_disks + 1
        )

