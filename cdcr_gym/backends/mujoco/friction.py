"""Cable–disk friction on the MuJoCo backend: the slip state implicit in the physics step.

The capstan model is ``cdcr_gym.model.friction`` (one model for both backends): segment k of a
cable carries T_k = T·exp(−s·μ·A_k) (A_k the wrap accumulated up to segment k, s the cable's
slip state, Dahl law ``friction.update_slip`` over the slip length x_s). In stick the Dahl law is
a stiff spring along the cable: s moves by a = (1 − s·σ)/x_s per metre slid (σ the sliding
direction), so the loads change by g·Δs with g = ∂τ/∂s = Σ_k J_kᵀ·μ·A_k·T_k (J_k the segment
tendon's Jacobian; a tension x on a tendon loads the joints by −J_kᵀ·x) — ≈ μ·A·T/x_s along the
cable, ≈ 3·10⁵ N/m at 80 N. Evaluated explicitly at the start of MuJoCo's 20 ms step this spring
overshoots every step: the slip state cycles between pulling and releasing (issue 21 item 4).

So s is taken **backward Euler**, consistently with MuJoCo's Euler step (which treats joint
damping implicitly: (M + h·D)·Δv = h·f). Within one step the positions are fixed and v⁺ is
affine in the generalized force, so the sliding of the step loaded at a slip state s⁺ is exact
to first order in h·v:

    x(s⁺) = −h·J_L·v⁺ = x_free + R·(T(s⁺) − T(s)),   R = h²·J_L·(M + h·D)⁻¹·J_segᵀ,

(x_free: the step at the current s, J_L the whole cable's Jacobian, J_seg the segment tendons';
a tension on a tendon loads the joints by −Jᵀ·T), and the step is taken at the root of

    s⁺ = update_slip(s, x(s⁺))

(the exact Dahl update over the step's own sliding; a safeguarded Newton iteration, a few
iterations per step; each cable's residual is monotone in its s⁺ and brackets a root in
[−1, 1]). s⁺ becomes the state, so the slip reported (and the anchor tension read) is the one
that loaded the step. At rest x = 0 and s⁺ = s: a settled robot keeps its profile (stick), a
fixed point with the capstan statics at that s. (With ``integrator="implicitfast"`` or
``"RK4"``, or contacts with obstacles, R is an approximation of the step's response — the
fixed point is the same.) The previous explicit rule (s advanced by the
previous step's length change, the loads at that s) overshot every step from 50 N up.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym.model import friction

__all__ = ["jacobian_index", "dense_tendon_jacobian", "implicit_slip_step"]


def jacobian_index(model: Any, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where rows ``ids`` of the tendon Jacobian sit in MuJoCo's sparse ``ten_J`` (CSR, the
    structure in the model): (row, column, index into ``data.ten_J``) of every non-zero."""
    rows, cols, src = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0, int)]
    for r, tid in enumerate(np.asarray(ids).ravel()):
        adr, nnz = int(model.ten_J_rowadr[tid]), int(model.ten_J_rownnz[tid])
        rows.append(np.full(nnz, r))
        cols.append(model.ten_J_colind[adr : adr + nnz])
        src.append(np.arange(adr, adr + nnz))
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(src)


def dense_tendon_jacobian(
    data: Any, index: tuple[np.ndarray, np.ndarray, np.ndarray], n_rows: int, nv: int
) -> np.ndarray:
    """Rows (n_rows, nv) of the tendon Jacobian at ``data``'s state (``jacobian_index``)."""
    out = np.zeros((n_rows, nv))
    rows, cols, src = index
    out[rows, cols] = data.ten_J[src]
    return out


