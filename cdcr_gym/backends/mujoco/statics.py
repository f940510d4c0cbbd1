"""The static equilibrium of a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`.

:class:`StaticSolve` (a base class of the backend; not used on its own) finds the shape the
dynamics settle to under given tensions — a relaxed fixed-point iteration on the joint
stiffness, in MuJoCo's generalized forces — for resets, goals and ``equilibrium``: first
Anderson-accelerated (``anderson.py``: the same fixed point in ~20 instead of ~600
``mj_forward`` calls on a 30-disk robot), then, if that fails, the plain relaxed iteration.
Under drive displacements (:meth:`StaticSolve.displacement_equilibrium`, a model with drives)
the same map with the drives' stiffness in the preconditioner solves the drives' law and the
statics together, in one solve instead of an outer iteration of tension solves.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_ANGLE, Backend, Readings
from cdcr_gym.backends.mujoco.anderson import anderson_solve, drive_preconditioner
from cdcr_gym.backends.mujoco.drives import RELEASED
from cdcr_gym.model.tendons import tendon_tensions

__all__ = ["StaticSolve"]


class StaticSolve:
    """The statics part of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`."""

    def _solve_static(
        self: Any,
        model: Any,
        data: Any,
        tensions: np.ndarray,
        tol: float = 1e-13,
        max_iter: int = 1000,
        relaxations: tuple[float, ...] = (1.0, 0.5, 0.25),
    ) -> bool:
        """Put ``data`` at the static equilibrium of ``model`` under ``tensions`` (C,) N.

        The fixed point q ← q ⊕ ω·K⁻¹·(τ_cable(q) + τ_passive(q) − τ_gravity(q)) from the
        straight pose (bullet's iteration, in MuJoCo's generalized forces; ⊕ MuJoCo's position
        integration, which handles the ball joints' quaternions), to max |K⁻¹·τ| < ``tol`` rad.
        With ω = 1 it converges when the cable and gravity load stiffnesses are a fraction of K;
        where they are not (tdcr2 with gravity and every cable near max_tension: the plain
        iteration oscillates although the dynamics settle) it is restarted with the smaller
        relaxation factors ω of ``relaxations`` (``max_iter``/ω iterations each). Every ω has the
        same fixed point, the state the dynamics settle to, so a case the plain iteration solves
        gives the same bits. Returns whether it converged.
        """
        mj = self._mj
        k_inv = 1.0 / model.jnt_stiffness[model.dof_jntid]
        step = np.empty(model.nv)
        for omega in relaxations:
            data.qpos[:] = model.qpos0
            data.qvel[:] = 0.0
            data.act[:] = 0.0
            data.ctrl[:] = 0.0
            data.ctrl[: self._n_pull] = tensions
            data.ctrl[self._drive_slice] = RELEASED
            for _ in range(int(max_iter / omega)):
                mj.mj_forward(model, data)
                np.subtract(data.qfrc_actuator + data.qfrc_passive, data.qfrc_bias, out=step)
                step *= k_inv
                size = np.max(np.abs(step))
                if not size <= MAX_JOINT_ANGLE:  # NaN too
                    break
                mj.mj_integratePos(model, data.qpos, step, omega)
                if size < tol:
                    mj.mj_forward(model, data)
                    return True
        return False

    def _solve_static_fast(
        self: Any, model: Any, data: Any, tensions: np.ndarray, tol: float = 1e-13
    ) -> bool:
        """:meth:`_solve_static` (the same fixed point and tolerance, from the straight pose),
        Anderson-accelerated (``anderson.py``); the relaxed plain iteration if that fails."""
        data.qvel[:] = 0.0
        data.act[:] = 0.0
        data.ctrl[:] = 0.0
        data.ctrl[: self._n_pull] = tensions
        data.ctrl[self._drive_slice] = RELEASED
        k_inv = 1.0 / model.jnt_stiffness[model.dof_jntid]

        def precondition(_: Any, residual: np.ndarray) -> np.ndarray:
            return np.multiply(residual, k_inv, out=residual)

        if anderson_solve(self._mj, model, data, precondition, tol=tol) > 0:
            return True
        return bool(self._solve_static(model, data, tensions, tol=tol))

    def _solve_drives(
        self: Any, model: Any, data: Any, displacements: np.ndarray, tol: float = 1e-13
    ) -> bool:
        """Put ``data`` at the static equilibrium of ``model`` (with drives) under drive
        displacements ``displacements`` (C,) m, the drives holding them (motors at 0 N):
        Anderson-accelerated, preconditioned with the taut drives' stiffness (``anderson.py``),
        to max|P·r| < ``tol`` rad. With a compliant base (c > 0) the actuators' commands are
        the displacements less the base's give c·(ΣT − ΣT0) (``drives.py``), re-solved from
        the settled shape (secant steps on the give) until it changes by less than 1e-12 m (at
        most 50 solves).
        Returns whether it converged."""
        data.qvel[:] = 0.0
        data.act[:] = 0.0
        data.ctrl[:] = 0.0
        p = self.params
        k = np.asarray(p.cable_stiffness, dtype=float)
        t0 = np.asarray(p.cable_pretension, dtype=float)
        stiffness = np.asarray(model.jnt_stiffness[model.dof_jntid], dtype=float)
        comp = float(p.base_compliance)
        give, prev = 0.0, None  # the base's give (m) and the secant's previous (give, residual)
        for _ in range(50 if comp > 0.0 else 1):
            command = displacements - give
            data.ctrl[self._drive_slice] = command
            law = (command, k, t0, self._straight, self.drive_max_tension)
            precondition = drive_preconditioner(stiffness, self._jac_index[0], self._cable_ids, law)
            if anderson_solve(self._mj, model, data, precondition, tol=tol) <= 0:
                return False
            if comp == 0.0:
                return True
            shortening = self._straight - data.ten_length[self._cable_ids]
            t, _, _ = tendon_tensions(
                displacements, shortening, k, t0, self.drive_max_tension, comp
            )
            residual = comp * float(t.sum() - t0.sum()) - give
            if abs(residual) < 1e-12:
                return True
            # secant on the scalar give (a fixed-point step first)
            step = residual
            if prev is not None and residual != prev[1]:
                step = -residual * (give - prev[0]) / (residual - prev[1])
            prev = (give, residual)
            give += step
        return False

    def static_equilibrium(self: Any, tensions: np.ndarray, index: int = 0) -> np.ndarray:
        """Joint positions ``qpos`` of robot ``index``'s static equilibrium under ``tensions``
        (C,) N (MuJoCo's qpos layout: 4 per ball joint, 2 per Cardan joint).

        Raises:
            SimulationDivergedError: if no equilibrium is found.
        """
        t = self._check_tensions(tensions, 1)[0]
        data = self._scratch
        model = self._models[index]
        if not self._solve_static_fast(model, data, t):
            raise self._diverged(
                "no static equilibrium found: the cables' destabilising load stiffness exceeds "
                "the joint stiffness; use more disks, more links_per_span or lower tensions",
                data,
                t,
                0.0,
            )
        return data.qpos.copy()

    def equilibrium(self: Any, tensions: np.ndarray) -> Readings:
        """Static equilibria under ``tensions`` (M, C) N of the nominal robot (the constructor's
        parameters, not a randomised robot's: the interface has no robot index, and so the
        goals of N batched envs are those of N single envs, as on the analytic backend),
        without changing the state. The placed spheres are ignored."""
        self._check_open()
        return self._statics(self._check_tensions(tensions))

    def _drive_equilibrium(self: Any, tensions: np.ndarray) -> Readings:
        self._check_open()
        return self._statics(self._check_tensions(tensions, limit=self.drive_max_tension))

    def _statics(self: Any, t_all: np.ndarray) -> Readings:
        """:meth:`equilibrium` of checked tensions (M, C) N."""
        m = t_all.shape[0]
        tip, direction = np.empty((m, 3)), np.empty((m, 3))
        lengths = np.empty((m, self.params.n_cables))
        data, model = self._scratch, self.model
        for j, t in enumerate(t_all):
            if not self._solve_static_fast(model, data, t):
                raise self._diverged("no static equilibrium found", data, t, 0.0)
            tip[j] = data.site_xpos[self._tip_id]
            direction[j] = data.site_xmat[self._tip_id, 2::3]
            lengths[j] = data.ten_length[self._cable_ids]
        return Readings(tip, direction, lengths, t_all.copy())

    def reset_displacements(
        self: Any, displacements: np.ndarray, mask: np.ndarray | None = None
    ) -> None:
        """``Backend.reset_displacements`` by each robot's own drive solve (:meth:`_solve_drives`
        on its model: the shape its dynamics settle to under these commands, also where
        co-contracted tendons leave the shape under their tensions alone ambiguous); before the
        drives exist, or for a robot whose drive solve fails, through the tensions
        (``Backend``'s). Time 0, neutral friction slip; placed spheres stay."""
        self._check_open()
        if not self._drives:
            Backend.reset_displacements(self, displacements, mask)
            return
        d, rows = self._displacement_rows(displacements, mask)
        p = self.params
        k = np.asarray(p.cable_stiffness, dtype=float)
        t0 = np.asarray(p.cable_pretension, dtype=float)
        for i in rows.tolist():
            data, model = self._datas[i], self._models[i]
            spheres = data.mocap_pos.copy()
            self._mj.mj_resetData(model, data)
            data.mocap_pos[:] = spheres
            if not self._solve_drives(model, data, d[i]):
                one = np.zeros(p.n_cables * self.num_robots).reshape(self.num_robots, -1)
                one[i] = Backend.displacement_equilibrium(self, d[i : i + 1]).tensions[0]
                only = np.zeros(self.num_robots, dtype=bool)
                only[i] = True
                self.reset(one, only)
                continue
            shortening = self._straight - data.ten_length[self._cable_ids]
            t, _, _ = tendon_tensions(
                d[i : i + 1], shortening[None], k, t0, self.drive_max_tension, p.base_compliance
            )
            data.qvel[:] = 0.0
            data.time = 0.0
            self._tensions[i] = t[0]
            self.slip[i] = 0.0
            self._backbone_slip[i] = 0.0
            self.time[i] = 0.0
            self._sense(i)

    def displacement_equilibrium(
        self: Any, displacements: np.ndarray, tol: float = 1e-9, max_iter: int = 50
    ) -> Readings:
        """Readings of the static equilibrium under drive displacements ``displacements``
        (M, C) m of the nominal robot, without changing the state (``Backend``'s method: the
        same equilibrium, T = clip(T0 + k·(d − s), 0, max_tension) at the robot's own
        shortenings s). Once the drives are built (a displacement action mode builds them at
        construction) each row is one drive solve (:meth:`_solve_drives`: the drives' law and
        the statics at once); a row it cannot solve, and every row before the drives exist,
        goes through ``Backend``'s outer iteration on tension solves (``tol``, ``max_iter``
        are that iteration's). The tensions are the law at the settled tendon lengths.

        Raises:
            ValueError: naming ``displacements`` for a wrong shape or non-finite values.
        """
        self._check_open()
        p = self.params
        d = np.asarray(displacements, dtype=np.float64)
        if d.ndim != 2 or d.shape[1] != p.n_cables or not np.isfinite(d).all():
            raise ValueError(
                f"displacements must be finite with shape (M, {p.n_cables}), got {displacements!r}"
            )
        if not self._drives:
            return Backend.displacement_equilibrium(self, d, tol, max_iter)
        m = d.shape[0]
        tip, direction = np.empty((m, 3)), np.empty((m, 3))
        lengths = np.zeros((m, p.n_cables))
        data, model = self._scratch, self.model
        k = np.asarray(p.cable_stiffness, dtype=float)
        t0 = np.asarray(p.cable_pretension, dtype=float)
        failed = []
        for j, row in enumerate(d):
            if not self._solve_drives(model, data, row):
                failed.append(j)
                continue
            tip[j] = data.site_xpos[self._tip_id]
            direction[j] = data.site_xmat[self._tip_id, 2::3]
            lengths[j] = data.ten_length[self._cable_ids]
        tensions, _, _ = tendon_tensions(
            d, self._straight - lengths, k, t0, self.drive_max_tension, p.base_compliance
        )
        out = Readings(tip, direction, lengths, tensions)
        if failed:
            slow = Backend.displacement_equilibrium(self, d[failed], tol, max_iter)
            for name in ("tip", "tip_direction", "cable_lengths", "tensions"):
                getattr(out, name)[failed] = getattr(slow, name)
        return out
