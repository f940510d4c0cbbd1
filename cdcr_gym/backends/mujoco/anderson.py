"""Anderson-accelerated static solves of a MuJoCo robot (tension or drive commands).

The backend's plain static solve (``statics.py``) is the fixed point of the map

    G(q) = q ⊕ P·r(q),   r(q) = τ_actuator(q) + τ_passive(q) − τ_bias(q)   (N·m, (nv,))

(⊕ MuJoCo's position integration, P a preconditioner: K⁻¹, the joints' inverse stiffness).
Iterated plainly it converges at the rate of (cable and gravity load stiffness)/K — on the
30-disk FTDCR v4 robot ~0.95 per iteration, ~600 ``mj_forward`` calls per solve at the
1e-13 rad tolerance, and not at all where the rate exceeds 1. :func:`anderson_solve` iterates
the same map with Anderson (type-II) mixing of the last ``memory`` iterates: the same fixed
point (every iterate is scored by the same residual max|P·r| < ``tol``), in ~15–20 calls.

Coordinates: the iterate is x (nv,) rad in MuJoCo's tangent space at ``qpos0`` (the straight
pose): qpos = qpos0 ⊕ x (a ball joint's x is its rotation vector), so the mixing, a linear
combination of iterates, is taken of vectors, never of quaternions.

With displacement drives (``ctrl`` = d on the drives' actuators) the drives' stiffness
Jᵀ·diag(k)·J (J the cables' tendon Jacobian, only the taut drives) is of the order of the
joints' K: the plain map diverges, and :func:`drive_preconditioner` supplies
P = (K + Jᵀ·diag(k_taut)·J)⁻¹, a Newton step without the geometric (tension × curvature) and
gravity stiffness, which Anderson mixing then corrects.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_ANGLE
from cdcr_gym.backends.mujoco import friction as mj_friction

__all__ = ["anderson_solve", "drive_preconditioner", "MEMORY", "MAX_ITER"]

#: Iterates mixed (Anderson memory).
MEMORY = 10
#: Iterations before giving up (the caller then falls back to the relaxed plain iteration).
MAX_ITER = 300

#: P(data, r) → the step P·r (nv,) rad for the residual r (nv,) N·m at ``data``'s state (after
#: ``mj_forward``); it may overwrite r.
Preconditioner = Callable[[Any, np.ndarray], np.ndarray]


def anderson_solve(
    mj: Any,
    model: Any,
    data: Any,
    precondition: Preconditioner,
    x0: np.ndarray | None = None,
    tol: float = 1e-13,
    max_iter: int = MAX_ITER,
    memory: int = MEMORY,
) -> int:
    """Put ``data`` (whose ``ctrl`` holds the commands, ``qvel`` and ``act`` zero) at the fixed
    point of q ⊕ P·r(q) (module docstring), from qpos0 ⊕ ``x0`` (default: the straight pose).

    Returns the number of ``mj_forward`` calls on success (``data`` then holds the equilibrium
    with its position stage computed, as the plain solve leaves it: the last step integrated,
    then ``mj_forward``), or −1 if it did not converge to max|P·r| < ``tol`` rad within
    ``max_iter`` iterations or an iterate bent a joint beyond ``MAX_JOINT_ANGLE``.
    """
    nv = model.nv
    qpos0 = model.qpos0
    x = np.zeros(nv) if x0 is None else np.array(x0, dtype=float)
    xs: list[np.ndarray] = []
    fs: list[np.ndarray] = []
    trial = np.empty(model.nq)
    gx = np.empty(nv)
    for k in range(max_iter):
        data.qpos[:] = qpos0
        mj.mj_integratePos(model, data.qpos, x, 1.0)
        mj.mj_forward(model, data)
        step = precondition(
            data, np.subtract(data.qfrc_actuator + data.qfrc_passive, data.qfrc_bias)
        )
        size = float(np.max(np.abs(step)))
        if not size <= MAX_JOINT_ANGLE:  # NaN too
            return -1
        trial[:] = data.qpos
        mj.mj_integratePos(model, trial, step, 1.0)
        if size < tol:
            data.qpos[:] = trial
            mj.mj_forward(model, data)
            return k + 2
        mj.mj_differentiatePos(model, gx, 1.0, qpos0, trial)
        f = gx - x
        xs.append(x)
        fs.append(f)
        if len(xs) > memory + 1:
            del xs[0], fs[0]
        if len(xs) == 1:
            x = gx.copy()
            continue
        d_x = np.diff(np.asarray(xs), axis=0).T  # (nv, m)
        d_f = np.diff(np.asarray(fs), axis=0).T
        gamma = np.linalg.lstsq(d_f, f, rcond=None)[0]
        x = x + f - (d_x + d_f) @ gamma
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > 4.0 * MAX_JOINT_ANGLE:
            xs, fs = [], []  # a wild extrapolation: restart the mixing from the plain step
            x = gx.copy()
    return -1


def drive_preconditioner(
    stiffness: np.ndarray,
    jac_index: tuple[np.ndarray, np.ndarray, np.ndarray],
    cable_ids: np.ndarray,
    law: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float],
) -> Preconditioner:
    """P = (K + Jᵀ·diag(k_taut)·J)⁻¹ of the module docstring for a model with displacement
    drives: ``stiffness`` (nv,) K, ``jac_index`` the cables' rows of MuJoCo's sparse tendon
    Jacobian (``friction.jacobian_index``), ``cable_ids`` (C,) their tendon ids, ``law`` the
    drives' (d (C,) m, k (C,) N/m, T0 (C,) N, L0 (C,) m, max_tension N). A drive counts where
    its law T0 + k·(d − (L0 − L)) is strictly between 0 and max_tension at the current tendon
    length L (slack and saturated drives have no stiffness)."""
    n = len(cable_ids)
    d, k, t0, straight, t_max = law
    diag_k = np.diag(stiffness)

    def precondition(data: Any, residual: np.ndarray) -> np.ndarray:
        raw = t0 + k * (d - (straight - data.ten_length[cable_ids]))
        k_taut = np.where((raw > 0.0) & (raw < t_max), k, 0.0)
        jac = mj_friction.dense_tendon_jacobian(data, jac_index, n, stiffness.size)
        return np.linalg.solve(diag_k + jac.T @ (k_taut[:, None] * jac), residual)

    return precondition
