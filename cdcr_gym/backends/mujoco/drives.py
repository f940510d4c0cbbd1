"""Tendon displacement drives of a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`.

:class:`TendonDrives` holds the backend's ``apply_displacements`` and what it needs (a base class
of the backend; not used on its own). Each cable's drive is a ``general`` actuator on its
tendon with force −clip(T0 + k·(d − (L0 − L)), 0, T_max): gain −k on the command d (m), bias
k·L0 − T0 and −k·L (L the tendon length, L0 at the straight pose), force range [−T_max, 0] — the
one-sided clamp is the slack tendon, the upper one the saturation (``cdcr_gym.model.tendons``).
The drives' tendons get damping γ·k (γ = the physics timestep) and the step the
``implicitfast`` integrator, which treats that damping implicitly: the stiff spring stays stable.
Tension commands release the drives (force exactly 0, damping off).

A compliant base (``RobotParams.base_compliance`` c > 0, :mod:`cdcr_gym.model.tendons`): every
drive loses c·Σ(T − T0) of its pull. The total load couples the tendons, which MuJoCo's
per-tendon actuators cannot; so at the start of every control step the coupled law is solved
exactly at the current tendon lengths (:func:`cdcr_gym.model.tendons.tendon_tensions`) and each
actuator gets the command less the base's give, d − c·(ΣT − ΣT0). At rest that is the law
exactly; the static solves (:meth:`_solve_drives`) iterate it to convergence.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.base import DriveState
from cdcr_gym.backends.mujoco import friction as mj_friction
from cdcr_gym.model.tendons import tendon_tensions

__all__ = ["RELEASED", "TendonDrives"]

#: The drives' control while released: far below any slack point, so the force is exactly 0.
RELEASED = -1.0e3
#: Slack (m) within which a gated drive keeps its damping (:attr:`TendonDrives.gate_damping`).
DAMPING_MARGIN = 1.0e-3


class TendonDrives:
    """The displacement-drive part of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`."""

    _drive_state: DriveState | None
    #: False (default): every drive's tendon carries the damping γ·k. True: only the drives
    #: that are taut or within ``DAMPING_MARGIN`` + this step's command change of taut (at the
    #: start of each control step) carry it; the slack ones none. The damping is needed only
    #: by the stiff taut-drive modes; on a slack tendon it resists the robot's motion with
    #: nothing to balance it but the rod's bending stiffness, so the shapes in which tendons
    #: go slack settle with a time constant of ~γ·Σk/K_rod (0.3–0.6 s on ftdcr_v4). Measured
    #: on 60 rows of the ftdcr_v4 measurements replayed 0.6 s apart (gravity off): mean tip
    #: distance to the quasi-static CCKA shape 3.5 mm ungated, 0.19 mm gated. Each robot then
    #: gets its own MjModel.
    gate_damping: bool = False

    def enable_displacement_control(self: Any) -> None:
        """Build the displacement drives (module docstring) now rather than at the first
        :meth:`apply_displacements`, so that a drive this backend cannot run is refused at
        once (the env calls it at construction in a displacement action mode).

        Raises:
            ValueError: for ``integrator="RK4"``, an infinite ``tendon_stiffness`` (MuJoCo
                needs a finite spring), or drives that would make the step unstable at this
                ``physics_timestep`` (:meth:`drive_stability` >= 1).
        """
        self._check_open()
        if self._drives:
            return
        p = self.params
        if self.integrator == "RK4":
            raise ValueError(
                "integrator='RK4' cannot run displacement commands on the MuJoCo backend (the "
                "drives' stiff tendons need implicit tendon damping: use 'Euler', "
                "'implicitfast' or 'implicit')"
            )
        k = np.asarray(p.cable_stiffness)
        if not np.isfinite(k).all():
            raise ValueError(
                f"tendon_stiffness must be finite (N/m) for displacement commands on the MuJoCo "
                f"backend, got {p.tendon_stiffness!r} (use a large finite k, e.g. 1e6, for a "
                f"nearly inextensible tendon)"
            )
        self._drives = True
        self._rebuild(self._has_segments, self.n_obstacles)
        rho = self.drive_stability()
        if not rho < 1.0:
            raise ValueError(
                f"tendon_stiffness={p.tendon_stiffness!r} N/m with physics_timestep="
                f"{self.physics_timestep!r} s makes the MuJoCo step unstable (spectral radius "
                f"{rho:.4f} of the linearised step with taut drives, >= 1); use a smaller "
                f"physics_timestep or a larger damping_ratio"
            )

    def drive_stability(self: Any) -> float:
        """Spectral radius of one physics step of the straight robot (nominal model) with
        every drive taut, linearised: v⁺ = v + h·(M + hD)⁻¹·(−K·x − D·v), x⁺ = x + h·v⁺ with
        K = K_joints + Jᵀ·diag(k)·J (J the cables' tendon Jacobian) and D = β·K_joints +
        γ·Jᵀ·diag(k)·J (the joints' damping and the drives' tendon damping, both implicit in
        ``implicitfast``). < 1: stable (tension stiffening, gravity and contacts ignored)."""
        mj, model, data = self._mj, self.model, self._scratch
        mj.mj_resetData(model, data)
        mj.mj_forward(model, data)
        nv = model.nv
        mass = np.zeros((nv, nv))
        mj.mj_fullM(model, data, mass)
        jac = mj_friction.dense_tendon_jacobian(data, self._jac_index[0], self.params.n_cables, nv)
        k = np.asarray(self.params.cable_stiffness)
        drives = jac.T @ (k[:, None] * jac)
        stiffness = np.diag(self._stiffness) + drives
        h = model.opt.timestep
        damping = self.damping_time * np.diag(self._stiffness) + h * drives
        b = np.linalg.inv(mass + h * damping)
        eye = np.eye(nv)
        v_from_x, v_from_v = -h * b @ stiffness, eye - h * b @ damping
        step = np.block([[eye + h * v_from_x, h * v_from_v], [v_from_x, v_from_v]])
        return float(np.max(np.abs(np.linalg.eigvals(step))))

    def _set_drive_damping(self: Any, on: bool) -> None:
        """The drives' tendon damping γ·k (γ = physics timestep, module docstring) on every
        model, or 0; a robot with its own drives (:meth:`set_drive_parameters`) gets its k."""
        h = self.physics_timestep
        nominal = np.asarray(self.params.cable_stiffness, dtype=np.float64)
        self.model.tendon_damping[self._cable_ids] = h * nominal if on else 0.0
        k = np.broadcast_to(self._drive_constants[0], (self.num_robots, nominal.size))
        for i, model in enumerate(self._models):
            if model is not self.model:
                model.tendon_damping[self._cable_ids] = h * k[i] if on else 0.0

    def set_drive_parameters(
        self: Any,
        index: Any,
        stiffness: np.ndarray,
        pretension: np.ndarray,
        base_compliance: np.ndarray | None = None,
    ) -> None:
        """Give robots ``index`` (n,) their own drive law: tendon stiffness ``stiffness`` (n, C)
        N/m and pretension ``pretension`` (n, C) N (the law of the module docstring with these
        k and T0; the drives' damping γ·k follows k), and optionally its compliant base
        ``base_compliance`` (n,) m/N (module docstring). Each such robot gets its own MjModel
        (a calibration's batched finite differences: one robot per perturbed parameter).
        Builds the drives first if needed; a later rebuild (friction switched on by
        :meth:`set_randomized`, obstacles) resets them: call this last.

        Raises:
            ValueError: naming ``stiffness`` / ``pretension`` for a wrong shape, a
                non-finite or non-positive k, or a negative or non-finite T0.
        """
        self._check_open()
        idx = np.asarray(index, dtype=int).reshape(-1)
        c = self.params.n_cables
        k = validation.real_array(stiffness, "stiffness", (idx.size, c))
        t0 = validation.real_array(pretension, "pretension", (idx.size, c))
        if np.any(k <= 0.0):
            raise ValueError(f"stiffness must be > 0 N/m, got {k.tolist()}")
        if np.any(t0 < 0.0):
            raise ValueError(f"pretension must be >= 0 N, got {t0.tolist()}")
        comp = None
        if base_compliance is not None:
            comp = validation.real_array(base_compliance, "base_compliance", (idx.size,))
            if np.any(comp < 0.0):
                raise ValueError(f"base_compliance must be >= 0 m/N, got {comp.tolist()}")
        if not self._drives:
            self.enable_displacement_control()  # rebuilds the model: the robots' values after
        if comp is not None:
            self._base_compliance[idx] = comp
        k_all, t_all, t_max = self._drive_constants
        k_all = np.array(np.broadcast_to(k_all, (self.num_robots, c)))
        t_all = np.array(np.broadcast_to(t_all, (self.num_robots, c)))
        h = self.physics_timestep
        for j, i in enumerate(idx.tolist()):
            model = self._own_model(i)
            model.actuator_gainprm[self._drive_slice, 0] = -k[j]
            model.actuator_biasprm[self._drive_slice, 0] = k[j] * self._straight - t0[j]
            model.actuator_biasprm[self._drive_slice, 1] = -k[j]
            model.tendon_damping[self._cable_ids] = h * k[j] if self._driving else 0.0
            k_all[i], t_all[i] = k[j], t0[j]
        self._drive_constants = (k_all, t_all, t_max)

    def _drive_cap_changed(self: Any) -> None:
        """The drives' law and every robot's actuator force range [−T_max, 0] take the new
        :attr:`drive_max_tension` T_max (``Backend.set_drive_max_tension``)."""
        cap = self.drive_max_tension
        k, t0, _ = self._drive_constants
        self._drive_constants = (k, t0, cap)
        if self._drives:
            for model in {id(m): m for m in (self.model, *self._models)}.values():
                model.actuator_forcerange[self._drive_slice, 0] = -cap

    def _release_drives(self: Any) -> None:
        """Tension commands: the drives' force clamped to exactly 0, their damping off."""
        if self._driving:
            for data in self._datas:
                data.ctrl[self._drive_slice] = RELEASED
            self._set_drive_damping(False)
            self._driving = False
        self._drive_state = None

    def _drive_law(
        self: Any, displacements: np.ndarray, lengths: np.ndarray, robot: int = 0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(tensions, slack, saturated) of the drives' law at tendon lengths ``lengths`` m
        (``backends.base.drive_tensions`` with finite k, inlined: it runs every step); rows
        (N, C) of every robot, or (C,) of robot ``robot``."""
        k, t0, t_max = self._drive_constants
        if k.ndim == 2 and displacements.ndim == 1:  # one robot's row (friction path)
            k, t0 = k[robot], t0[robot]
        raw = t0 + k * (displacements - (self._straight - lengths))
        return np.clip(raw, 0.0, t_max), raw <= 0.0, raw > t_max

    def _drive_commands(self: Any, displacements: np.ndarray) -> np.ndarray:
        """The actuators' commands (N, C) m for drive displacements ``displacements`` (N, C):
        the displacements less each robot's base give c·(ΣT − ΣT0) with the tensions of the
        coupled law at the current tendon lengths (module docstring); unchanged for c = 0."""
        comp = self._base_compliance
        if not np.any(comp > 0.0):
            return displacements
        k, t0, t_max = self._drive_constants
        n, c = displacements.shape
        k = np.broadcast_to(k, (n, c))
        t0 = np.broadcast_to(t0, (n, c))
        t, _, _ = tendon_tensions(displacements, self._straight - self._lengths, k, t0, t_max, comp)
        give = comp * (t.sum(axis=1) - t0.sum(axis=1))
        return displacements - give[:, None]

    def apply_displacements(self: Any, displacements: np.ndarray) -> None:
        """Hold drive displacements ``displacements`` (N, C) m for one control step
        (``n_substeps`` MuJoCo steps; the drives evaluate the law at every physics step, the
        module docstring). The first call builds the drives
        (:meth:`enable_displacement_control`). :meth:`read`'s tensions are the law at the
        tendons' lengths after the step (exactly 0 N for a slack tendon), :attr:`drive_state`
        says which are slack or saturated.

        Raises:
            ValueError: naming ``displacements`` for a wrong shape or non-finite values.
            SimulationDivergedError: as :meth:`apply_tensions`.
        """
        self._check_open()
        n, c = self.num_robots, self.params.n_cables
        if (
            type(displacements) is np.ndarray
            and displacements.shape == (n, c)
            and np.isfinite(displacements).all()
        ):
            d = displacements.astype(np.float64)  # a copy
        else:
            d = validation.real_array(displacements, "displacements", (n, c)).copy()
        if not self._drives:
            self.enable_displacement_control()
        if not self._driving:
            self._set_drive_damping(True)
            self._driving = True
        command = self._drive_commands(d)
        if self.gate_damping:
            self._gate_drive_damping(command)
        self._displacements = command
        self.time += self.control_timestep
        n_pull, drive = self._n_pull, self._drive_slice
        for data, row in zip(self._datas, command):
            data.ctrl[:n_pull] = 0.0
            data.ctrl[drive] = row
        if self._rough:
            self._step_with_friction(self._tensions.copy(), command)
            for i in range(n):
                self._check_state(i)
        elif self.threads is None or self._backbone_rough():
            for i, data in enumerate(self._datas):
                self._advance(self._models[i], data, self.n_substeps, i)
                self._check_state(i)
                self._sense(i)
        else:
            self._rollout_step()
            for i in range(n):
                self._check_state(i)
                self._sense(i)
        if np.any(self._base_compliance > 0.0):
            k, t0, t_max = self._drive_constants
            tensions, slack, saturated = tendon_tensions(
                d, self._straight - self._lengths, k, t0, t_max, self._base_compliance
            )
        else:
            tensions, slack, saturated = self._drive_law(d, self._lengths)
        self._tensions = tensions
        self._drive_state = DriveState(d.copy(), slack, saturated)

    def _gate_drive_damping(self: Any, d: np.ndarray) -> None:
        """The drives' damping γ·k on the tendons taut or nearly taut under command ``d``
        (N, C) m at the current lengths, 0 on the others (:attr:`gate_damping`)."""
        k, t0, _ = self._drive_constants
        n, c = d.shape
        k = np.broadcast_to(k, (n, c))
        t0 = np.broadcast_to(t0, (n, c))
        raw = t0 + k * (d - (self._straight - self._lengths))
        margin = DAMPING_MARGIN + np.abs(d - self._displacements)
        damped = raw > -k * margin
        h = self.physics_timestep
        for i in range(n):
            model = self._own_model(i)
            model.tendon_damping[self._cable_ids] = np.where(damped[i], h * k[i], 0.0)

    @property
    def drive_state(self: Any) -> DriveState | None:
        return self._drive_state

    @property
    def straight_cable_lengths(self: Any) -> np.ndarray:
        """The cables' tendon lengths (C,) m at the straight pose (L0 of the drives)."""
        return self._straight.copy()
