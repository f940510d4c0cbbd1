"""The joint damping of :class:`~cdcr_gym.backends.bullet.backend.BulletBackend`: D = β·K with
the β whose first bending mode, stepped by the backend's implicit integrator, has the stated
``damping_ratio``.

The integrator treats the joint springs and dampers by backward Euler (``integrator`` module
docstring): per mode (1 + h·d + h²·k)·ẋ⁺ = ẋ − h·k·x, x⁺ = x + h·ẋ⁺ (scheme ``"backward"`` of
``cdcr_gym.backends.damping``), which damps even with d = 0: ζ_num ≈ h·ω₁/2 (0.096 for the
paper robot at the default h = 10 ms). β is lowered to deliver the stated ζ in total; a ζ below
the step's own damping (β = 0) is refused, naming ``damping_ratio``, the minimum at this
timestep and the longest timestep dividing ``control_timestep`` that reaches it. The first mode
is taken with gravity's stiffness at the straight pose (it lowers ω₁, raising ζ₁ by ω₁/ω₁g).
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from cdcr_gym.backends.damping import damping_time, first_mode, minimum_damping_ratio
from cdcr_gym.model.discrete import DiscreteBackbone

__all__ = ["gravity_stiffness", "tuned_damping_time", "backend_damping_time"]


def gravity_stiffness(chain: DiscreteBackbone) -> np.ndarray:
    """−∂τ_gravity/∂q (2n, 2n) N·m/rad of ``chain`` (with gravity, whatever its flag) at the
    straight pose, by central differences of ``DiscreteBackbone.gravity_loads``."""
    heavy = copy.copy(chain)
    heavy.gravity = True
    n = chain.n_dof
    out = np.empty((n, n))
    eps = 1e-6
    for i in range(n):
        dq = np.zeros(n)
        dq[i] = eps
        out[:, i] = -(heavy.gravity_loads(dq) - heavy.gravity_loads(-dq)) / (2.0 * eps)
    return out


def tuned_damping_time(
    damping_ratio: float,
    mass: np.ndarray,
    stiffness: np.ndarray,
    gravity: np.ndarray | None,
    physics_timestep: float,
    control_timestep: float,
) -> float:
    """β (s) such that the first mode of M (2n, 2n) kg·m², K (2n,) N·m/rad and the gravity
    stiffness ``gravity`` (2n, 2n) or ``None``, stepped by backward Euler with
    ``physics_timestep`` s, has ``damping_ratio``.

    Raises:
        ValueError: naming ``damping_ratio``, if it is below the step's own damping.
    """
    w2, kappa = first_mode(mass, stiffness, gravity)
    h = physics_timestep
    try:
        return damping_time(damping_ratio, w2, kappa, h, "backward")
    except ValueError:
        pass
    low = minimum_damping_ratio(w2, kappa, h, "backward")
    allow = next(
        (
            control_timestep / n
            for n in range(1, 10001)
            if minimum_damping_ratio(w2, kappa, control_timestep / n, "backward") <= damping_ratio
        ),
        None,
    )
    hint = (
        f"physics_timestep <= {allow:.4g} s (control_timestep / {round(control_timestep / allow)})"
        if allow is not None
        else "a much shorter physics_timestep"
    )
    raise ValueError(
        f"damping_ratio={damping_ratio!r} is below the damping ratio {low:.3g} that the "
        f"implicit (backward-Euler) step adds by itself at physics_timestep={h!r} s for this "
        f"robot (first mode {math.sqrt(w2) / (2 * math.pi):.3g} Hz): use damping_ratio >= "
        f"{low:.3g} or {hint}"
    )


def backend_damping_time(backend: Any) -> float:
    """:func:`tuned_damping_time` of a ``BulletBackend`` (its mass matrix at the straight pose,
    current joint stiffness, gravity and timesteps)."""
    return tuned_damping_time(
        backend.damping_ratio,
        backend._mass0,
        backend.chain.stiffness,
        backend._gravity_stiffness if backend.gravity else None,
        backend.physics_timestep,
        backend.control_timestep,
    )
