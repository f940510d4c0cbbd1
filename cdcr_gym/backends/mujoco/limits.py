"""What a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend` can simulate stably.

:class:`StabilityLimits` (a base class of the backend; not used on its own) computes the longest
stable physics timestep from the chain's bending modes and refuses, at construction or when the
env is made, timesteps and randomisation ranges the backend cannot run, naming the argument; at
every step it checks the state and raises ``SimulationDivergedError`` saying what diverged.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from cdcr_gym.backends.base import MAX_JOINT_ANGLE, MAX_JOINT_RATE, SimulationDivergedError
from cdcr_gym.backends.mujoco.damping import stable_timestep
from cdcr_gym.model.discrete import bending_modes
from cdcr_gym.model.statics import check_tip_payload

__all__ = ["StabilityLimits"]


class StabilityLimits:
    """The stability checks of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`."""

    def stable_timestep(self: Any, model: Any = None) -> float:
        """The longest ``physics_timestep`` (s) accepted for ``model`` (default: the nominal
        one): with D = β·K the Euler step is linearly stable for h < 2β in every mode (damping
        implicit, stiffness explicit); the cables' load (a follower force) and the joints'
        nonlinearity take part of that, most at low ζ, so h <= β·min(1, 1/2 + β·ω₁/2) is
        accepted (measured: bang-bang extreme tensions for 400 steps stay stable there on the
        paper robot, ball and Cardan joints, ζ from 0.01 to 1.5; they diverge near 2β). β is
        the one that delivers ``damping_ratio`` at h (``damping.tune_damping``), so this is
        the longest h whose β passes. RK4 treats the damping explicitly: h <= 2.5/(β·ω_max²)
        and 2.5/ω_max."""
        return stable_timestep(self, self.model if model is None else model)

    def _modes(self: Any, model: Any) -> tuple[float, float]:
        """ω₁ and ω_max (rad/s) of ``model``'s straight chain (its stiffness and masses)."""
        mj, data = self._mj, self._scratch
        mj.mj_resetData(model, data)
        mj.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mj.mj_fullM(model, data, mass)
        mass[np.diag_indices(model.nv)] -= model.dof_armature  # the links' own inertia
        return bending_modes(mass, model.jnt_stiffness[model.dof_jntid])

    def _check_timestep(self: Any, model: Any, context: str) -> None:
        """Refuse a physics timestep beyond :meth:`stable_timestep` of ``model``, naming the
        arguments (``context``: the randomised robot it is about, if any)."""
        limit = self.stable_timestep(model)
        if self.physics_timestep <= limit:
            return
        raise ValueError(
            f"physics_timestep={self.physics_timestep!r} s is too long for "
            f"damping_ratio={self.damping_ratio!r} with integrator={self.integrator!r}"
            f"{context}: the step diverges; stable up to {limit:.3g} s (see "
            f"MuJoCoBackend.stable_timestep): use a physics_timestep <= {limit:.3g} s that "
            f"divides control_timestep={self.control_timestep!r} s, or "
            + ("integrator='Euler'" if self.integrator == "RK4" else "a larger damping_ratio")
        )

    def check_randomization(self: Any, ranges: dict[str, tuple[float, float]]) -> None:
        """Refuse, when the env is made, ``randomize`` ranges (name → (low, high)) whose
        extreme robots this backend cannot simulate: the heaviest ``tip_payload`` on the
        softest robot must be held under gravity (``check_tip_payload``, as the constructor's
        ``tip_payload``), and the stiffest, lightest robot (highest ``youngs_modulus``, lowest
        payload) must be stable at ``physics_timestep`` (:meth:`stable_timestep`).

        Raises:
            ValueError: naming ``randomize[<name>]``, the range and the reason.
        """
        e0 = self.params.youngs_modulus
        e_low, e_high = ranges.get("youngs_modulus", (e0, e0))
        p_low, p_high = ranges.get("tip_payload", (self.tip_payload, self.tip_payload))
        gravity = self.gravity or ranges.get("gravity", (0.0, 0.0))[1] > 0.0
        named = " and ".join(
            f"randomize[{k!r}]={list(ranges[k])}"
            for k in ("youngs_modulus", "tip_payload")
            if k in ranges
        )
        if not named:
            return

        def robot(youngs: float, payload: float) -> Any:
            model = copy.copy(self.model)
            model.jnt_stiffness[:] = self._nominal_stiffness * (youngs / e0)
            self._set_payload(model, payload)
            model.opt.gravity[:] = self.gravity_in_base if gravity else 0.0
            return model

        if "tip_payload" in ranges or "youngs_modulus" in ranges:
            heavy = robot(e_low, p_high)
            try:
                check_tip_payload(
                    p_high,
                    self.params,
                    gravity,
                    lambda t: self._solve_static(heavy, self._scratch, t, relaxations=(1.0,)),
                )
            except ValueError as exc:
                raise ValueError(
                    f"{named}: at the range's extreme (youngs_modulus={e_low!r} Pa, "
                    f"tip_payload={p_high!r} kg): {exc}; narrow the range"
                ) from None
        stiff = robot(e_high, p_low)
        self._check_timestep(
            stiff,
            f" and {named} (the stiffest robot: youngs_modulus={e_high!r} Pa, "
            f"tip_payload={p_low!r} kg)",
        )

    def _check_state(self: Any, i: int) -> None:
        """Raise :class:`SimulationDivergedError` if robot i's state is non-finite, a joint is
        bent beyond ``MAX_JOINT_ANGLE``, the joint-rate vector is longer than
        ``MAX_JOINT_RATE``, a cable's length is beyond every shape's (a section bent past 180°:
        |l_i − L_i| > π r_i m_i, the observation's bound), or MuJoCo reported a bad
        acceleration (it then resets the data)."""
        qpos, qvel, warning = self._views[i][:3]
        rate2 = qvel.dot(qvel)  # NaN fails the comparisons below
        lengths = self._views[i][5][self._cable_ids]
        if (
            warning.number > 0
            or not rate2 <= MAX_JOINT_RATE * MAX_JOINT_RATE
            or not self._max_joint_angle(qpos) <= MAX_JOINT_ANGLE
            or not np.all(np.abs(lengths - self._run_lengths) <= self._length_reach)
        ):
            data = self._datas[i]
            if warning.number > 0:
                why = "MuJoCo reported a bad acceleration"
            elif not rate2 <= MAX_JOINT_RATE * MAX_JOINT_RATE:
                why = f"a joint turns faster than {MAX_JOINT_RATE:g} rad/s"
            elif not self._max_joint_angle(qpos) <= MAX_JOINT_ANGLE:
                why = f"a joint is bent beyond {math.degrees(MAX_JOINT_ANGLE):g}°"
            else:
                why = "a section is bent past 180° (a cable length beyond every shape's)"
            raise self._diverged(
                f"the simulation diverged: {why}", data, self._tensions[i], float(self.time[i])
            )

    def _max_joint_angle(self: Any, q: np.ndarray) -> float:
        """Largest joint angle (rad) of joint positions ``q``: the ball joints' rotation angles,
        the hinges' angles (inf for a non-finite state); a cheap bound first (sum of squares)."""
        if self.joint == "ball":
            w = q[0::4]
            # Σ sin²(angle/2) = n − Σ w² <= 1/2 bounds every angle by 90°
            if self.n_links - w.dot(w) <= 0.5:
                return 0.0
            w_min = float(np.abs(w).min())
            return 2.0 * math.acos(min(w_min, 1.0)) if math.isfinite(w_min) else math.inf
        if q.dot(q) <= MAX_JOINT_ANGLE * MAX_JOINT_ANGLE:
            return 0.0
        return float(np.abs(q).max())

    def _diverged(
        self: Any, message: str, data: Any, tensions: np.ndarray, time: float
    ) -> SimulationDivergedError:
        state = {
            "joint_positions": np.array(data.qpos),
            "joint_velocities": np.array(data.qvel),
            "tensions": np.array(tensions),
            "time": time,
        }
        return SimulationDivergedError(
            f"{message} (t = {time:.4f} s, tensions {np.asarray(tensions).tolist()} N, "
            f"max |q̇| = {np.max(np.abs(data.qvel))} rad/s)",
            state,
        )
