"""One constant-curvature section (CCKA, docs/model.md): arc ↔ cable lengths, tip pose, backbone points.

Pure numpy; imports no simulator and no Gymnasium. Every function broadcasts over leading batch
dimensions: an argument of shape (..., 3) or (...) gives results with the same leading shape.
All arrays are float64.

Conventions (SI units):
    * Base frame R0 at the base disk centre, backbone along +Z0, cable 1 at +X0.
    * Cable i sits at angle β_i (0°, 120°, 240°) about +Z0 at distance r from the backbone axis.
    * Arc parameters: bending angle θ in [0, π] (rad), bending-plane angle φ (rad, measured from
      +X0 about +Z0; the tip moves towards φ), curvature κ = θ/ℓ (1/m).
    * At θ = 0 (straight robot) φ is undefined; we return φ = 0 by convention.

Corrections to the paper (see README): eq. 2 uses tan⁻¹ of a ratio, which loses the quadrant;
we use atan2. Eq. 5's Z line reads (r·L_sum/L_sqr)·sin(2L_sqr/3r), but it must be
(r·L_sum/(2·L_sqr))·sin(2L_sqr/3r) = sin θ/κ: with equal cable lengths the printed form gives
Z = 2ℓ = 1.282 m instead of ℓ = 0.641 m.

The 0/0 forms at θ = 0 are evaluated by :func:`arc_profile`, exact and finite there. Internally
the shape is the *bending vector* w = θ·(cos φ, sin φ) (rad), in which the cable lengths
(l_i = ℓ − r·w·u_i, u_i = (cos β_i, sin β_i)) and the tension statics are linear and nothing is
singular at θ = 0 (``cdcr_gym.model.chain`` uses it for any number of sections).

Input contract: non-finite arguments, negative cable lengths, non-positive lengths or radii and
bending angles outside [0, π] raise ``ValueError`` naming the argument.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "arc_profile",
    "arc_from_lengths",
    "lengths_from_arc",
    "tip_from_arc",
    "forward_kinematics",
    "inverse_kinematics",
    "arc_from_tip",
    "tip_rotation",
    "tip_pose",
    "backbone_points",
    "bending_from_arc",
    "arc_from_bending",
]

_SQRT3 = math.sqrt(3.0)
# cos β_i, sin β_i of the paper's cables at 0°, 120°, 240°, exact (np.cos(2π/3) differs in the last
# bits), so that the three-fold symmetry holds exactly.
_COS_BETA = (1.0, -0.5, -0.5)
_SIN_BETA = (0.0, 0.5 * _SQRT3, -0.5 * _SQRT3)


# -- validation --------------------------------------------------------------------------------


def check_positive(name: str, value: float, what: str) -> float:
    """``value`` as a float, or ``ValueError`` naming ``name`` unless finite and > 0."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} ({what}) must be a finite number > 0, got {value!r}") from None
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} ({what}) must be finite and > 0, got {value!r}")
    return value


def as_finite(name: str, value, last: int | None = None) -> np.ndarray:
    """``value`` as a float64 array, finite, with last axis ``last`` if given; else ValueError."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real array, got {value!r}") from None
    if last is not None and arr.shape[-1:] != (last,):
        raise ValueError(f"{name} must have shape (..., {last}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return arr


def _as_theta(theta) -> np.ndarray:
    theta = as_finite("theta", theta)
    if np.any(theta < 0.0) or np.any(theta > np.pi):
        raise ValueError(
            f"theta (bending angle) must lie in [0, π] rad, got values in "
            f"[{np.min(theta)!r}, {np.max(theta)!r}]"
        )
    return theta


def _as_lengths(lengths) -> np.ndarray:
    lengths = as_finite("lengths", lengths, 3)
    if np.any(lengths < 0.0):
        raise ValueError(f"lengths (cable lengths) must be >= 0 m, got {lengths!r}")
    return lengths


def _stack3(x, y, z) -> np.ndarray:
    """Stack three broadcast-compatible components into a (..., 3) float64 array."""
    out = np.empty(np.broadcast_shapes(np.shape(x), np.shape(y), np.shape(z)) + (3,))
    out[..., 0] = x
    out[..., 1] = y
    out[..., 2] = z
    return out


# -- the arc profile -----------------------------------------------------------------------------


def arc_profile(theta) -> tuple[np.ndarray, np.ndarray]:
    """(f, g) = ((1 − cos θ)/θ², sin θ/θ), exact and finite at θ = 0 (values 1/2, 1); even in θ.

    From t = tan(θ/4): sin(θ/2) = 2t/(1+t²) and cos(θ/2) = (1−t²)/(1+t²), so with
    q = sin(θ/2)/(θ/2) = (t/(θ/4))/(1+t²): sin θ/θ = q·cos(θ/2) and (1 − cos θ)/θ² = q²/2.
    One tangent and no cancellation near θ = 0. Meant for |θ| <= π (any shape, rad).
    """
    return profile_nonnegative(np.abs(np.asarray(theta, dtype=np.float64)))


def profile_nonnegative(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`arc_profile` for θ >= 0 (float64 array, any shape), with the fewest numpy calls."""
    x = 0.25 * theta
    safe = np.maximum(x, 1e-20)  # tan(1e-20)/1e-20 == 1.0 exactly: exact at θ = 0
    p = np.tan(safe)
    p /= safe  # tan(θ/4)/(θ/4)
    t = p * x
    t *= t  # tan²(θ/4)
    den = t + 1.0
    p /= den  # q = sin(θ/2)/(θ/2)
    g = 1.0 - t
    g *= p
    g /= den
    f = p * p
    f *= 0.5
    return f, g


