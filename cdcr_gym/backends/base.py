"""The interface between the env core and a robot model (a *backend*).

A backend owns the physical state of ``num_robots`` robots and nothing else: it knows no goals,
rewards, tasks or Gymnasium spaces (dm_control's physics/task split). The env core
(``cdcr_gym.envs.core``) turns actions into cable commands, hands them to the backend, and
reads the robots back through :meth:`Backend.read`.

Conventions: SI units (m, N, rad, s); base frame R0 at the base disk centre with the backbone
along +Z0 and the first cable of the first section at angle β from +X0 about +Z0. Cables are
ordered section by section (proximal first), within a section in the order of its
``cable_angles`` (``RobotParams.cable_angles``); ``C = params.n_cables``. Tensions are in
[0, params.max_tension] N. A cable's length is its length from the base disk to the last disk of
its section (m).

Tendon displacements (SPEC §8; :meth:`Backend.apply_displacements`) are in m at the drive,
positive = pulled in; each tendon then pulls with T = clip(T0 + k·(d − s), 0, max_tension),
s = L_straight − L its geometric shortening (``params.cable_stiffness`` k,
``params.cable_pretension`` T0; :func:`drive_tensions`).

Arrays are float64 with a leading robot axis of size ``N = num_robots`` (the analytic backend
steps thousands of robots at once; a simulator backend has N = 1). Determinism: the same calls
in the same order give bit-identical readings.
"""

from __future__ import annotations

import abc
import math
from typing import NamedTuple

import numpy as np

from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.tendons import shortening_matrix, solve_displacement_statics, tendon_tensions

__all__ = [
    "Backend",
    "Readings",
    "DriveState",
    "drive_tensions",
    "SimulationDivergedError",
    "diverged",
    "MAX_JOINT_ANGLE",
    "MAX_JOINT_RATE",
]


#: A joint whose angle exceeds this (rad) or whose rate exceeds ``MAX_JOINT_RATE`` (rad/s) is
#: taken as a diverged simulation (a real spacer-disk span never kinks by 90°).
MAX_JOINT_ANGLE = 0.5 * math.pi
MAX_JOINT_RATE = 1.0e3


class SimulationDivergedError(RuntimeError):
    """The simulation produced a non-finite or exploding state.

    Attributes:
        state: dict with the offending ``joint_positions`` (rad), ``joint_velocities`` (rad/s),
            ``tensions`` (N) and simulated ``time`` (s), as numpy arrays / float.
    """

    def __init__(self, message: str, state: dict):
        super().__init__(message)
        self.state = state


def diverged(
    message: str, q: np.ndarray, qd: np.ndarray, tensions: np.ndarray, time: float
) -> SimulationDivergedError:
    """A :class:`SimulationDivergedError` describing the state (q, q̇, tensions, time)."""
    state = {
        "joint_positions": q.copy(),
        "joint_velocities": qd.copy(),
        "tensions": tensions.copy(),
        "time": time,
    }
    return SimulationDivergedError(
        f"{message} (t = {time:.4f} s, tensions {tensions.tolist()} N, "
        f"max |q| = {np.max(np.abs(q))} rad, max |q̇| = {np.max(np.abs(qd))} rad/s)",
        state,
    )


class Readings(NamedTuple):
    """What the env core reads from a backend after every command (all float64, SI units)."""

    tip: np.ndarray  #: (N, 3) tip (last disk centre) position in R0, m
    tip_direction: np.ndarray  #: (N, 3) unit backbone tangent at the tip in R0
    cable_lengths: np.ndarray  #: (N, C) sensed cable lengths, m
    tensions: np.ndarray  #: (N, C) cable tensions acting at the actuators, N
    #: (N, C) tensions at the cables' anchors, N, where friction makes them differ (else None)
    anchor_tensions: np.ndarray | None = None


class DriveState(NamedTuple):
    """The tendon drives after a displacement command (SPEC §8)."""

    displacements: np.ndarray  #: (N, C) commanded displacements held, m
    slack: np.ndarray  #: (N, C) bool: T0 + k(d − s) <= 0, the tendon carries exactly 0 N
    saturated: np.ndarray  #: (N, C) bool: the law asks for more than max_tension (held there)


