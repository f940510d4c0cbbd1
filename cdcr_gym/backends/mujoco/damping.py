"""The joint damping of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`: D = β·K with
the β whose first bending mode, stepped by MuJoCo, has the stated ``damping_ratio``.

MuJoCo's ``Euler`` integrator (and ``implicitfast``, which the displacement drives use) treats
the joint damping implicitly and the joint springs explicitly: per mode
(1 + h·d)·ẋ⁺ = ẋ − h·k·x, x⁺ = x + h·ẋ⁺ (``cdcr_gym.backends.damping``, scheme
``"symplectic"``), which removes less energy than the continuous damper (ζ 0.62 instead of 0.7
at h = 20 ms on the paper robot). The first mode is taken with gravity (its stiffness at the
straight pose), which lowers ω₁ and raises ζ₁ by ω₁/ω₁g (up to 10 % on ``tdcr2``). RK4 is
taken as exact (no compensation) at the short timesteps it is stable at.

The step is stable for β·min(1, 1/2 + β·ω₁/2) >= h (``limits.StabilityLimits``): a stated ζ
below what the step delivers at that smallest β is refused, naming ``damping_ratio``, the
minimum at this timestep and the longest timestep dividing ``control_timestep`` that reaches it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.optimize

from cdcr_gym.backends.damping import damping_time, first_mode, minimum_damping_ratio
from cdcr_gym.model.discrete import bending_modes

__all__ = ["stable_beta", "scheme_of", "tune_damping", "stable_timestep", "gravity_stiffness"]


def stable_beta(h: float, omega1: float) -> float:
    """The smallest damping time β (s) accepted at timestep ``h`` s: β·min(1, 1/2 + β·ω₁/2) = h
    (``omega1``: ω₁ rad/s of the straight chain without gravity)."""
    f = lambda b: b * min(1.0, 0.5 + 0.5 * b * omega1) - h  # noqa: E731
    hi = 2.0 * h + 2.0 / omega1
    return float(scipy.optimize.brentq(f, 0.0, hi, xtol=1e-14))


def scheme_of(integrator: str) -> str:
    """The per-mode step (``cdcr_gym.backends.damping.SCHEMES``) of a MuJoCo integrator."""
    return "exact" if integrator == "RK4" else "symplectic"


def gravity_stiffness(mj: Any, model: Any, data: Any) -> np.ndarray | None:
    """−∂τ_gravity/∂q (nv, nv) N·m/rad at ``model``'s reference pose (straight chain), by
    central differences of ``qfrc_bias`` at rest; ``None`` without gravity."""
    if not np.any(model.opt.gravity):
        return None
    nv = model.nv
    q0 = np.array(model.qpos0)
    out = np.empty((nv, nv))
    eps = 1e-6

    def bias(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        data.qvel[:] = 0.0
        mj.mj_forward(model, data)
        return np.array(data.qfrc_bias)

    for i in range(nv):
        dv = np.zeros(nv)
        dv[i] = eps
        plus, minus = q0.copy(), q0.copy()
        mj.mj_integratePos(model, plus, dv, 1.0)
        mj.mj_integratePos(model, minus, -dv, 1.0)
        out[:, i] = (bias(plus) - bias(minus)) / (2.0 * eps)  # τ_gravity = −qfrc_bias
    mj.mj_resetData(model, data)
    return out


def _first_mode(backend: Any, model: Any) -> tuple[float, float, float, np.ndarray]:
    """(ω₁ rad/s of the straight chain without gravity, ω₁g² 1/s² and κ 1/s² of its first
    mode with ``model``'s gravity, joint stiffness K (nv,) N·m/rad) of ``model``."""
    mj, data = backend._mj, backend._scratch
    # the links' own inertia: without the armature (h·D with solid obstacles), exactly, so
    # that β does not depend on the model's previous damping (bit-identical re-seeding)
    armature = np.array(model.dof_armature)
    model.dof_armature[:] = 0.0
    try:
        mj.mj_resetData(model, data)
        mj.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mj.mj_fullM(model, data, mass)
        k = np.array(model.jnt_stiffness[model.dof_jntid])
        omega1, _ = bending_modes(mass, k)
        w2, kappa = first_mode(mass, k, gravity_stiffness(mj, model, data))
    finally:
        model.dof_armature[:] = armature
    return omega1, w2, kappa, k


def tune_damping(backend: Any, model: Any) -> float:
    """Set ``model.dof_damping`` = β·K for ``backend.damping_ratio`` (the β of the module
    docstring, from ``model``'s own stiffness, masses, gravity and timestep) and return β (s).

    Raises:
        ValueError: ``damping_ratio`` below what ``model``'s timestep delivers.
    """
    omega1, w2, kappa, k = _first_mode(backend, model)
    h = float(model.opt.timestep)
    scheme = scheme_of(backend.integrator)
    floor = 0.0 if scheme == "exact" else stable_beta(h, omega1)
    zeta = backend.damping_ratio
    try:
        beta = damping_time(zeta, w2, kappa, h, scheme, floor)
    except ValueError:
        raise ValueError(_too_low(backend, w2, kappa, omega1, h, scheme)) from None
    model.dof_damping[:] = beta * k
    return beta


def stable_timestep(backend: Any, model: Any) -> float:
    """The longest timestep h (s) at which ``model`` (its stiffness, masses, gravity) gets the
    stated ``damping_ratio`` from a stable β (>= :func:`stable_beta`), by bisection; for RK4,
    β = 2ζ/ω₁ and h <= min(2.5/(β·ω_max²), 2.5/ω_max)."""
    omega1, w2, kappa, _ = _first_mode(backend, model)
    zeta = backend.damping_ratio
    if backend.integrator == "RK4":
        beta = damping_time(zeta, w2, kappa, 1e-3, "exact")
        highest = backend._modes(model)[1]
        return min(2.5 / (beta * highest**2), 2.5 / highest)

    def ok(h: float) -> bool:
        low = minimum_damping_ratio(w2, kappa, h, "symplectic", stable_beta(h, omega1))
        return low <= zeta

    lo, hi = 0.0, 1.0
    if ok(hi):
        return hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _too_low(backend: Any, w2: float, kappa: float, omega1: float, h: float, scheme: str) -> str:
    """The refusal of a ``damping_ratio`` below the step's minimum, with a timestep that
    reaches it (the longest dividing ``control_timestep``)."""
    zeta = backend.damping_ratio
    low = minimum_damping_ratio(w2, kappa, h, scheme, stable_beta(h, omega1))
    dt = backend.control_timestep
    allow = None
    for n in range(1, 10001):
        hn = dt / n
        if minimum_damping_ratio(w2, kappa, hn, scheme, stable_beta(hn, omega1)) <= zeta:
            allow = hn
            break
    hint = (
        f"physics_timestep <= {allow:.4g} s (control_timestep / {round(dt / allow)})"
        if allow is not None
        else "a much shorter physics_timestep"
    )
    return (
        f"damping_ratio={zeta!r} is below the smallest damping ratio {low:.3g} that MuJoCo's "
        f"{backend.integrator} step delivers stably at physics_timestep={h!r} s for this "
        f"robot (first mode {math.sqrt(w2) / (2 * math.pi):.3g} Hz): use damping_ratio >= "
        f"{low:.3g} or {hint}"
    )
