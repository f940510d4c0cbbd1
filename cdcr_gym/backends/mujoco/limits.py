"""What a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend` can simulate stably.

:class:`StabilityLimits` (a base class of the backend; not used on its own) computes the longest
stable physics timestep from the chain's bending modes and refuses, at construction or when the
env is made, timesteps and randomisation ranges the backend cannot run, naming the argument.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from cdcr_gym.model.discrete import bending_modes
from cdcr_gym.model.statics import check_tip_payload

__all__ = ["StabilityLimits"]


class StabilityLimits:
    """The stability checks of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`."""

    def stable_timestep(self: Any, model: Any = None) -> float:
        """The longest ``physics_timestep`` (s) accepted for ``model`` (default: the nominal
        one): with D = β·K (β = 2ζ/ω₁) the Euler step is linearly stable for h < 2β in every
        mode (damping implicit, stiffness explicit); the cables' load (a follower force) and
        the joints' nonlinearity take part of that, most at low ζ, so h <= β·min(1, 1/2 + ζ)
        is accepted (measured: bang-bang extreme tensions for 400 steps stay stable there on
        the paper robot, ball and Cardan joints, ζ from 0.01 to 1.5; they diverge near 2β).
        RK4 treats the damping explicitly: h <= 2.5/(β·ω_max²) and 2.5/ω_max."""
        model = self.model if model is None else model
        first, highest = self._modes(model)
        beta = 2.0 * self.damping_ratio / first
        if self.integrator == "RK4":
            return min(2.5 / (beta * highest**2), 2.5 / highest)
        return beta * min(1.0, 0.5 + self.damping_ratio)

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
