"""Cable tensions ↔ bending, by the elastic pure-moment model (SPEC §3).

A frictionless cable anchored at the tip disk and routed parallel to the backbone loads an
inextensible Euler–Bernoulli rod (no gravity) with a pure bending moment T·r about the axis
perpendicular to the cable's direction. Summed over the three cables, the curvature vector is

    (κx, κy) = (r / EI) · Σ_i T_i · (cos β_i, sin β_i),

constant along the rod, so the shape is an exact constant-curvature arc with κ = |(κx, κy)|,
φ = atan2(κy, κx) and θ = κℓ. A common-mode tension (equal on all three cables) adds
Σ u_i = 0 and does not bend. Units: N, m, rad. Functions broadcast over leading dimensions.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym.params import CABLE_ANGLES, RobotParams
from legacy.kinematics_v0 import _C2, _C3, _S2, _S3, _arc_from_bending, _max3, _maximum, _min3

__all__ = ["arc_from_tensions", "tensions_from_arc", "bending_limit", "CABLE_DIRECTIONS"]

#: Unit vectors u_i = (cos β_i, sin β_i) of the three cables, shape (3, 2).
CABLE_DIRECTIONS = np.stack([np.cos(CABLE_ANGLES), np.sin(CABLE_ANGLES)], axis=-1)


def _as_tensions(tensions: np.ndarray) -> np.ndarray:
    tensions = np.asarray(tensions, dtype=np.float64)
    if tensions.shape[-1:] != (3,):
        raise ValueError(f"tensions must have shape (..., 3), got shape {tensions.shape}")
    if not np.all(np.isfinite(tensions)):
        raise ValueError(f"tensions must be finite, got {tensions!r}")
    return tensions


# -- component kernels (floats or arrays; see cdcr_gym.kinematics) --------------------------------
# In terms of the bending vector w = θ·(cos φ, sin φ) (rad) the statics are linear:
# w = (r ℓ / EI)·Σ T_i u_i, and the minimal tensions holding w are
# (EI/(r ℓ))·(2/3)·(w·u_i − min_j w·u_j).


def _bending_from_tensions(t1, t2, t3, compliance):
    """Bending vector w (rad) under tensions (N); ``compliance`` = r ℓ / EI (rad/N)."""
    return (
        compliance * (t1 + t2 * _C2 + t3 * _C3),
        compliance * (t2 * _S2 + t3 * _S3),
    )


def _tensions_from_bending(wx, wy, stiffness):
    """Minimal non-negative tensions (T1, T2, T3) (N) holding the bending vector w (rad).

    ``stiffness`` = EI/(r ℓ) (N/rad). Σ_i T_i u_i = m has the particular solution
    T_i = (2/3)·m·u_i (since Σ u_i u_iᵀ = 3/2·I); subtracting the minimum leaves the cable opposite
    the bend slack (exactly zero) and loads the two cables that bracket φ.
    """
    k = (2.0 / 3.0) * stiffness
    p1 = k * wx
    p2 = k * (wx * _C2 + wy * _S2)
    p3 = k * (wx * _C3 + wy * _S3)
    low = _min3(p1, p2, p3)
    return p1 - low, p2 - low, p3 - low


def _workspace_scale(wx, wy, stiffness, max_tension):
    """Factor in (0, 1] that brings w radially onto the tension-reachable hexagon if outside.

    The minimal tensions are positively homogeneous in w, so w·s with
    s = T_max / max(max_i T_i(w), T_max) is θ clipped to θ_lim(φ) with φ kept (cf.
    :func:`bending_limit`, ``workspace.clip_to_workspace``).
    """
    t1, t2, t3 = _tensions_from_bending(wx, wy, stiffness)
    return max_tension / _maximum(_max3(t1, t2, t3), max_tension)


def arc_from_tensions(tensions: np.ndarray, params: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """Bending of the backbone under cable tensions.

    Args:
        tensions: cable tensions (T1, T2, T3), shape (..., 3), N. Negative values are treated
            as given (a cable cannot push; callers keep tensions >= 0).
        params: the robot.

    Returns:
        ``(theta, phi)``, each of shape (...): bending angle θ = κℓ (rad) and bending-plane angle
        (rad, towards the pulling cables; 0 when θ = 0).
    """
    tensions = _as_tensions(tensions)
    compliance = params.cable_radius * params.length / params.bending_stiffness
    wx, wy = _bending_from_tensions(
        tensions[..., 0], tensions[..., 1], tensions[..., 2], compliance
    )
    return _arc_from_bending(wx, wy)


def _minimal_tension_profile(phi: np.ndarray) -> np.ndarray:
    """Minimal non-negative tensions per unit bending moment magnitude, shape (..., 3).

    Σ_i T_i u_i = m has the particular solution T_i = (2/3)·m·u_i (since Σ u_i u_iᵀ = 3/2·I);
    adding c·(1, 1, 1) changes nothing, and the smallest non-negative choice subtracts the
    minimum, which leaves the cable opposite the bend slack (exactly zero) and loads the two
    cables that bracket φ.
    """
    phi = np.asarray(phi, dtype=np.float64)
    return np.stack(_tensions_from_bending(np.cos(phi), np.sin(phi), 1.0), axis=-1)


def tensions_from_arc(
    theta: np.ndarray,
    phi: np.ndarray,
    params: RobotParams,
    pretension: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Tension inverse kinematics: the smallest non-negative tensions that give (θ, φ).

    Args:
        theta: wanted bending angle, shape (...), rad (>= 0).
        phi: wanted bending-plane angle, shape (...), rad.
        params: the robot.
        pretension: common-mode tension added to all three cables (N, >= 0); it does not bend.

    Returns:
        ``(tensions, clipped)``: tensions of shape (..., 3) in N, clipped to
        [0, params.max_tension]; ``clipped`` (shape (...), bool) is True where clipping changed a
        tension, i.e. where the wanted shape is outside what the tension limit allows (see
        :func:`bending_limit`).
    """
    pretension = float(pretension)
    if not np.isfinite(pretension) or pretension < 0.0:
        raise ValueError(f"pretension must be finite and >= 0 N, got {pretension!r}")
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    stiffness = params.bending_stiffness / (params.cable_radius * params.length)  # N/rad
    tensions = (
        np.stack(
            _tensions_from_bending(theta * np.cos(phi), theta * np.sin(phi), stiffness), axis=-1
        )
        + pretension
    )
    clipped_tensions = np.clip(tensions, 0.0, params.max_tension)
    return clipped_tensions, np.any(clipped_tensions != tensions, axis=-1)