def bending_from_arc(theta, phi) -> np.ndarray:
    """Bending vector w = θ·(cos φ, sin φ) (rad), shape (..., 2), from θ, φ (rad, broadcast)."""
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    return np.stack(np.broadcast_arrays(theta * np.cos(phi), theta * np.sin(phi)), axis=-1)


def arc_from_bending(w) -> tuple[np.ndarray, np.ndarray]:
    """(θ, φ) (rad), each (...), of bending vectors w (..., 2); φ = 0 where θ = 0."""
    w = np.asarray(w, dtype=np.float64)
    wx, wy = w[..., 0], w[..., 1]
    theta = np.sqrt(wx * wx + wy * wy)
    phi = np.where(theta == 0.0, 0.0, np.arctan2(wy, wx)) + 0.0  # + 0.0 turns −0.0 into 0.0
    return theta, phi


def _bending_from_lengths(l1, l2, l3, r):
    """(wx, wy) (rad) from the cable lengths (paper eq. 2–3): differences first (exact nearby)."""
    k = 1.0 / (3.0 * r)
    return ((l2 - l1) + (l3 - l1)) * k, _SQRT3 * (l3 - l2) * k


def _tip_components(theta, wx, wy, length):
    """Tip (x, y, z) (m): x = ℓ·f(θ)·wx, y = ℓ·f(θ)·wy, z = ℓ·g(θ) (paper eq. 1)."""
    f, g = profile_nonnegative(theta)
    lf = length * f
    return lf * wx, lf * wy, length * g


# -- public API (the same names, signatures and results as cdcr_gym.kinematics) ------------------


