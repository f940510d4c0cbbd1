"""Joint damping that delivers the stated damping ratio ζ of the first bending mode.

Both physics backends damp the joints in proportion to their stiffness, D = β·K (Kelvin–Voigt
material damping of the rod). In continuous time a mode v with M·v̈ + D·v̇ + (K + K_g)·v = 0
(K_g: gravity's stiffness) has ω² = vᵀ(K + K_g)v / vᵀMv and damping ratio
ζ = β·κ / (2ω) with κ = vᵀKv / vᵀMv; without gravity κ = ω² and ζ = β·ω/2, so the higher modes
get ζ_k = ζ₁·ω_k/ω₁ (stiffness-proportional damping).

The time steppers change that: a mode of one step of length h maps (x, ẋ) to z·(x, ẋ), and the
decay one measures on the released tip is that of z, not of the continuous equation. For a mode
with (mass-normalised) stiffness k = ω² and damping d = β·κ:

* **backward Euler** (``"backward"``: bullet's implicit spring–damper step),
  (1 + h·d + h²·k)·ẋ⁺ = ẋ − h·k·x, x⁺ = x + h·ẋ⁺: z solves
  (1 + h·d + h²·k)·z² − (2 + h·d)·z + 1 = 0, |z|² = 1/(1 + h·d + h²·k). Even with d = 0 it
  decays: the numerical damping ζ_num ≈ h·ω/2 (0.096 for the paper robot at h = 10 ms).
  Gravity's stiffness is explicit there (only the joint springs' κ is in the h²·k term).
* **semi-implicit Euler with implicit damping** (``"symplectic"``: MuJoCo's ``Euler`` and
  ``implicitfast`` for joint damping), (1 + h·d)·ẋ⁺ = ẋ − h·k·x, x⁺ = x + h·ẋ⁺: z solves
  (1 + h·d)·z² − (2 + h·d − h²·k)·z + 1 = 0, |z|² = 1/(1 + h·d). The stiffness step adds no
  damping, but the damping step removes less than d (ln(1 + h·d)/h < d): ζ falls short
  (0.64 instead of 0.7 for the paper robot at h = 20 ms).
* ``"exact"``: the continuous equation (RK4 at the accepted timesteps).

The equivalent continuous mode of the two roots z₁, z₂ (s_i = ln z_i / h) is ω² = s₁·s₂,
2ζω = −(s₁ + s₂), which is what a fit of a damped sinusoid (or, over-damped, of two
exponentials) to the sampled decay returns. :func:`damping_time` inverts it: the β whose
stepped first mode has the stated ζ; a ζ below what the step allows (at β = its smallest
accepted value) is refused, naming ``damping_ratio``, the minimum and a timestep that reaches it.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import scipy.linalg
import scipy.optimize

__all__ = [
    "SCHEMES",
    "stepped_mode",
    "first_mode",
    "damping_time",
    "minimum_damping_ratio",
]

SCHEMES = ("backward", "symplectic", "exact")


def stepped_mode(
    k: float, d: float, h: float, scheme: str, k_implicit: float | None = None
) -> tuple[float, float]:
    """(ω rad/s, ζ) of the equivalent continuous mode of one scalar mode (unit mass,
    stiffness ``k`` 1/s², damping ``d`` 1/s) stepped with ``h`` s by ``scheme``
    (:data:`SCHEMES`); ζ = inf if the step diverges or flips sign every step.

    ``k_implicit``: the part of ``k`` that ``"backward"`` treats implicitly (the joint springs;
    default all of it); the rest (gravity, cables) is explicit, evaluated at the step's start:
    (1 + h·d + h²·k_i)·ẋ⁺ = ẋ − h·k·x, so z solves a·z² − (a + 1 − h²·k)·z + 1 = 0 with
    a = 1 + h·d + h²·k_i."""
    if scheme == "exact":
        w = math.sqrt(k)
        return w, d / (2.0 * w)
    if scheme == "backward":
        a = 1.0 + h * d + h * h * (k if k_implicit is None else k_implicit)
        b, c = -(a + 1.0 - h * h * k), 1.0
    elif scheme == "symplectic":
        a, b, c = 1.0 + h * d, -(2.0 + h * d - h * h * k), 1.0
    else:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    disc = cmath.sqrt(b * b - 4.0 * a * c)
    z1, z2 = (-b + disc) / (2.0 * a), (-b - disc) / (2.0 * a)
    if max(abs(z1), abs(z2)) > 1.0 + 1e-12 or (z1.real <= 0.0 and abs(z1.imag) < 1e-15):
        return math.nan, math.inf
    if z2.real <= 0.0 and abs(z2.imag) < 1e-15:
        return math.nan, math.inf
    s1, s2 = cmath.log(z1) / h, cmath.log(z2) / h
    w = math.sqrt(max((s1 * s2).real, 0.0))
    return w, -(s1 + s2).real / (2.0 * w)


def first_mode(
    mass: np.ndarray, stiffness: np.ndarray, gravity_stiffness: np.ndarray | None = None
) -> tuple[float, float]:
    """(ω₁² 1/s², κ 1/s²) of the first mode of M·v̈ + (K + K_g)·v = 0: ω₁² = vᵀ(K + K_g)v/vᵀMv
    and κ = vᵀKv/vᵀMv (the share of the joint stiffness K, which sets the damping D = β·K).

    ``mass`` (n, n) kg·m², ``stiffness`` (n,) N·m/rad (diagonal K), ``gravity_stiffness``
    (n, n) N·m/rad (−∂τ_gravity/∂q, symmetrised here; ``None``: no gravity). If gravity makes
    the straight pose unstable (a payload that bends the robot over), the straight-pose modes
    say nothing about the bent robot's: gravity is then left out."""
    k = np.diag(np.asarray(stiffness, float))
    total = k if gravity_stiffness is None else k + 0.5 * (gravity_stiffness + gravity_stiffness.T)
    w2, v = scipy.linalg.eigh(total, mass)
    if w2[0] <= 0.0:
        w2, v = scipy.linalg.eigh(k, mass)
    vec = v[:, 0]
    modal_mass = float(vec @ mass @ vec)
    return float(w2[0]), float(vec @ k @ vec) / modal_mass


