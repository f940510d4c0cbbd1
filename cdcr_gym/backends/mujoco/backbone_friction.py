"""Backbone friction of a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`: a Coulomb
moment against the bending of every joint.

A real backbone does not bend freely: tendons pressed into their pinholes, disks on the rod and
the rod in its clamp rub, so a robot released from a bend stays a little bent towards where it
came from (hysteresis that does not need the tendons to carry load, unlike the capstan
friction of the cables, :mod:`cdcr_gym.backends.mujoco.friction`). Each joint degree of freedom
gets a friction moment of magnitude ``backbone_friction`` M_f (N·m):

    τ_f = −M_f·z,

with a slip state z ∈ [−1, 1] per degree of freedom that follows the joint's rotation Δq (rad)
over each physics step by the displacement-regularised (Dahl-type) law of the capstan friction
(:func:`cdcr_gym.model.friction.update_slip`, solved exactly per step): z relaxes towards the sign
of Δq over a slip angle q_s. A joint that reverses keeps its moment until it has turned ≈ q_s
back (stick), then slides with |τ_f| = M_f. q_s = M_f / k_j (k_j the joint's bending
stiffness): the stick band is as stiff as the joint itself. In the quasi-static limit a joint
held by its own spring alone comes to rest within ≈ M_f/k_j of its frictionless equilibrium (a
section's curvature within ≈ M_f/EI of it); taut tendons, which stiffen the robot, narrow that
band.

The moment is applied explicitly (``qfrc_applied``, renewed before every physics step), so the
stick band adds the stiffness k_j to the explicit joint spring: the step is stable while
h·2k_j/d_j < 1.8 (h the physics timestep, d_j the joint damping; the damping is implicit), which
:meth:`BackboneFriction.set_backbone_friction` checks. Static solves (``equilibrium``,
``displacement_equilibrium``: goals, resets) are frictionless; friction acts in ``apply_*``.
Robots stepped with backbone friction are stepped one by one (not by ``mujoco.rollout``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import validation

__all__ = ["BackboneFriction", "STABILITY"]

#: Largest h·(k_j + k_stick)/d_j accepted (the explicit spring with implicit damping is stable
#: below 2).
STABILITY = 1.8


class BackboneFriction:
    """The backbone-friction part of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`
    (a base class of the backend; not used on its own)."""

    #: M_f (N,) N·m of every robot (0: none).
    _backbone_torque: np.ndarray
    #: z (N, nv): the slip state of every joint degree of freedom of every robot.
    _backbone_slip: np.ndarray

    def _init_backbone_friction(self: Any, torque: float) -> None:
        """Every robot's M_f = ``torque`` N·m (validated), slip states at rest."""
        self._backbone_torque = np.zeros(self.num_robots)
        self._backbone_slip = np.zeros((self.num_robots, self.model.nv))
        if torque:
            self.set_backbone_friction(np.arange(self.num_robots), np.full(self.num_robots, torque))

    @property
    def backbone_friction(self: Any) -> float:
        """The backbone friction moment M_f (N·m) of robot 0."""
        return float(self._backbone_torque[0])

    def set_backbone_friction(self: Any, index: Any, torque: Any) -> None:
        """Give robots ``index`` (n,) the backbone friction moment ``torque`` (n,) N·m ≥ 0.

        Raises:
            ValueError: naming ``backbone_friction`` for a negative or non-finite moment, or
                one whose stick band would make a robot's step unstable (module docstring:
                lower ``physics_timestep`` or raise ``damping_ratio``).
        """
        idx = np.asarray(index, dtype=int).reshape(-1)
        m_f = validation.real_array(torque, "backbone_friction", (idx.size,))
        if np.any(m_f < 0.0):
            raise ValueError(f"backbone_friction must be >= 0 N·m, got {m_f.tolist()}")
        for j, i in enumerate(idx.tolist()):
            if m_f[j] > 0.0:
                model = self._models[i]
                k = np.asarray(model.jnt_stiffness[model.dof_jntid], dtype=float)
                d = np.asarray(model.dof_damping, dtype=float)
                worst = float(np.max(2.0 * model.opt.timestep * k / np.maximum(d, 1e-300)))
                if worst >= STABILITY:
                    raise ValueError(
                        f"backbone_friction={float(m_f[j])!r} N·m: the friction's stick band "
                        f"makes the step unstable (h·2k/d = {worst:.2f} >= {STABILITY} at "
                        f"physics_timestep={self.physics_timestep!r} s); lower "
                        f"physics_timestep or raise damping_ratio"
                    )
            else:
                self._datas[i].qfrc_applied[:] = 0.0
        self._backbone_torque[idx] = m_f
        self._backbone_slip[idx] = 0.0

    def _backbone_rough(self: Any) -> bool:
        """Whether any robot has backbone friction (then robots are stepped one by one)."""
        return bool(np.any(self._backbone_torque > 0.0))

    def _advance_with_backbone_friction(
        self: Any, model: Any, data: Any, n_steps: int, i: int
    ) -> None:
        """``n_steps`` MuJoCo steps of robot ``i`` with its backbone friction (module
        docstring), leaving ``data`` as :meth:`_advance` does (``mj_step1`` of the new state)."""
        mj = self._mj
        m_f = float(self._backbone_torque[i])
        z = self._backbone_slip[i]
        k = np.asarray(model.jnt_stiffness[model.dof_jntid], dtype=float)
        slip_angle = m_f / np.maximum(k, 1e-300)
        h = model.opt.timestep
        for step in range(n_steps):
            data.qfrc_applied[:] = -m_f * z
            if step == 0 and self._splittable:
                mj.mj_step2(model, data)
            else:
                mj.mj_step(model, data)
            dq = data.qvel * h
            # exact Dahl step (model.friction.update_slip): z → sign(dq) over the slip angle
            decay = np.exp(-np.abs(dq) / slip_angle)
            z[:] = np.where(dq >= 0.0, 1.0 - (1.0 - z) * decay, -1.0 + (1.0 + z) * decay)
        mj.mj_step1(model, data)