def arc_from_lengths(lengths: ArrayLike, r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc parameters from the three cable lengths (paper eq. 2–4, with atan2).

    Args:
        lengths: cable lengths (l1, l2, l3), shape (..., 3), m (finite, >= 0).
        r: distance of the cables from the backbone axis, m.

    Returns:
        ``(theta, phi, kappa)``, each of shape (...): bending angle (rad, >= 0), bending-plane
        angle (rad, in (−π, π], 0 when θ = 0) and curvature (1/m). The backbone length is
        ℓ = (l1 + l2 + l3)/3.
    """
    r = check_positive("r", r, "cable radius, m")
    lengths = _as_lengths(lengths)
    l1, l2, l3 = lengths[..., 0], lengths[..., 1], lengths[..., 2]
    # |w| = 2·L_sqr/(3r) with L_sqr² = l1²+l2²+l3²−l1l2−l1l3−l2l3,
    # atan2(wy, wx) = atan2(√3(l3 − l2), l2 + l3 − 2 l1).
    w = np.stack(_bending_from_lengths(l1, l2, l3, r), axis=-1)
    theta, phi = arc_from_bending(w)
    kappa = 3.0 * theta / (l1 + l2 + l3)  # = 2 L_sqr / (r L_sum)
    return theta, phi, kappa


def lengths_from_arc(theta: ArrayLike, phi: ArrayLike, length: float, r: float) -> np.ndarray:
    """Cable lengths for an arc: l_i = ℓ − r·θ·cos(φ − β_i).

    Args:
        theta: bending angle, shape (...), rad, in [0, π].
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.
        r: cable distance from the axis, m.

    Returns:
        Cable lengths, shape (..., 3), m. The cable on the inside of the bend is the shortest.
    """
    length = check_positive("length", length, "backbone length, m")
    r = check_positive("r", r, "cable radius, m")
    theta = _as_theta(theta)
    phi = as_finite("phi", phi)
    wx, wy = theta * np.cos(phi), theta * np.sin(phi)
    return _stack3(
        length - r * wx,
        length - r * (wx * _COS_BETA[1] + wy * _SIN_BETA[1]),
        length - r * (wx * _COS_BETA[2] + wy * _SIN_BETA[2]),
    )


def tip_from_arc(theta: ArrayLike, phi: ArrayLike, length: float) -> np.ndarray:
    """Tip position of the arc (paper eq. 1), exact at θ = 0.

    X = ℓ(1 − cos θ)/θ · cos φ,  Y = ℓ(1 − cos θ)/θ · sin φ,  Z = ℓ sin θ/θ.

    Args:
        theta: bending angle, shape (...), rad, in [0, π].
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.

    Returns:
        Tip position in R0, shape (..., 3), m.
    """
    length = check_positive("length", length, "backbone length, m")
    theta = _as_theta(theta)
    phi = as_finite("phi", phi)
    return _stack3(*_tip_components(theta, theta * np.cos(phi), theta * np.sin(phi), length))


def forward_kinematics(lengths: ArrayLike, r: float) -> np.ndarray:
    """Tip position from the three cable lengths (the corrected paper eq. 5).

    Args:
        lengths: cable lengths, shape (..., 3), m. Their mean is the backbone length.
        r: cable distance from the axis, m.

    Returns:
        Tip position in R0, shape (..., 3), m. Equal lengths give (0, 0, ℓ) exactly.
    """
    r = check_positive("r", r, "cable radius, m")
    lengths = _as_lengths(lengths)
    l1, l2, l3 = lengths[..., 0], lengths[..., 1], lengths[..., 2]
    wx, wy = _bending_from_lengths(l1, l2, l3, r)
    backbone = (l1 + l2 + l3) / 3.0
    return _stack3(*_tip_components(np.sqrt(wx * wx + wy * wy), wx, wy, backbone))


def arc_from_tip(tip: ArrayLike, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arc (θ in [0, π]) whose tip is nearest to ``tip``, and the distance between them.

    For a point on the reachable surface, φ = atan2(y, x) and θ = 2·atan2(√(x²+y²), z) (the
    chord from the base to the tip makes the angle θ/2 with +Z0). For a point off the surface the
    bending plane is still φ = atan2(y, x) or its opposite (the surface is symmetric about +Z0);
    θ is found by minimising the in-plane distance (a grid picks the basin, Newton polishes).

    Args:
        tip: wanted tip positions, shape (..., 3), m.
        length: backbone length ℓ, m.

    Returns:
        ``(theta, phi, residual)``, each of shape (...): bending angle in [0, π] (rad), bending
        plane angle (rad; 0 on the Z axis) and distance from ``tip`` to the arc's tip (m;
        ≈ 0 on the surface).
    """
    length = check_positive("length", length, "backbone length, m")
    tip = as_finite("tip", tip, 3)
    x, y, z = tip[..., 0], tip[..., 1], tip[..., 2]
    rho = np.hypot(x, y)
    phi = np.where(rho == 0.0, 0.0, np.arctan2(y, x)) + 0.0
    theta = np.minimum(2.0 * np.arctan2(rho, z), np.pi)
    best = in_plane_distance(theta, rho, z, length)
    grid = np.linspace(0.0, np.pi, 65)
    for side in (1.0, -1.0):
        rho_side = side * rho
        dist_grid = in_plane_distance(grid, rho_side[..., None], z[..., None], length)
        cand = newton_nearest(grid[np.argmin(dist_grid, axis=-1)], rho_side, z, length)
        dist = in_plane_distance(cand, rho_side, z, length)
        better = dist < best
        theta = np.where(better, cand, theta)
        best = np.where(better, dist, best)
        if side < 0.0:
            flipped = better & (theta > 0.0)
            phi = np.where(flipped, np.where(phi > 0.0, phi - np.pi, phi + np.pi), phi)
    phi = np.where(theta == 0.0, 0.0, phi) + 0.0
    return theta, phi, best


def in_plane_distance(theta, rho, z, length: float) -> np.ndarray:
    """Distance from the in-plane point (ρ, z) (m) to the arc tip ℓ·((1−cos θ)/θ, sin θ/θ)."""
    f, g = arc_profile(theta)
    return np.hypot(rho - length * theta * f, z - length * g)


def newton_nearest(theta, rho, z, length: float, upper=np.pi) -> np.ndarray:
    """Newton steps on |(ρ, z) − ℓ(G(θ), H(θ))|² from ``theta``, kept in [0, upper] (rad).

    G = (1 − cos θ)/θ, H = sin θ/θ; ``upper`` (rad, broadcast) is π or a bending limit.
    """
    for _ in range(8):
        g, h, dg, dh, d2g, d2h = _profile_derivatives(theta)
        eg = rho - length * g
        eh = z - length * h
        df = -2.0 * length * (eg * dg + eh * dh)
        d2f = 2.0 * length**2 * (dg**2 + dh**2) - 2.0 * length * (eg * d2g + eh * d2h)
        positive = d2f > 0.0
        step = np.where(positive, df / np.where(positive, d2f, 1.0), 0.0)
        theta = np.clip(theta - step, 0.0, upper)
    return theta


def _profile_derivatives(theta: np.ndarray) -> tuple[np.ndarray, ...]:
    """G = (1−cos θ)/θ, H = sin θ/θ and their first two θ-derivatives, finite at θ = 0."""
    f, h = arc_profile(theta)
    g = theta * f
    small = theta < 1e-3
    t = np.where(small, 1.0, theta)  # safe divisor
    s, c = np.sin(t), np.cos(t)
    dg = np.where(small, 0.5 - theta**2 / 8.0, (t * s - (1.0 - c)) / t**2)
    dh = np.where(small, -theta / 3.0 + theta**3 / 30.0, (t * c - s) / t**2)
    d2g = np.where(small, -theta / 4.0, (t**2 * c - 2.0 * t * s + 2.0 * (1.0 - c)) / t**3)
    d2h = np.where(
        small, -1.0 / 3.0 + theta**2 / 10.0, (-(t**2) * s - 2.0 * t * c + 2.0 * s) / t**3
    )
    return g, h, dg, dh, d2g, d2h


def inverse_kinematics(
    tip: ArrayLike, length: float, r: float, *, return_residual: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Cable lengths that put the tip at ``tip`` (analytic CCKA inverse kinematics).

    The workspace of an inextensible 2-DOF section is a 2-D surface; for a point off it, the
    lengths of the arc whose tip is nearest are returned (see :func:`arc_from_tip`). This ignores
    the tension limit; ``cdcr_gym.model.ik.solve_ik`` respects it.

    Args:
        tip: wanted tip positions, shape (..., 3), m.
        length: backbone length ℓ, m.
        r: cable distance from the axis, m.
        return_residual: also return the distance (m, shape (...)) from ``tip`` to the tip the
            returned lengths reach.

    Returns:
        Cable lengths, shape (..., 3), m; with ``return_residual``, ``(lengths, residual)``.
    """
    theta, phi, residual = arc_from_tip(tip, length)
    lengths = lengths_from_arc(theta, phi, length, r)
    return (lengths, residual) if return_residual else lengths


def tip_rotation(theta: ArrayLike, phi: ArrayLike) -> np.ndarray:
    """Orientation of the tip frame in R0: Rz(φ)·Ry(θ)·Rz(−φ).

    Args:
        theta: bending angle, shape (...), rad, in [0, π].
        phi: bending-plane angle, shape (...), rad.

    Returns:
        Rotation matrices, shape (..., 3, 3); the third column is the backbone tangent at the tip.
    """
    theta, phi = np.broadcast_arrays(_as_theta(theta), as_finite("phi", phi))
    ct, st, cp, sp = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    vt = 1.0 - ct
    rot = np.empty(theta.shape + (3, 3))
    rot[..., 0, 0] = ct * cp**2 + sp**2
    rot[..., 0, 1] = -vt * cp * sp
    rot[..., 0, 2] = st * cp
    rot[..., 1, 0] = -vt * cp * sp
    rot[..., 1, 1] = ct * sp**2 + cp**2
    rot[..., 1, 2] = st * sp
    rot[..., 2, 0] = -st * cp
    rot[..., 2, 1] = -st * sp
    rot[..., 2, 2] = ct
    return rot


def tip_pose(theta: ArrayLike, phi: ArrayLike, length: float) -> np.ndarray:
    """Homogeneous transform of the tip frame in R0, shape (..., 4, 4) (translation in m)."""
    theta, phi = np.broadcast_arrays(_as_theta(theta), as_finite("phi", phi))
    pose = np.zeros(theta.shape + (4, 4))
    pose[..., :3, :3] = tip_rotation(theta, phi)
    pose[..., :3, 3] = tip_from_arc(theta, phi, length)
    pose[..., 3, 3] = 1.0
    return pose


def backbone_points(theta: ArrayLike, phi: ArrayLike, length: float, n: int = 50) -> np.ndarray:
    """Points along the constant-curvature backbone, evenly spaced in arc length.

    Args:
        theta: bending angle, shape (...), rad, in [0, π].
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.
        n: number of points (>= 2), base and tip included.

    Returns:
        Points in R0, shape (..., n, 3), m; the first is the base (0, 0, 0), the last the tip.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n (number of backbone points) must be an integer >= 2, got {n!r}")
    length = check_positive("length", length, "backbone length, m")
    s = np.linspace(0.0, 1.0, n)  # fraction of the arc length
    theta = _as_theta(theta)[..., None]
    phi = as_finite("phi", phi)[..., None]
    # A sub-arc of length sℓ has bending angle sθ in the same plane.
    return tip_from_arc(theta * s, phi, length) * s[:, None]