def _zeta(beta: float, w2: float, kappa: float, h: float, scheme: str) -> float:
    # backward Euler: the joint springs (κ) implicit, gravity's share (ω₁² − κ) explicit
    return stepped_mode(w2, beta * kappa, h, scheme, kappa)[1]


def minimum_damping_ratio(
    w2: float, kappa: float, h: float, scheme: str, min_beta: float = 0.0
) -> float:
    """The smallest ζ of the stepped first mode (ω₁² = ``w2``, κ = ``kappa``, see
    :func:`first_mode`) for a damping time β >= ``min_beta`` s (the stability floor)."""
    return _zeta(min_beta, w2, kappa, h, scheme)


def damping_time(
    zeta: float,
    w2: float,
    kappa: float,
    h: float,
    scheme: str,
    min_beta: float = 0.0,
) -> float:
    """The damping time β (s), D = β·K, whose first mode stepped by ``scheme`` with ``h`` s
    has the damping ratio ``zeta`` (ω₁² = ``w2`` and κ = ``kappa`` from :func:`first_mode`).

    Raises:
        ValueError: if ``zeta`` is below :func:`minimum_damping_ratio` (β >= ``min_beta``);
            the message names ``damping_ratio``, the value and the minimum at ``h``.
    """
    low = _zeta(min_beta, w2, kappa, h, scheme)
    if zeta < low:
        raise ValueError(
            f"damping_ratio={zeta!r} is below the smallest damping ratio "
            f"{low:.3g} the physics step of {h!r} s delivers for this robot's first mode"
        )
    hi = max(2.0 * zeta / math.sqrt(w2), min_beta, 1e-6) * 2.0
    while _zeta(hi, w2, kappa, h, scheme) < zeta:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError(f"damping_ratio={zeta!r} cannot be reached at h = {h!r} s")
    if zeta == low:
        return min_beta
    return float(
        scipy.optimize.brentq(
            lambda b: _zeta(b, w2, kappa, h, scheme) - zeta, min_beta, hi, xtol=1e-12, rtol=1e-12
        )
    )
