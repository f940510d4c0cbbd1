"""The physics step of the pybullet backend: cable loads as generalized forces, implicit joint
springs and dampers, and the divergence check.

Implicit spring–damper integration
    pybullet has no joint springs. The default motors are switched off and every physics step
    applies a joint torque. The joints are stiff against the light links (the paper's robot, 9
    links: highest mode ω_max ≈ 3 600 rad/s, the half tip link with its disk; an explicit
    spring would need h < 2/ω_max ≈ 0.55 ms, explicit damping less), so stiffness and damping
    are treated by backward Euler: with M = ``calculateMassMatrix(q)`` and b(q, q̇) =
    ``calculateInverseDynamics(q, q̇, 0)`` (gravity + Coriolis; pybullet evaluates it as if the
    base were upright, so for a turned base gravity is set to its R0 components for that call),
    (M + hD + h²K)·Δq̇ = h·(τ_cable − b − K·q − (D + hK)·q̇),   q̇⁺ = q̇ + Δq̇,
    and the torque sent to pybullet is τ = τ_cable − K·(q + h·q̇⁺) − D·q̇⁺. pybullet's own
    semi-implicit Euler step (q̇⁺ = q̇ + h·M⁻¹(τ − b), q⁺ = q + h·q̇⁺) then reproduces the
    backward-Euler update exactly, which is unconditionally stable for the linear spring and
    damper. Cable and gravity loads stay explicit: their stiffness (the cables' ≈ ΣT·Δ/4 per
    joint, ≤ 4.3 N·m/rad at 3 × 80 N on the paper's robot; gravity's ≲ 0.4 N·m/rad) is a
    fraction of K = EI/Δ = 15.1 N·m/rad, which keeps the step stable (checked to h = 0.1 s)
    as long as the disk spans do not buckle (``cdcr_gym.model.discrete.check_span_buckling``).
    A state at rest is a fixed point of the update iff K·q = τ_cable(q) − b(q, 0): the settled
    state is the static solution, independent of h.

Cable–disk friction
    With ``friction_coefficient`` μ > 0 each cable's segments carry the capstan profile of
    ``cdcr_gym.model.friction``: T_k = T_act·exp(−s·μ·Σ_{j≤k} α_j), with the wrap angles α_j at
    the current pinholes (the base disk's from the base axis, where the cable arrives from the
    actuator) and the cable's slip state s ∈ [−1, 1] (+1 pulled, −1 released), which follows
    the cable's sliding by the Dahl-type law ``friction.update_slip`` over the slip length x_s:
    the sliding is the change of the cable's length inside the robot since the previous
    physics step (shortening = sliding towards the base). The segment tensions load the
    backbone span by span (``DiscreteBackbone.cable_loads`` with per-span tensions), evaluated
    at the start of the step. In stick the slip law is a stiff spring along the cable: s moves
    by (1 − s·σ)/x_s per metre slid (x_s = 0.1 mm by default), so the loads change by
    G·Δq with G = Σ_i (∂τ/∂s_i)·(ds_i/dx)·(∂l_i/∂q) (≈ μ·α·T/x_s along the cable). That
    stiffness is treated implicitly, like K: (M + hD + h²(K + G))·Δq̇ = h·(τ − b − Kq −
    (D + hK + hG)·q̇), with the slope of the direction the cable slides in *this* step (a
    first solve without G; ``_implicit_velocity``). Explicit, it made the slip state flip
    every physics step (a limit cycle: after loading cable 1 of the paper robot to 80 N in
    10 N steps with μ = 0.2 the tip kept oscillating by 0.3 mm, each control step ending at a
    random point of the cycle, bending further than without friction); with the previous
    step's direction, a reversing cable (unloading 70 N after 80 N) chattered by 1.7 mm. s has memory, so a settled robot keeps the
    profile of its last motion: load–unload cycles open a hysteresis loop. With μ = 0 none of
    this runs (bit-identical to the frictionless model).

Damping
    Per-joint, stiffness-proportional (Kelvin–Voigt material damping of the rod): D = β·K with
    β ≈ 2ζ/ω₁, where ω₁ is the first bending mode of the linearised chain at the straight pose
    (generalized eigenproblem K·v = ω²·M·v) and ζ = ``damping_ratio``; the backend corrects β
    for gravity and for this step's own damping (``damping.py``), so that the first mode as
    stepped has ζ. Higher modes are over-damped and relax at ≈ 1/β = ω₁/(2ζ).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from types import ModuleType

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_ANGLE, MAX_JOINT_RATE
from cdcr_gym.model import friction
from cdcr_gym.model.discrete import DiscreteBackbone
from cdcr_gym.model.params import STANDARD_GRAVITY

__all__ = ["ImplicitIntegrator"]


class ImplicitIntegrator:
    """Advances one pybullet multibody by backward-Euler joint springs and dampers.

    Args:
        pb, client, body: the pybullet module, client id and multibody.
        chain: the discretised model (cable loads, stiffness K).
        physics_timestep: h (s).
        damping_time: β (s), D = β·K.
        gravity_in_base: gravity (m/s²) in R0 components for pybullet's inverse dynamics when
            the base is turned and gravity is on; ``None`` for an upright base or no gravity.
        friction_coefficient: cable–disk μ >= 0 (0: frictionless, the plain path).
        slip_length: x_s (m, > 0) of the slip law (module docstring).
    """

    def __init__(
        self,
        pb: ModuleType,
        client: int,
        body: int,
        chain: DiscreteBackbone,
        physics_timestep: float,
        damping_time: float,
        gravity_in_base: tuple[float, float, float] | None,
        friction_coefficient: float = 0.0,
        slip_length: float = 1e-4,
    ) -> None:
        self._pb, self._client, self._body = pb, client, body
        self.chain = chain
        self.n_dof = n2 = chain.n_dof
        self.joint_ids = list(range(n2))
        self._zeros = [0.0] * n2
        self.h = h = physics_timestep
        self.K = chain.stiffness.copy()
        self.D = damping_time * self.K
        self._A_diag = h * self.D + h * h * self.K
        self._D_plus_hK = self.D + h * self.K
        self._gravity_in_base = gravity_in_base
        self._q: np.ndarray | None = None
        self._qd: np.ndarray | None = None
        self.friction_coefficient = friction_coefficient
        self.slip_length = slip_length
        #: Slip state s (C,) of every cable (+1 pulled, −1 released, between: stick).
        self.slip = np.zeros(chain.params.n_cables)
        self._last_lengths: np.ndarray | None = None
        #: Sliding (C,) m of each cable in its last step that moved (its sign: the direction).
        self._last_sliding = np.zeros_like(self.slip)
        self._entry = np.ascontiguousarray(chain.base_rotation[:, 2])

    def set_stiffness(self, stiffness: np.ndarray, damping_time: float) -> None:
        """New joint stiffness K (2n,) N·m/rad and damping time β (s), D = β·K (randomised
        parameters; the pybullet body is unchanged)."""
        h = self.h
        self.K = stiffness.copy()
        self.D = damping_time * self.K
        self._A_diag = h * self.D + h * h * self.K
        self._D_plus_hK = self.D + h * self.K

    def set_gravity_in_base(self, gravity_in_base: tuple[float, float, float] | None) -> None:
        """See the constructor's ``gravity_in_base`` (gravity switched on or off)."""
        self._gravity_in_base = gravity_in_base

    # -- friction --------------------------------------------------------------------------------
    def reset_friction(self) -> None:
        """Neutral slip state (s = 0) and no sliding history: after a reset to rest."""
        self.slip = np.zeros_like(self.slip)
        self._last_lengths = None
        self._last_sliding = np.zeros_like(self.slip)

    def segment_tensions(self, q: np.ndarray, tensions: np.ndarray) -> np.ndarray:
        """Tensions (n_disks, C) N of every cable's segment k (row k: from disk k to k + 1)
        at joint angles ``q`` for actuator ``tensions`` (C,) N and the current slip state."""
        _, pins = self.chain.stations_and_pinholes(q)
        wraps = friction.wrap_angles(pins.transpose(1, 0, 2), self._entry)  # (C, n_disks)
        return friction.tension_profile(tensions, wraps, self.friction_coefficient, self.slip).T

    def _friction_loads(
        self, q: np.ndarray, tensions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cable loads τ (2n,) N·m and lengths (C,) m with the capstan profile at the current
        slip, and the factors of the slip law's stiffness: ∂τ/∂s_i (C, 2n) and ∂l_i/∂q (C, 2n).

        In stick the Dahl law makes the friction a stiff spring in the cable's sliding
        coordinate: s moves by a = (1 − s·σ)/x_s per metre slid (σ the sliding direction), and
        the segment tensions T_k = T·e^(−s·μ·A_k) (A_k the wrap accumulated up to segment k)
        move with s. Linearised over one step, τ(q + Δq, s + Δs) ≈ τ − G·Δq with
        G = Σ_i (∂τ/∂s_i)·a_i·(∂l_i/∂q) (sliding x = −Δl). Treated explicitly, this stiffness
        (≈ μ·α·T/x_s along the cable) makes the step flip the slip state back and forth (a
        limit cycle); :meth:`_implicit_velocity` adds G to the backward-Euler system like K.
        """
        chain = self.chain
        _, pins = chain.stations_and_pinholes(q)
        wraps = friction.wrap_angles(pins.transpose(1, 0, 2), self._entry)  # (C, n_disks)
        seg_t = friction.tension_profile(tensions, wraps, self.friction_coefficient, self.slip).T
        tau, lengths = chain.cable_loads(q, seg_t)
        dtds = -self.friction_coefficient * np.cumsum(wraps, axis=-1).T * seg_t  # (n_disks, C)
        n_cables = tensions.shape[0]
        dtau_ds = np.zeros((n_cables, q.size))
        dl_dq = np.zeros((n_cables, q.size))
        for i in range(n_cables):
            if tensions[i] == 0.0:
                continue
            unit = np.zeros((chain.n_disks, n_cables))
            unit[:, i] = 1.0
            dl_dq[i] = -chain.cable_loads(q, unit)[0]  # τ of a unit tension is −∂l/∂q
            only = np.zeros_like(dtds)
            only[:, i] = dtds[:, i]
            dtau_ds[i] = chain.cable_loads(q, only)[0]
        return tau, lengths, dtau_ds, dl_dq

    def _implicit_velocity(
        self,
        mass: np.ndarray,
        rhs: np.ndarray,
        qd: np.ndarray,
        dtau_ds: np.ndarray,
        dl_dq: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """q̇⁺ (2n,) and the slip stiffness G (2n, 2n) of a step with the slip law implicit.

        The Dahl law's slope a = (1 − s·σ)/x_s depends on the direction σ in which the cable
        slides *during this step*: 0 for a cable sliding on in its saturated direction, 2/x_s
        for one reversing. σ is that of the step without G (for a cable that does not move:
        the last sliding); a cable whose implicit step slides against it is at the law's kink
        and takes the larger slope (1 + |s|)/x_s (a stiffer spring only damps). (Taking σ from
        the *previous* step, as before, left a reversing cable explicit: unloading from 80 N
        to 70 N chattered by 1.7 mm per 20 control steps.)
        """
        h = self.h
        qd_free = qd + np.linalg.solve(mass, h * rhs)
        free = -h * (dl_dq @ qd_free)
        sigma = np.where(free != 0.0, np.sign(free), np.sign(self._last_sliding))
        s = self.slip
        slope = np.where(sigma != 0.0, 1.0 - s * sigma, 1.0 + np.abs(s)) / self.slip_length
        for _ in range(2):
            stiffness = dtau_ds.T @ (slope[:, None] * dl_dq)
            qd_new = qd + np.linalg.solve(
                mass + (h * h) * stiffness, h * (rhs - h * (stiffness @ qd))
            )
            kink = sigma * (-h * (dl_dq @ qd_new)) < 0.0
            if not kink.any():
                break
            slope = np.where(kink, (1.0 + np.abs(s)) / self.slip_length, slope)
        return qd_new, stiffness

    def _slide(self, lengths: np.ndarray) -> None:
        """Advance the slip state by the sliding since the last call (lengths (C,) m)."""
        if self._last_lengths is not None:
            sliding = self._last_lengths - lengths
            self.slip = friction.update_slip(self.slip, sliding, self.slip_length)
            self._last_sliding = np.where(sliding != 0.0, sliding, self._last_sliding)
        self._last_lengths = lengths

    # -- state -----------------------------------------------------------------------------------
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles q (2n,) rad and rates q̇ (2n,) rad/s from pybullet (cached until a change)."""
        if self._q is None:
            js = self._pb.getJointStates(self._body, self.joint_ids, physicsClientId=self._client)
            n = self.n_dof
            self._q = np.fromiter((s[0] for s in js), np.float64, n)
            self._qd = np.fromiter((s[1] for s in js), np.float64, n)
        assert self._qd is not None
        return self._q, self._qd

    def set_state(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Set q (2n,) rad and q̇ (2n,) rad/s in pybullet."""
        self._pb.resetJointStatesMultiDof(
            self._body,
            self.joint_ids,
            [[float(v)] for v in q],
            targetVelocities=[[float(v)] for v in qd],
            physicsClientId=self._client,
        )
        self.invalidate()

    def invalidate(self) -> None:
        """Drop the cached state (after any change of the pybullet state)."""
        self._q = self._qd = None

    # -- loads -----------------------------------------------------------------------------------
    def bias(self, q_list: list, qd_list: list) -> np.ndarray:
        """b(q, q̇) = C(q, q̇)·q̇ + g(q): the joint torques (N·m) for zero acceleration.

        pybullet's ``calculateInverseDynamics`` works in the base frame and applies the world
        gravity vector there as if the base were upright (pybullet 3.2.7). For a turned base we
        therefore set gravity to its base-frame components R0ᵀ·g around the call (a test checks
        the result against the chain model's gravity loads).
        """
        pb, cid = self._pb, self._client
        if self._gravity_in_base is None:
            return np.array(
                pb.calculateInverseDynamics(
                    self._body, q_list, qd_list, self._zeros, physicsClientId=cid
                )
            )
        pb.setGravity(*self._gravity_in_base, physicsClientId=cid)
        try:
            return np.array(
                pb.calculateInverseDynamics(
                    self._body, q_list, qd_list, self._zeros, physicsClientId=cid
                )
            )
        finally:
            pb.setGravity(0.0, 0.0, -STANDARD_GRAVITY, physicsClientId=cid)

    def gravity_bias(self, q: np.ndarray) -> np.ndarray:
        """b(q, 0): the joint torques that hold the chain still against gravity (N·m)."""
        return self.bias(q.tolist(), self._zeros)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix M(q) (2n, 2n) from pybullet."""
        return np.asarray(
            self._pb.calculateMassMatrix(self._body, q.tolist(), physicsClientId=self._client)
        )

    # -- stepping --------------------------------------------------------------------------------
    def advance(
        self, tensions: np.ndarray, n_steps: int, on_step: Callable[[], None]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Hold ``tensions`` (C,) N for ``n_steps`` physics steps; the final (q, q̇).

        Each step: read q, q̇; τ_cable(q); M(q) and b(q, q̇) from pybullet; solve the
        backward-Euler system for q̇⁺; send τ = τ_cable − K(q + h q̇⁺) − D q̇⁺; step.
        ``on_step`` is called after every step (the backend drops its cached geometry and
        advances its clock). The caller checks the result with :meth:`finite_and_bounded`.
        """
        pb, cid, body, ids = self._pb, self._client, self._body, self.joint_ids
        h, n2 = self.h, self.n_dof
        K, D, D_plus_hK = self.K, self.D, self._D_plus_hK
        torque_mode = pb.TORQUE_CONTROL
        cable_loads = self.chain.cable_loads
        rough = self.friction_coefficient > 0.0
        for _ in range(n_steps):
            q, qd = self.state()
            ql = q.tolist()
            friction_stiffness = None
            if rough:
                tau_c, lengths, dtau_ds, dl_dq = self._friction_loads(q, tensions)
                self._slide(lengths)
            else:
                tau_c, _ = cable_loads(q, tensions)
            # M(q) comes as 2n tuples of 2n floats: fromiter over the flattened rows is the
            # cheapest conversion
            rows = pb.calculateMassMatrix(body, ql, physicsClientId=cid)
            mass = np.fromiter(itertools.chain.from_iterable(rows), np.float64, n2 * n2).reshape(
                n2, n2
            )
            bias = self.bias(ql, qd.tolist())
            mass.reshape(-1)[:: n2 + 1] += self._A_diag  # the diagonal (a view): M + hD + h²K
            rhs = tau_c - bias - K * q - D_plus_hK * qd
            if rough:  # the slip's stick stiffness, implicit
                qd_new, friction_stiffness = self._implicit_velocity(mass, rhs, qd, dtau_ds, dl_dq)
            else:
                qd_new = qd + np.linalg.solve(mass, h * rhs)
            torque = tau_c - K * (q + h * qd_new) - D * qd_new
            if friction_stiffness is not None:
                torque -= h * (friction_stiffness @ qd_new)
            # TORQUE_CONTROL torques accumulate until the next step: exactly one call per step
            pb.setJointMotorControlArray(
                body, ids, torque_mode, forces=torque.tolist(), physicsClientId=cid
            )
            pb.stepSimulation(physicsClientId=cid)
            self.invalidate()
            on_step()
        return self.state()

    def cable_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """J = ∂l/∂q (C, 2n) m/rad of the cable lengths at joint angles ``q`` (the loads of a
        unit tension are −J_iᵀ, ``DiscreteBackbone.cable_loads``) and the lengths (C,) m."""
        n_cables = self.slip.shape[0]
        jac = np.empty((n_cables, q.size))
        unit = np.zeros(n_cables)
        lengths = np.empty(0)
        for i in range(n_cables):
            unit[i] = 1.0
            tau, lengths = self.chain.cable_loads(q, unit)
            jac[i] = -tau
            unit[i] = 0.0
        return jac, lengths

    def advance_displacements(
        self,
        displacements: np.ndarray,
        drive: tuple[np.ndarray, np.ndarray, float, np.ndarray],
        n_steps: int,
        on_step: Callable[[], None],
    ) -> tuple[np.ndarray, np.ndarray]:
        """Hold tendon ``displacements`` d (C,) m at compliant drives for ``n_steps`` physics
        steps (frictionless); the final (q, q̇).

        ``drive`` = (k (C,) N/m, T0 (C,) N, max_tension N, L0 (C,) m, the straight lengths):
        each tendon pulls with T = clip(T0 + k·(d − (L0 − l(q))), 0, max_tension). The drives'
        stiffness is implicit like K: linearised over the step, T⁺ = T_c + h·k_a·J·q̇⁺ with
        k_a = k on the tendons inside their linear range at the *end* of the step (else 0,
        and T_c their clamp value 0 or max_tension), so (M + hD + h²(K + Jᵀk_aJ))·Δq̇ =
        h·(−JᵀT_c − b − Kq − (D + hK + hJᵀk_aJ)·q̇). The active set is that of the predicted
        end state: from the start state's, re-solved while a prediction leaves its assumed
        set (a clamped tendon is then tried linear first; at most 2C + 2 solves): a tendon
        that goes slack within the step carries nothing, one that saturates is held at the
        limit, so a stiff drive (k up to 10⁵ N/m and more) is stable at any h.
        """
        pb, cid, body, ids = self._pb, self._client, self._body, self.joint_ids
        h, n2 = self.h, self.n_dof
        K, D, D_plus_hK = self.K, self.D, self._D_plus_hK
        k, t0, t_max, straight = drive
        torque_mode = pb.TORQUE_CONTROL
        for _ in range(n_steps):
            q, qd = self.state()
            ql = q.tolist()
            jac, lengths = self.cable_jacobian(q)
            raw = t0 + k * (displacements - (straight - lengths))
            rows = pb.calculateMassMatrix(body, ql, physicsClientId=cid)
            mass = np.fromiter(itertools.chain.from_iterable(rows), np.float64, n2 * n2).reshape(
                n2, n2
            )
            bias = self.bias(ql, qd.tolist())
            mass.reshape(-1)[:: n2 + 1] += self._A_diag
            base = -bias - K * q - D_plus_hK * qd
            rate = jac @ qd  # l̇ at the start
            # each tendon's assumed end state: 0 slack, 1 linear, 2 saturated
            state = np.where(raw <= 0.0, 0, np.where(raw < t_max, 1, 2))
            for _ in range(2 * raw.size + 2):
                active = state == 1
                k_a = np.where(active, k, 0.0)
                t_c = np.where(active, raw, np.where(state == 0, 0.0, t_max))
                stiff = jac.T @ (k_a[:, None] * jac)
                rhs = base - jac.T @ t_c - h * (jac.T @ (k_a * rate))
                qd_new = qd + np.linalg.solve(mass + (h * h) * stiff, h * rhs)
                level = raw + h * k * (jac @ qd_new)
                ends = np.where(level <= 0.0, 0, np.where(level < t_max, 1, 2))
                if np.array_equal(ends, state):
                    break
                # a clamped tendon predicted elsewhere is tried linear first (else the
                # slack/saturated guesses can alternate when the whole range lies within
                # one step's travel of a stiff drive)
                state = np.where((ends != state) & (state != 1), 1, ends)
            tensions = t_c + h * k_a * (jac @ qd_new)
            torque = -jac.T @ tensions - K * (q + h * qd_new) - D * qd_new
            pb.setJointMotorControlArray(
                body, ids, torque_mode, forces=torque.tolist(), physicsClientId=cid
            )
            pb.stepSimulation(physicsClientId=cid)
            self.invalidate()
            on_step()
        return self.state()

    @staticmethod
    def finite_and_bounded(q: np.ndarray, qd: np.ndarray) -> bool:
        """Whether every joint angle is within ``MAX_JOINT_ANGLE`` and rate within
        ``MAX_JOINT_RATE`` (NaN fails every comparison, so non-finite states fail too)."""
        return bool(np.max(np.abs(q)) <= MAX_JOINT_ANGLE and np.max(np.abs(qd)) <= MAX_JOINT_RATE)
