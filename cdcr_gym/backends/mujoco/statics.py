"""The static equilibrium of a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`.

:class:`StaticSolve` (a base class of the backend; not used on its own) finds the shape the
dynamics settle to under given tensions — a relaxed fixed-point iteration on the joint
stiffness, in MuJoCo's generalized forces — for resets, goals and ``equilibrium``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_ANGLE, Readings
from cdcr_gym.backends.mujoco.drives import RELEASED

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

    def static_equilibrium(self: Any, tensions: np.ndarray, index: int = 0) -> np.ndarray:
        """Joint positions ``qpos`` of robot ``index``'s static equilibrium under ``tensions``
        (C,) N (MuJoCo's qpos layout: 4 per ball joint, 2 per Cardan joint).

        Raises:
            SimulationDivergedError: if no equilibrium is found.
        """
        t = self._check_tensions(tensions, 1)[0]
        data = self._scratch
        model = self._models[index]
        if not self._solve_static(model, data, t):
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
        t_all = self._check_tensions(tensions)
        m = t_all.shape[0]
        tip, direction = np.empty((m, 3)), np.empty((m, 3))
        lengths = np.empty((m, self.params.n_cables))
        data, model = self._scratch, self.model
        for j, t in enumerate(t_all):
            if not self._solve_static(model, data, t):
                raise self._diverged("no static equilibrium found", data, t, 0.0)
            tip[j] = data.site_xpos[self._tip_id]
            direction[j] = data.site_xmat[self._tip_id, 2::3]
            lengths[j] = data.ten_length[self._cable_ids]
        return Readings(tip, direction, lengths, t_all.copy())