def bending_limit(phi: np.ndarray, params: RobotParams, pretension: float = 0.0) -> np.ndarray:
    """Largest bending angle θ (rad) reachable in plane φ with tensions in [0, max_tension].

    The reachable curvature vectors form a regular hexagon (the Minkowski sum of the three
    segments [0, T_max·u_i]): its vertices, at φ = 0°, 60°, …, are reached with one or two cables
    at T_max and bend by θ_max = T_max·r·ℓ/EI; mid-edge (φ = 30°, 90°, …) the limit is
    θ_max·cos 30°. A pretension p on all cables leaves T_max − p for bending.

    Args:
        phi: bending-plane angle, shape (...), rad.
        params: the robot.
        pretension: common-mode tension (N) in [0, max_tension).

    Returns:
        θ limit, shape (...), rad.
    """
    pretension = float(pretension)
    if not np.isfinite(pretension) or not 0.0 <= pretension < params.max_tension:
        raise ValueError(
            f"pretension must be in [0, max_tension={params.max_tension}) N, got {pretension!r}"
        )
    phi = np.asarray(phi, dtype=np.float64)
    # tension per unit moment of the most loaded cable (max of _minimal_tension_profile)
    profile_max = _max3(*_tensions_from_bending(np.cos(phi), np.sin(phi), 1.0))
    moment_max = (params.max_tension - pretension) / profile_max
    return moment_max * params.cable_radius * params.length / params.bending_stiffness
