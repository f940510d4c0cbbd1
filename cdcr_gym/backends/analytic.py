"""The CCKA/PCC backend: the piecewise-constant-curvature model and its pure-moment statics.

Quasi-static and batched: every command moves all N robots straight to their equilibrium shapes
(no dynamics, no gravity). Tension commands bend the sections by the coupled pure-moment statics
(``PCCModel.bending_from_tensions``: a cable loads its own section and every proximal one);
cable-length commands set the shape by ``PCCModel.bending_from_lengths`` and report the minimal
tensions that hold it (``model.statics.minimal_tensions``, clipped to max_tension). The single
env runs it with N = 1, the batched env with N = num_envs.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import Backend, Readings
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import minimal_tensions

__all__ = ["AnalyticBackend"]


class AnalyticBackend(Backend):
    """N constant-curvature robots driven by cable tensions or cable lengths.

    Args:
        params: the robot (default: the paper's, ``RobotParams()``).
        num_robots: number of robots N stepped together (>= 1).
    """

    control_timestep = 0.0
    supports_length_control = True

    def __init__(self, params: RobotParams | None = None, num_robots: int = 1) -> None:
        if params is None:
            params = RobotParams()
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self.num_robots = validation.integer(num_robots, "num_robots", 1)
        self.model = PCCModel(params)
        self._set(np.zeros((self.num_robots, params.n_cables)))

    def _shape(self, tensions: np.ndarray, comp: np.ndarray) -> Readings:
        """Readings of the bending component rows ``comp`` (2S, N) held by ``tensions`` (N, C).

        The model works field-major (one row per component); the computed readings are the
        transposed views, (N, ·) Fortran-ordered arrays, so the tasks' field-major observation
        buffers fill from contiguous rows (``tensions`` are kept as given).
        """
        tip, direction, lengths = self.model.forward_rows(comp)
        return Readings(tip.T, direction.T, lengths.T, tensions)

    def _set(self, tensions: np.ndarray) -> None:
        self._comp = self.model.bending_rows_from_tensions(tensions)
        self._readings = self._shape(tensions, self._comp)

    @property
    def _w(self) -> np.ndarray:
        """Bending vectors (N, S, 2), rad."""
        return self._comp.T.reshape(self.num_robots, self.params.n_sections, 2)

    # -- commands -------------------------------------------------------------------------------
    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        t = validation.per_cable(tensions, "tensions", self.n_cables, 0.0, self.params.max_tension)
        if t.shape != (self.num_robots, self.n_cables):
            raise ValueError(
                f"tensions must have shape ({self.num_robots}, {self.n_cables}), "
                f"got shape {t.shape}"
            )
        if mask is None:
            self._set(t.copy())
            return
        new = self._readings.tensions.copy()
        new[mask] = t[mask]
        self._set(new)

    def apply_tensions(self, tensions: np.ndarray) -> None:
        self._set(tensions)

    def apply_cable_lengths(self, lengths: np.ndarray) -> None:
        m = self.model
        w = m.bending_from_lengths(lengths)
        tensions, _ = minimal_tensions(m, w)
        self._comp = np.ascontiguousarray(w.reshape(self.num_robots, -1).T)
        self._readings = self._shape(tensions, self._comp)

    # -- readings -------------------------------------------------------------------------------
    def read(self) -> Readings:
        return self._readings

    def equilibrium(self, tensions: np.ndarray) -> Readings:
        t = validation.per_cable(tensions, "tensions", self.n_cables, 0.0, self.params.max_tension)
        flat = t.reshape(-1, self.n_cables)
        r = self._shape(flat, self.model.bending_rows_from_tensions(flat))
        batch = t.shape[:-1]
        return Readings(*(x.reshape(batch + x.shape[1:]) for x in r))

    @property
    def bending(self) -> np.ndarray:
        """Per-section bending vectors w_j = θ_j (cos φ_j, sin φ_j) (N, S, 2), rad."""
        return self._w.copy()

    def backbone_points(self, index: int = 0) -> np.ndarray:
        return self.model.backbone_points(self._w[index])

    def disk_frames(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        return self.model.disk_frames(self._w[index])