def implicit_slip_step(
    mj: Any,
    model: Any,
    data: Any,
    *,
    tensions: np.ndarray,
    slip: np.ndarray,
    mu: float,
    slip_length: float,
    wraps: np.ndarray,
    cable_ids: np.ndarray,
    segment_ids: np.ndarray,
    segment_order: list[tuple[int, int]],
    cable_index: tuple[np.ndarray, np.ndarray, np.ndarray],
    segment_index: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> np.ndarray:
    """The slip state (C,) at the end of robot ``data``'s next step (backward Euler in s).

    ``data`` holds the position and velocity stages of the current state (``mj_step1``);
    ``wraps`` (C, n_disks) rad are the current wrap angles, ``segment_ids`` (n_disks, C) the
    segment tendon ids (−1 where a cable does not cross a span), ``segment_order`` the (span,
    cable) of each friction actuator after the C pull actuators (``mjcf``); the ctrl of the
    pull actuators (or the displacement drives, ``mjcf``) must apply ``tensions``. Leaves the friction actuators' ctrl at the returned
    slip state, ready for ``mj_step2``; ``cable_index`` and ``segment_index`` are the
    :func:`jacobian_index` of ``cable_ids`` and of the routed ``segment_ids`` (row-major).
    Solves ``s⁺ = update_slip(s, x(s⁺))`` with x(s⁺) the sliding of the step loaded at s⁺
    (module docstring) by Newton's method in x, on the side the free step slides.
    """
    h = model.opt.timestep
    n_pull = len(cable_ids)

    def set_segments(s: np.ndarray) -> None:
        seg = friction.tension_profile(tensions, wraps, mu, s).T  # (n_disks, C)
        data.ctrl[n_pull : n_pull + len(segment_order)] = [
            seg[k, c] - tensions[c] for k, c in segment_order
        ]

    set_segments(slip)
    mj.mj_fwdActuation(model, data)
    mj.mj_fwdAcceleration(model, data)
    mj.mj_fwdConstraint(model, data)
    mass = np.zeros((model.nv, model.nv))
    mj.mj_fullM(model, data, mass)
    if model.opt.disableflags & mj.mjtDisableBit.mjDSBL_EULERDAMP:
        system = mass  # h·D is in the mass matrix (armature): Δv = h·qacc
    else:
        system = mass + np.diag(h * model.dof_damping)  # Euler: (M + hD)·Δv = h·M·qacc
    nv = model.nv
    j_l = dense_tendon_jacobian(data, cable_index, len(cable_ids), nv)  # (C, nv)
    free = -h * (j_l @ (data.qvel + h * np.linalg.solve(system, mass @ data.qacc)))
    routed = segment_ids >= 0  # (n_disks, C)
    j_seg = dense_tendon_jacobian(data, segment_index, int(routed.sum()), nv)  # (n_seg, nv)
    # sliding per newton of extra tension in each segment: x = −h·J_L·h·A⁻¹·(−J_segᵀ·ΔT)
    per_tension = h * h * (j_l @ np.linalg.solve(system, j_seg.T))  # (C, n_seg)
    reach = np.cumsum(wraps, axis=-1).T[routed]  # A_k of each routed segment (n_seg,)
    cable = np.nonzero(routed)[1]  # the cable of each routed segment
    t0 = friction.tension_profile(tensions, wraps, mu, slip).T[routed]

    n_cables = len(slip)
    # The root in the sliding x (C,): r(x) = x − x_free − R·(T(s⁺(x)) − T(s)) rises with x
    # (a higher s⁺ lowers the tensions, which lengthens the cable) and r(0) = −x_free, so x
    # slides the way the free step does; on that side s⁺(x) is smooth: Newton from x = 0.
    sigma = np.sign(free)
    x = np.zeros(n_cables)
    for _ in range(50):
        decay = np.exp(-np.abs(x) / slip_length)
        s_new = sigma + (slip - sigma) * decay
        t_seg = tensions[cable] * np.exp(-s_new[cable] * mu * reach)
        res = x - free - per_tension @ (t_seg - t0)
        ds_dx = (1.0 - slip * sigma) * decay / slip_length
        dx_ds = np.zeros((n_cables, n_cables))  # ∂x_i/∂s⁺_j through cable j's tensions
        np.add.at(dx_ds.T, cable, (per_tension * (-mu * reach * t_seg)).T)
        step = np.linalg.solve(np.eye(n_cables) - dx_ds * ds_dx[None, :], -res)
        x_next = x + step
        x_next = np.where(sigma * x_next < 0.0, 0.0, x_next)  # stay on the free step's side
        done = np.max(np.abs(x_next - x)) < 1e-15
        x = x_next
        if done:
            break
    s = friction.update_slip(slip, x, slip_length)
    set_segments(s)
    return s


class CapstanFriction:
    """The capstan-friction stepping of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`
    (a base class of the backend; not used on its own): robots with μ > 0 are stepped physics
    step by physics step with :func:`implicit_slip_step`."""

    def _step_with_friction(
        self: Any, t: np.ndarray, displacements: np.ndarray | None = None
    ) -> None:
        """Physics step by physics step: the slip state at the end of the step (backward Euler
        in s, ``backends/mujoco/friction.py``), the capstan segment tensions at the current wrap
        angles and that slip state, then one MuJoCo step. With ``displacements`` (N, C) m the
        drives pull (the motors hold 0) and the actuator tensions ``t`` are the drives' law at
        the current tendon lengths, renewed before every physics step."""
        if not self._has_segments:
            raise RuntimeError("internal: friction without segment tendons")
        n_pull = self._n_pull
        n_seg = len(self._segment_order)
        for _ in range(self.n_substeps):
            for i, (model, data) in enumerate(zip(self._models, self._datas)):
                if displacements is None:
                    data.ctrl[:n_pull] = t[i]
                else:
                    t[i] = self._drive_law(displacements[i], self._lengths[i], i)[0]
                if self._mu[i] > 0.0:
                    self.slip[i] = implicit_slip_step(
                        self._mj,
                        model,
                        data,
                        tensions=t[i],
                        slip=self.slip[i],
                        mu=float(self._mu[i]),
                        slip_length=self.friction_slip_length,
                        wraps=self._wraps(i),
                        cable_ids=self._cable_ids,
                        segment_ids=self._segment_ids,
                        segment_order=self._segment_order,
                        cable_index=self._jac_index[0],
                        segment_index=self._jac_index[1],
                    )
                else:
                    data.ctrl[n_pull : n_pull + n_seg] = 0.0
                self._advance(model, data, 1, i)
                self._sense(i)

    def _wraps(self: Any, i: int) -> np.ndarray:
        """Wrap angles (C, n_disks) rad of robot i's cables at its current pinholes."""
        pins = self._datas[i].site_xpos[self._pin_ids]  # (n_disks + 1, C, 3)
        return friction.wrap_angles(pins.transpose(1, 0, 2))  # entry +z of R0

    def _segment_tensions(self: Any, i: int, t: np.ndarray) -> np.ndarray:
        """Capstan tensions (n_disks, C) N of robot i's cable segments (row k: disk k → k+1)
        at its current pinholes and slip state."""
        return friction.tension_profile(t, self._wraps(i), self._mu[i], self.slip[i]).T

    @property
    def anchor_tensions(self: Any) -> np.ndarray:
        """Tension (N, C) N in each cable's last segment (= the actuator's without friction)."""
        out = self._tensions.copy()
        for i in range(self.num_robots):
            if self._mu[i] > 0.0:
                seg = self._segment_tensions(i, self._tensions[i])
                out[i] = seg[self._last_span, np.arange(self.params.n_cables)]
        return out