def drive_tensions(
    params: RobotParams,
    displacements: np.ndarray,
    shortening: np.ndarray,
    max_tension: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drives' law T = clip(T0 + k·(d − s − c·Σ(T − T0)), 0, max_tension) of robot
    ``params`` (c its ``base_compliance``; the cap ``max_tension`` N, default
    ``params.max_tension``, ``inf``: none):
    (tensions (..., C) N, slack (..., C) bool, saturated (..., C) bool) for displacements
    ``displacements`` (..., C) m and geometric shortenings ``shortening`` (..., C) m
    (:func:`cdcr_gym.model.tendons.tendon_tensions`)."""
    return tendon_tensions(
        displacements,
        shortening,
        params.cable_stiffness,
        params.cable_pretension,
        params.max_tension if max_tension is None else max_tension,
        params.base_compliance,
    )


class Backend(abc.ABC):
    """A batch of ``num_robots`` robots that the env core can drive.

    Subclasses set :attr:`params`, :attr:`num_robots`, :attr:`control_timestep` and
    :attr:`supports_length_control`, and implement the abstract methods.
    """

    #: The robot's parameters (all robots of a backend share them).
    params: RobotParams
    #: Number of robots N stepped together.
    num_robots: int = 1
    #: Simulated time (s) that one command advances; 0.0 for a quasi-static model that jumps to
    #: equilibrium.
    control_timestep: float = 0.0
    #: Whether :meth:`apply_cable_lengths` is available (cable-displacement actions).
    supports_length_control: bool = False
    #: Whether :meth:`apply_displacements` is available (tendon displacements through the
    #: compliant drives, the ``displacement`` action modes).
    supports_displacement_control: bool = False
    #: Names of the randomised parameters (``cdcr_gym.randomization.RANDOMIZABLE``) that
    #: :meth:`set_randomized` applies; the others are drawn and reported but not modelled.
    randomizable: frozenset[str] = frozenset()
    #: Whether the backend simulates obstacle spheres itself (:meth:`set_obstacles`, and the
    #: ``obstacle_clearance`` and ``contact_forces`` properties, (N,) m and N).
    supports_obstacles: bool = False

    @property
    def n_cables(self) -> int:
        """Number of cables C."""
        return self.params.n_cables

    @abc.abstractmethod
    def reset(self, tensions: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Put robots at rest in their static equilibrium under ``tensions`` (N, C) N.

        ``mask`` (N,) bool selects the robots to reset (all if None); rows of ``tensions`` for
        the others are ignored. Zero tensions give the straight robot (with gravity, where the
        backend has it, the rest shape under its own weight). Deterministic: the same call gives
        the same state, whatever happened before. Tensions lie in [0,
        :attr:`reset_max_tension`] (above ``params.max_tension`` only for drives capped
        higher: the rest shape of a displacement command).
        """

    @abc.abstractmethod
    def apply_tensions(self, tensions: np.ndarray) -> None:
        """Hold cable tensions ``tensions`` (N, C) N for one control step.

        The caller guarantees finite values in [0, params.max_tension].
        """

    def apply_cable_lengths(self, lengths: np.ndarray) -> None:
        """Set cable lengths ``lengths`` (N, C) m (cable-displacement control).

        The caller guarantees lengths of a reachable shape. Only backends with
        :attr:`supports_length_control` implement it.
        """
        raise NotImplementedError(f"{type(self).__name__} does not support cable-length control")

    def apply_displacements(self, displacements: np.ndarray) -> object:
        """Hold tendon displacements ``displacements`` (N, C) m at the drives for one control
        step (module docstring: T = clip(T0 + k·(d − s), 0, max_tension) per tendon).

        The caller guarantees finite values. Afterwards :meth:`read` reports the tendons'
        tensions under the law at the robots' current shapes (exactly 0 N for a slack tendon,
        max_tension for a saturated one) and :attr:`drive_state` which tendons are slack or
        saturated. Only backends with :attr:`supports_displacement_control` implement it
        (the return value is the backend's own: None, or e.g. the analytic backend's
        :class:`~cdcr_gym.model.tendons.TendonState`).
        """
        raise NotImplementedError(f"{type(self).__name__} does not support displacement control")

    def enable_displacement_control(self) -> None:
        """Prepare for :meth:`apply_displacements` now (the env calls it at construction in a
        displacement action mode), so that drives this backend cannot run are refused at once
        (``ValueError``); the default prepares nothing."""

    @property
    def drive_state(self) -> DriveState | None:
        """The drives after the last :meth:`apply_displacements` (None after any other
        command)."""
        return None

    #: The drives' tension cap set by :meth:`set_drive_max_tension` (None: params.max_tension).
    _drive_cap: float | None = None

    @property
    def drive_max_tension(self) -> float:
        """The displacement drives' tension cap T_max, N (``inf``: none):
        ``params.max_tension`` unless :meth:`set_drive_max_tension` set another."""
        return float(self.params.max_tension) if self._drive_cap is None else self._drive_cap

    def set_drive_max_tension(self, max_tension: float) -> None:
        """Cap the displacement drives' tensions at ``max_tension`` N (> 0; ``inf``: no cap)
        instead of ``params.max_tension``.

        ``params.max_tension`` is the range of the tension commands (and of an env's tension
        actions); a real drive's cap is its own: a servo winding a tendon stops at its torque
        limit, not at the range an agent's actions were given. A calibration replaying
        measured drive commands uses the cap of its tendon drive
        (``cdcr_gym.calibration.drive.TendonDrive.max_tension``, none by default), as its
        constant-curvature solve does. Tension commands keep their range [0,
        ``params.max_tension``].

        Raises:
            ValueError: naming ``max_tension`` for a NaN, a non-number or a value <= 0.
            NotImplementedError: on a backend without displacement control.
        """
        if not self.supports_displacement_control:
            raise NotImplementedError(
                f"{type(self).__name__} does not support displacement control"
            )
        try:
            cap = float(max_tension)
        except (TypeError, ValueError):
            raise ValueError(f"max_tension must be a number > 0 N, got {max_tension!r}") from None
        if not cap > 0.0:  # also NaN
            raise ValueError(f"max_tension must be > 0 N (inf: no cap), got {max_tension!r}")
        self._drive_cap = cap
        self._drive_cap_changed()

    @property
    def reset_max_tension(self) -> float:
        """The largest tension (N) a :meth:`reset` takes: ``params.max_tension``, or the drives'
        cap when it is higher (a reset to the drives' equilibrium under displacement commands,
        e.g. an env's ``initial_displacements``)."""
        return max(float(self.params.max_tension), self.drive_max_tension)

    def _drive_cap_changed(self) -> None:
        """Apply a new :attr:`drive_max_tension` (a backend whose drives keep it elsewhere)."""

    @property
    def straight_cable_lengths(self) -> np.ndarray:
        """Cable lengths (C,) m of the straight robot (L_straight of the drives' law): this
        backend's own (its sensed lengths at the straight pose)."""
        return PCCModel(self.params).straight_lengths.copy()

    def displacement_equilibrium(
        self, displacements: np.ndarray, tol: float = 1e-9, max_iter: int = 50
    ) -> Readings:
        """Readings of the static equilibrium under drive displacements ``displacements``
        (M, C) m of the nominal robot (like :meth:`equilibrium`), without changing the state.

        The tensions T solving T = clip(T0 + k·(d − s(T)), 0, T_max) with s(T) this
        backend's own shortenings (:meth:`equilibrium`) and T_max the drives' cap
        (:attr:`drive_max_tension`: the shape the drives settle to, also when their cap is
        above ``params.max_tension``), by a Newton-like iteration whose
        Jacobian is the CCKA model's: each step solves the CCKA displacement statics
        (:func:`cdcr_gym.model.tendons.solve_displacement_statics`) for the commands corrected
        by the gap between this backend's shortenings and the CCKA ones at the current
        tensions. Exact in one step on the CCKA backend; on a physics backend the gap is a few
        % of the shortening, and the iteration contracts by about that factor per step.

        Raises:
            ValueError: naming ``displacements`` for a wrong shape or non-finite values.
            RuntimeError: if it has not converged to ``tol``·params.max_tension after
                ``max_iter`` steps.
        """
        p = self.params
        d = np.asarray(displacements, dtype=np.float64)
        if d.ndim != 2 or d.shape[1] != p.n_cables or not np.isfinite(d).all():
            raise ValueError(
                f"displacements must be finite with shape (M, {p.n_cables}), got {displacements!r}"
            )
        model = PCCModel(p)
        m_s = shortening_matrix(model)
        k, t0, t_max = p.cable_stiffness, p.cable_pretension, self.drive_max_tension
        straight = self.straight_cable_lengths
        correction = np.zeros_like(d)
        tensions = None
        for _ in range(max_iter):
            state = solve_displacement_statics(
                model, d - correction, k, t0, t_max, initial_tensions=tensions
            )
            new = state.tensions
            readings = self._drive_equilibrium(new)
            if tensions is not None and np.max(np.abs(new - tensions)) <= tol * p.max_tension:
                return readings
            tensions = new
            correction = (straight - readings.cable_lengths) - new @ m_s
        raise RuntimeError(
            f"the displacement equilibrium did not converge in {max_iter} steps (displacements "
            f"{d.tolist()} m)"
        )

    def reset_displacements(
        self, displacements: np.ndarray, mask: np.ndarray | None = None
    ) -> None:
        """Put robots ``mask`` (all if None) at rest in their drives' equilibrium under
        displacement commands ``displacements`` (N, C) m (:meth:`displacement_equilibrium`: the
        drives' law with their own cap): the rest shape of an env's ``initial_displacements``.

        This default resets under the tensions of that equilibrium (:meth:`reset`): the same
        shape wherever the tensions alone determine it. A backend whose drives settle to a
        shape the tensions alone do not single out (co-contracted tendons) overrides it with its
        own drive solve.

        Raises:
            ValueError: naming ``displacements`` for a wrong shape or non-finite values.
        """
        d, rows = self._displacement_rows(displacements, mask)
        t = np.zeros_like(d)
        t[rows] = self.displacement_equilibrium(d[rows]).tensions
        self.reset(t, mask)

    def _displacement_rows(
        self, displacements: np.ndarray, mask: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``displacements`` checked as (N, C) finite m, and the robot indices of ``mask``."""
        n, c = self.num_robots, self.params.n_cables
        d = np.asarray(displacements, dtype=np.float64)
        if d.shape != (n, c) or not np.isfinite(d).all():
            raise ValueError(
                f"displacements must be finite with shape ({n}, {c}) m, got {displacements!r}"
            )
        rows = np.arange(n) if mask is None else np.flatnonzero(np.asarray(mask).reshape(n))
        return d, rows

    def _drive_equilibrium(self, tensions: np.ndarray) -> Readings:
        """:meth:`equilibrium` under tensions (M, C) N the drives may pull: in [0,
        :attr:`drive_max_tension`], which may exceed ``params.max_tension`` (the range of
        tension commands that :meth:`equilibrium` checks). Backends whose drives can be capped
        above it override this (the same statics without that upper bound)."""
        return self.equilibrium(tensions)

    @abc.abstractmethod
    def read(self) -> Readings:
        """The current :class:`Readings` of all robots (fresh arrays the caller may keep)."""

    @abc.abstractmethod
    def equilibrium(self, tensions: np.ndarray) -> Readings:
        """Readings of the static equilibrium under ``tensions`` (M, C) N, for any M.

        This backend's own statics (its reachable set), without changing its state: the task
        samples goals with it, so a goal is always reachable on the backend that runs it.
        """

    @abc.abstractmethod
    def backbone_points(self, index: int = 0) -> np.ndarray:
        """Points along robot ``index``'s backbone, base to tip, shape (P, 3), m, in R0.

        The first point is the base (0, 0, 0), the last is the tip; every disk station is
        included.
        """

    @abc.abstractmethod
    def disk_frames(self, index: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Robot ``index``'s disks, base disk first: centres (D + 1, 3) m and orientations
        (D + 1, 3, 3) (columns: disk x, y axes and backbone tangent, in R0).

        The pinhole of a cable at (r, β) in disk k is ``centre_k + R_k @ (r cos β, r sin β, 0)``.
        """

    def set_randomized(self, index: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Give robots ``index`` (M,) their drawn parameters ``values`` (name → (M,) array, SI
        units; ``cdcr_gym.randomization``) before they are reset.

        Applies the names in :attr:`randomizable` and ignores the others; the default applies
        nothing.
        """

    def set_obstacles(self, index: np.ndarray, spheres: np.ndarray) -> None:
        """Place spheres ``spheres`` (M, K, 4) rows (x, y, z, radius m, in R0; radius 0: none)
        for robots ``index`` (M,). Only backends with :attr:`supports_obstacles` implement it."""
        raise NotImplementedError(f"{type(self).__name__} does not simulate obstacles")

    @property
    def obstacle_clearance(self) -> np.ndarray:
        """Smallest robot–sphere distance (N,) m (negative: penetration); backends with
        :attr:`supports_obstacles` only."""
        raise NotImplementedError(f"{type(self).__name__} does not simulate obstacles")

    @property
    def contact_forces(self) -> np.ndarray:
        """Total normal force (N,) N of the spheres on each robot; backends with
        :attr:`supports_obstacles` only."""
        raise NotImplementedError(f"{type(self).__name__} does not simulate obstacles")

    def close(self) -> None:
        """Release any resource (simulator client, window). Safe to call more than once."""
