"""The CCKA/PCC backend: the piecewise-constant-curvature model and its pure-moment statics.

Quasi-static and batched: every command moves all N robots straight to their equilibrium shapes
(no dynamics, no gravity). Tension commands bend the sections by the coupled pure-moment statics
(``PCCModel.bending_from_tensions``: a cable loads its own section and every proximal one);
cable-length commands set the shape by ``PCCModel.bending_from_lengths`` and report the minimal
tensions that hold it (``model.statics.minimal_tensions``, clipped to max_tension). Tendon
displacement commands (:meth:`AnalyticBackend.apply_displacements`, SPEC §8) go through the
robot's compliant drives (``params.tendon_stiffness``, ``tendon_pretension``) and
``model.tendons.solve_displacement_statics``, warm-started from the current tensions; slack and
saturated tendons are reported in :attr:`AnalyticBackend.tendon_state`. The single env runs it
with N = 1, the batched env with N = num_envs.

Per-robot parameters (domain randomisation, :meth:`AnalyticBackend.set_randomized`): a robot
with Young's modulus E and cable radius r bends by w = (r/r₀)(E₀/E)·w₀(T) under tensions T, and
its cable lengths change by (r/r₀)·Δl₀(w), where the subscript 0 is the nominal robot
(``params``): the statics and the length map are linear in r/EI and r. Until parameters are set
the nominal path runs unchanged.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import Backend, DriveState, Readings
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import minimal_tensions
from cdcr_gym.model.tendons import TendonState, solve_displacement_statics

__all__ = ["AnalyticBackend"]


class AnalyticBackend(Backend):
    """N constant-curvature robots driven by cable tensions or cable lengths.

    Args:
        params: the robot (default: the paper's, ``RobotParams()``).
        num_robots: number of robots N stepped together (>= 1).
    """

    control_timestep = 0.0
    supports_length_control = True
    supports_displacement_control = True
    randomizable = frozenset({"youngs_modulus", "cable_radius"})

    def __init__(self, params: RobotParams | None = None, num_robots: int = 1) -> None:
        if params is None:
            params = RobotParams()
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        self.params = params
        self.num_robots = validation.integer(num_robots, "num_robots", 1)
        self.model = PCCModel(params)
        #: Per-robot factors (N,) on the bending (r/r₀)(E₀/E) and on the cable-length changes
        #: (r/r₀); None while every robot is nominal.
        self.bending_scale: np.ndarray | None = None
        self.length_scale: np.ndarray | None = None
        self._tendon_state: TendonState | None = None
        self._displacements: np.ndarray | None = None
        self._set(np.zeros((self.num_robots, params.n_cables)))

    def _shape(
        self, tensions: np.ndarray, comp: np.ndarray, length_scale: np.ndarray | None = None
    ) -> Readings:
        """Readings of the bending component rows ``comp`` (2S, N) held by ``tensions`` (N, C);
        ``length_scale`` (N,): per-robot factors on the cable-length changes (None: nominal).

        The model works field-major (one row per component); the computed readings are the
        transposed views, (N, ·) Fortran-ordered arrays, so the tasks' field-major observation
        buffers fill from contiguous rows (``tensions`` are kept as given).
        """
        m = self.model
        tip, direction, lengths = m.forward_rows(comp)
        if length_scale is not None:  # lengths are linear in w: scaling w scales Δl
            lengths = m.bending_to_lengths.T @ (comp * length_scale)
            lengths += m.straight_lengths[:, None]
        return Readings(tip.T, direction.T, lengths.T, tensions)

    def _set(self, tensions: np.ndarray) -> None:
        self._tendon_state = None
        if self.bending_scale is None:  # the nominal robots: bending and lengths in one product
            comp, (tip, direction, lengths) = self.model.forward_rows_from_tensions(tensions)
            self._comp = comp
            self._readings = Readings(tip.T, direction.T, lengths.T, tensions)
            return
        comp = self.model.bending_rows_from_tensions(tensions)
        comp *= self.bending_scale
        self._comp = comp
        self._readings = self._shape(tensions, comp, self.length_scale)

    @property
    def _w(self) -> np.ndarray:
        """Bending vectors (N, S, 2), rad."""
        return self._comp.T.reshape(self.num_robots, self.params.n_sections, 2)

    # -- commands -------------------------------------------------------------------------------
    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        t = validation.per_cable(tensions, "tensions", self.n_cables, 0.0, self.reset_max_tension)
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
        if self.length_scale is not None and self.bending_scale is not None:
            w /= self.length_scale[:, None, None]
            tensions, _ = minimal_tensions(m, w / self.bending_scale[:, None, None])
        else:
            tensions, _ = minimal_tensions(m, w)
        self._comp = np.ascontiguousarray(w.reshape(self.num_robots, -1).T)
        self._readings = self._shape(tensions, self._comp, self.length_scale)
        self._tendon_state = None

    def apply_displacements(
        self, displacements: np.ndarray, stiffness=None, pretension=None
    ) -> TendonState:
        """Command tendon displacements ``displacements`` (N, C) m (positive = pulled in at the
        drive; 0 = the straight robot at its pretension) and move to the quasi-static shape.

        Each tendon pulls with T = clip(T0 + k·(d − s), 0, T_max) (SPEC §8; T_max
        :attr:`drive_max_tension`), s its
        geometric shortening, solved exactly with the pure-moment statics
        (:func:`cdcr_gym.model.tendons.solve_displacement_statics`, warm-started from the
        current tensions; per-robot randomised E and r are honoured).

        Args:
            displacements: (N, C) m, finite.
            stiffness: k (N/m), scalar, (C,) or (N, C); default ``params.tendon_stiffness``.
            pretension: T0 (N), scalar, (C,) or (N, C); default ``params.tendon_pretension``.

        Returns:
            the :class:`~cdcr_gym.model.tendons.TendonState` (tensions, bending, slack,
            saturated, shortening), also kept as :attr:`tendon_state`; :meth:`read` gives the
            readings (tensions = the drives' tensions).

        Raises:
            ValueError: naming the argument, for a wrong shape or non-finite values.
        """
        d = np.asarray(displacements, dtype=np.float64)
        if d.shape != (self.num_robots, self.n_cables):
            raise ValueError(
                f"displacements must have shape ({self.num_robots}, {self.n_cables}), "
                f"got shape {d.shape}"
            )
        p = self.params
        state = solve_displacement_statics(
            self.model,
            d,
            p.cable_stiffness if stiffness is None else stiffness,
            p.cable_pretension if pretension is None else pretension,
            self.drive_max_tension,
            initial_tensions=self._readings.tensions,
            bending_scale=self.bending_scale,
            length_scale=self.length_scale,
        )
        w = state.bending
        self._comp = np.ascontiguousarray(w.reshape(self.num_robots, -1).T)
        self._readings = self._shape(state.tensions, self._comp, self.length_scale)
        self._tendon_state = state
        self._displacements = d.copy()
        return state

    @property
    def tendon_state(self) -> TendonState | None:
        """The :class:`~cdcr_gym.model.tendons.TendonState` of the last
        :meth:`apply_displacements` (slack (N, C), saturated (N, C), …); None after any other
        command."""
        return self._tendon_state

    @property
    def drive_state(self) -> DriveState | None:
        state = self._tendon_state
        if state is None or self._displacements is None:
            return None
        return DriveState(self._displacements, state.slack, state.saturated)

    def set_randomized(self, index: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Set ``youngs_modulus`` (Pa) and ``cable_radius`` (m) of robots ``index`` (others in
        ``values`` are ignored: this model has no mass, gravity or friction)."""
        if not self.randomizable.intersection(values):
            return
        if self.bending_scale is None or self.length_scale is None:
            self.bending_scale = np.ones(self.num_robots)
            self.length_scale = np.ones(self.num_robots)
        p = self.params
        r_ratio = np.ones(len(index))
        e_ratio = np.ones(len(index))
        if "cable_radius" in values:
            r_ratio = np.asarray(values["cable_radius"], dtype=np.float64) / p.cable_radii[0]
        if "youngs_modulus" in values:
            e_ratio = p.youngs_modulus / np.asarray(values["youngs_modulus"], dtype=np.float64)
        self.length_scale[index] = r_ratio
        self.bending_scale[index] = r_ratio * e_ratio

    # -- readings -------------------------------------------------------------------------------
    def read(self) -> Readings:
        return self._readings

    def equilibrium(self, tensions: np.ndarray) -> Readings:
        return self._statics(tensions, self.params.max_tension)

    def _drive_equilibrium(self, tensions: np.ndarray) -> Readings:
        return self._statics(tensions, self.drive_max_tension)

    def _statics(self, tensions: np.ndarray, limit: float) -> Readings:
        """The CCKA shapes under tensions (..., C) N checked to lie in [0, ``limit``]."""
        t = validation.per_cable(tensions, "tensions", self.n_cables, 0.0, limit)
        flat = t.reshape(-1, self.n_cables)
        _, (tip, direction, lengths) = self.model.forward_rows_from_tensions(flat)
        batch = t.shape[:-1]
        return Readings(
            tip.T.reshape(batch + (3,)),
            direction.T.reshape(batch + (3,)),
            lengths.T.reshape(t.shape),
            t,
        )

    @property
    def bending(self) -> np.ndarray:
        """Per-section bending vectors w_j = θ_j (cos φ_j, sin φ_j) (N, S, 2), rad."""
        return self._w.copy()

    def backbone_points(self, index: int = 0) -> np.ndarray:
        return self.model.backbone_points(self._w[index])

    def disk_frames(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        return self.model.disk_frames(self._w[index])
