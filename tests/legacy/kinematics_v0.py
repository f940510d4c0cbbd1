"""Constant-curvature kinematics (CCKA) of one inextensible 2-DOF continuum section.

Pure numpy; imports no simulator and no Gymnasium. Every function broadcasts over leading batch
dimensions: an argument of shape (..., 3) or (...) gives results with the same leading shape.

Conventions (SI units):
    * Base frame R0 at the base disk centre, backbone along +Z0, cable 1 at +X0.
    * Cable i sits at angle β_i (0°, 120°, 240°) about +Z0 at distance r from the backbone axis.
    * Arc parameters: bending angle θ >= 0 (rad), bending-plane angle φ (rad, measured from +X0
      about +Z0; the tip moves towards φ), curvature κ = θ/ℓ (1/m).
    * At θ = 0 (straight robot) φ is undefined; we return φ = 0 by convention.

Corrections to the paper (see README): eq. 2 uses tan⁻¹ of a ratio, which loses the
quadrant; we use atan2. Eq. 5's Z line reads (r·L_sum/L_sqr)·sin(2L_sqr/3r), but it must be
(r·L_sum/(2·L_sqr))·sin(2L_sqr/3r) = sin θ/κ: with equal cable lengths the printed form gives
Z = 2ℓ = 1.282 m instead of ℓ = 0.641 m.

The 0/0 forms at θ = 0 are evaluated with sinc-style expressions that are exact and finite there:
    sin θ / θ        = sinc(θ/π)                      (numpy's normalised sinc)
    (1 − cos θ) / θ  = (θ/2) · sinc(θ/(2π))²
computed together from t = tan(θ/4) (one transcendental call, see ``_arc_profile``): with
q = sinc(θ/(2π)) = (tan(θ/4)/(θ/4)) / (1 + t²), sin θ/θ = q·(1 − t²)/(1 + t²) and
(1 − cos θ)/θ² = q²/2.

Internally the shape is carried as the *bending vector* w = θ·(cos φ, sin φ) (rad), in which the
cable lengths (l_i = ℓ − r·w·u_i, u_i = (cos β_i, sin β_i)) and the tension statics are linear and
nothing is singular at θ = 0. The private kernels below (``_lengths_from_bending``,
``_tip_from_bending``, ...) take and return *components* (x, y, z separately), each a Python
float or a numpy array of any shape; the public (..., 3)-array functions are thin wrappers around
them, the single env's analytic backend calls them with floats (fast ``math``-module path), and
the batched env with arrays of all envs at once. One formula, three call sites.
"""

from __future__ import annotations

import math

import numpy as np

from cdcr_gym.params import CABLE_ANGLES

__all__ = [
    "arc_from_lengths",
    "lengths_from_arc",
    "tip_from_arc",
    "forward_kinematics",
    "inverse_kinematics",
    "arc_from_tip",
    "tip_rotation",
    "tip_pose",
    "backbone_points",
]

_BETA = np.asarray(CABLE_ANGLES, dtype=np.float64)
_COS_BETA = np.cos(_BETA)
_SIN_BETA = np.sin(_BETA)
_SQRT3 = np.sqrt(3.0)
# cos β_i, sin β_i for the component kernels: the exact values (1, −1/2, −1/2) and
# (0, √3/2, −√3/2), so that the kernels keep the three-fold symmetry exactly (np.cos(2π/3) and
# np.cos(4π/3) differ in the last bits), as Python floats (a numpy scalar would pull the scalar
# path onto numpy's slow scalar arithmetic).
_SQRT3_F = math.sqrt(3.0)
_C1, _C2, _C3 = 1.0, -0.5, -0.5
_S1, _S2, _S3 = 0.0, 0.5 * _SQRT3_F, -0.5 * _SQRT3_F
assert np.allclose([_C1, _C2, _C3], _COS_BETA, atol=1e-15)
assert np.allclose([_S1, _S2, _S3], _SIN_BETA, atol=1e-15)


# -- elementwise primitives: Python floats -> math module, anything else -> numpy -----------------
# The kernels are written once with arithmetic operators and these few functions, so the same
# code runs on Python floats (the single env: ~50 ns per call instead of ~1 µs for numpy on tiny
# arrays) and on arrays of any shape (the batched env). Dispatch is on ``type(x) is float``:
# numpy scalars stay on numpy, so a batched call and a per-row call give bit-identical results.


def _sqrt(x):
    return math.sqrt(x) if type(x) is float else np.sqrt(x)


def _tan_over(x):
    """tan x / x, exact at x = 0 (value 1); |x| < π/2 for the arcs of interest."""
    if type(x) is float:
        return math.tan(x) / x if x else 1.0
    safe = np.where(x == 0.0, 1e-20, x)  # numpy's sinc trick: tan(1e-20)/1e-20 == 1.0 exactly
    return np.tan(safe) / safe


# (the float branches compare directly: ~3x faster than the builtins min/max)
def _minimum(a, b):
    if type(a) is float and type(b) is float:
        return b if b < a else a
    return np.minimum(a, b)


def _maximum(a, b):
    if type(a) is float and type(b) is float:
        return b if b > a else a
    return np.maximum(a, b)


def _min3(a, b, c):
    if type(a) is float and type(b) is float and type(c) is float:
        m = b if b < a else a
        return c if c < m else m
    return np.minimum(np.minimum(a, b), c)


def _max3(a, b, c):
    if type(a) is float and type(b) is float and type(c) is float:
        m = b if b > a else a
        return c if c > m else m
    return np.maximum(np.maximum(a, b), c)


def _clip(x, low, high):
    """x clipped to [low, high] (NaN passes through, like np.clip)."""
    if type(x) is float:
        return low if x < low else high if x > high else x
    return np.minimum(np.maximum(x, low), high)


def _stack3(x, y, z) -> np.ndarray:
    """Stack three broadcast-compatible components into a (..., 3) float64 array."""
    out = np.empty(np.broadcast_shapes(np.shape(x), np.shape(y), np.shape(z)) + (3,))
    out[..., 0] = x
    out[..., 1] = y
    out[..., 2] = z
    return out


# -- component kernels (one formula each; floats or arrays) ---------------------------------------


def _arc_profile(theta):
    """(f, g) = ((1 − cos θ)/θ², sin θ/θ), exact and finite at θ = 0 (1/2, 1); even in θ.

    From t = tan(θ/4): sin(θ/2) = 2t/(1+t²) and cos(θ/2) = (1−t²)/(1+t²), so with
    q = sin(θ/2)/(θ/2) = (t/(θ/4))/(1+t²): sin θ/θ = q·cos(θ/2) and (1 − cos θ)/θ² = q²/2.
    One tangent (vectorised in numpy, unlike sin/cos) and no cancellation near θ = 0.
    """
    x = 0.25 * theta
    p = _tan_over(x)
    t = p * x
    t2 = t * t
    inv = 1.0 / (1.0 + t2)
    q = p * inv
    return 0.5 * q * q, q * (1.0 - t2) * inv


def _bending_angle(wx, wy):
    """θ = |w| (rad) of the bending vector w = (wx, wy)."""
    return _sqrt(wx * wx + wy * wy)


def _bending_from_lengths(l1, l2, l3, r):
    """Bending vector w = θ·(cos φ, sin φ) (rad) from the cable lengths (paper eq. 2–3).

    wx = (l2 + l3 − 2 l1)/(3r), wy = √3 (l3 − l2)/(3r): |w| = 2 L_sqr/(3r) = θ and
    atan2(wy, wx) = φ. Differences of lengths first, which are exact for nearby lengths, so a
    nearly straight robot keeps its relative precision.
    """
    k = 1.0 / (3.0 * r)
    return ((l2 - l1) + (l3 - l1)) * k, _SQRT3_F * (l3 - l2) * k


def _lengths_from_bending(wx, wy, length, r):
    """Cable lengths (l1, l2, l3) = ℓ − r·(w·u_i) (m), u_i = (cos β_i, sin β_i)."""
    return (
        length - r * wx,  # u_1 = (1, 0)
        length - r * (wx * _C2 + wy * _S2),
        length - r * (wx * _C3 + wy * _S3),
    )


def _tip_from_bending(theta, wx, wy, length):
    """Tip (x, y, z) (m) of the arc with bending vector w and bending angle θ (= |w|).

    x = ℓ (1 − cos θ)/θ · cos φ = ℓ·f(θ)·wx, y = ℓ·f(θ)·wy, z = ℓ sin θ/θ (paper eq. 1).
    """
    f, g = _arc_profile(theta)
    lf = length * f
    return lf * wx, lf * wy, length * g


def _sin_over(theta: np.ndarray) -> np.ndarray:
    """sin θ / θ, exact at θ = 0."""
    return _arc_profile(theta)[1]


def _one_minus_cos_over(theta: np.ndarray) -> np.ndarray:
    """(1 − cos θ) / θ = 2 sin²(θ/2)/θ, exact at θ = 0 (value 0)."""
    return theta * _arc_profile(theta)[0]


def _check_radius(r: float) -> float:
    r = float(r)
    if not np.isfinite(r) or r <= 0.0:
        raise ValueError(f"r (cable radius) must be finite and > 0 m, got {r!r}")
    return r


def _check_length(length: float) -> float:
    length = float(length)
    if not np.isfinite(length) or length <= 0.0:
        raise ValueError(f"length (backbone length) must be finite and > 0 m, got {length!r}")
    return length


def _as_lengths(lengths: np.ndarray) -> np.ndarray:
    lengths = np.asarray(lengths, dtype=np.float64)
    if lengths.shape[-1:] != (3,):
        raise ValueError(f"lengths must have shape (..., 3), got shape {lengths.shape}")
    if not np.all(np.isfinite(lengths)):
        raise ValueError(f"lengths must be finite, got {lengths!r}")
    return lengths


def arc_from_lengths(lengths: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc parameters from the three cable lengths (paper eq. 2–4, with atan2).

    Args:
        lengths: cable lengths (l1, l2, l3), shape (..., 3), m.
        r: distance of the cables from the backbone axis, m.

    Returns:
        ``(theta, phi, kappa)``, each of shape (...): bending angle (rad, >= 0), bending-plane
        angle (rad, in (−π, π], 0 when θ = 0) and curvature (1/m). The backbone length is
        ℓ = (l1 + l2 + l3)/3.
    """
    r = _check_radius(r)
    lengths = _as_lengths(lengths)
    l1, l2, l3 = lengths[..., 0], lengths[..., 1], lengths[..., 2]
    # Through the bending vector: |w| = 2·L_sqr/(3r) with L_sqr² = l1²+l2²+l3²−l1l2−l1l3−l2l3,
    # atan2(wy, wx) = atan2(√3(l3 − l2), l2 + l3 − 2 l1) (both scaled by 1/(3r) > 0).
    wx, wy = _bending_from_lengths(l1, l2, l3, r)
    theta, phi = _arc_from_bending(wx, wy)
    kappa = 3.0 * theta / (l1 + l2 + l3)  # = 2 L_sqr / (r L_sum)
    return theta, phi, kappa


def _arc_from_bending(wx: np.ndarray, wy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(θ, φ) of a bending vector (arrays); φ = 0 when θ = 0."""
    theta = np.sqrt(wx * wx + wy * wy)
    phi = np.where(theta == 0.0, 0.0, np.arctan2(wy, wx)) + 0.0  # + 0.0 turns −0.0 into 0.0
    return theta, phi


def lengths_from_arc(theta: np.ndarray, phi: np.ndarray, length: float, r: float) -> np.ndarray:
    """Cable lengths for an arc: l_i = ℓ − r·θ·cos(φ − β_i).

    Args:
        theta: bending angle, shape (...), rad.
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.
        r: cable distance from the axis, m.

    Returns:
        Cable lengths, shape (..., 3), m. The cable on the inside of the bend is the shortest.
    """
    length = _check_length(length)
    r = _check_radius(r)
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    # θ·cos(φ − β) = wx cos β + wy sin β with the bending vector w = θ (cos φ, sin φ)
    return _stack3(*_lengths_from_bending(theta * np.cos(phi), theta * np.sin(phi), length, r))


def tip_from_arc(theta: np.ndarray, phi: np.ndarray, length: float) -> np.ndarray:
    """Tip position of the arc (paper eq. 1), exact at θ = 0.

    X = ℓ(1 − cos θ)/θ · cos φ,  Y = ℓ(1 − cos θ)/θ · sin φ,  Z = ℓ sin θ/θ.

    Args:
        theta: bending angle, shape (...), rad.
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.

    Returns:
        Tip position in R0, shape (..., 3), m.
    """
    length = _check_length(length)
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    return _stack3(*_tip_from_bending(theta, theta * np.cos(phi), theta * np.sin(phi), length))


def forward_kinematics(lengths: np.ndarray, r: float) -> np.ndarray:
    """Tip position from the three cable lengths (the corrected paper eq. 5).

    Args:
        lengths: cable lengths, shape (..., 3), m. Their mean is the backbone length.
        r: cable distance from the axis, m.

    Returns:
        Tip position in R0, shape (..., 3), m. Equal lengths give (0, 0, ℓ) exactly.
    """
    r = _check_radius(r)
    lengths = _as_lengths(lengths)
    l1, l2, l3 = lengths[..., 0], lengths[..., 1], lengths[..., 2]
    wx, wy = _bending_from_lengths(l1, l2, l3, r)
    backbone = (l1 + l2 + l3) / 3.0
    return _stack3(*_tip_from_bending(_bending_angle(wx, wy), wx, wy, backbone))


def arc_from_tip(tip: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The arc whose tip is nearest to ``tip``, and the distance between them.

    For a point on the reachable surface, φ = atan2(y, x) and θ = 2·atan2(√(x²+y²), z) (the
    chord from the base to the tip makes the angle θ/2 with +Z0). For a point off the surface the
    bending plane is still φ = atan2(y, x) (the surface is symmetric about +Z0); θ is found by
    minimising the in-plane distance with Newton steps started from the formula above.

    Args:
        tip: wanted tip positions, shape (..., 3), m.
        length: backbone length ℓ, m.

    Returns:
        ``(theta, phi, residual)``, each of shape (...): bending angle in [0, π] (rad), bending
        plane angle (rad; 0 on the Z axis) and distance from ``tip`` to the arc's tip (m;
        ≈ 0 on the surface).
    """
    length = _check_length(length)
    tip = np.asarray(tip, dtype=np.float64)
    if tip.shape[-1:] != (3,):
        raise ValueError(f"tip must have shape (..., 3), got shape {tip.shape}")
    if not np.all(np.isfinite(tip)):
        raise ValueError(f"tip must be finite, got {tip!r}")
    x, y, z = tip[..., 0], tip[..., 1], tip[..., 2]
    rho = np.hypot(x, y)
    phi = np.where(rho == 0.0, 0.0, np.arctan2(y, x)) + 0.0
    # Candidate 1: the closed form, exact for points on the surface (θ > π is outside the model).
    theta = np.minimum(2.0 * np.arctan2(rho, z), np.pi)
    best = _in_plane_distance(theta, rho, z, length)
    # Candidates 2 and 3: for points off the surface, the nearest arc lies in the plane through
    # the point and +Z0, on the point's side (φ) or the opposite side (φ + π, in-plane ρ < 0).
    # A coarse grid over θ in [0, π] picks the basin, Newton steps polish it.
    grid = np.linspace(0.0, np.pi, 65)
    for side in (1.0, -1.0):
        rho_side = side * rho
        dist_grid = _in_plane_distance(grid, rho_side[..., None], z[..., None], length)
        cand = _newton_nearest(grid[np.argmin(dist_grid, axis=-1)], rho_side, z, length)
        dist = _in_plane_distance(cand, rho_side, z, length)
        better = dist < best
        theta = np.where(better, cand, theta)
        best = np.where(better, dist, best)
        if side < 0.0:
            flipped = better & (theta > 0.0)
            phi = np.where(flipped, np.where(phi > 0.0, phi - np.pi, phi + np.pi), phi)
    phi = np.where(theta == 0.0, 0.0, phi) + 0.0
    return theta, phi, best


def _in_plane_distance(
    theta: np.ndarray, rho: np.ndarray, z: np.ndarray, length: float
) -> np.ndarray:
    """Distance from the in-plane point (ρ, z) to the arc tip ℓ·(g(θ), h(θ))."""
    return np.hypot(rho - length * _one_minus_cos_over(theta), z - length * _sin_over(theta))


def _newton_nearest(theta: np.ndarray, rho: np.ndarray, z: np.ndarray, length: float) -> np.ndarray:
    """Newton steps on f(θ) = |(ρ, z) − ℓ(g(θ), h(θ))|², kept in [0, π]."""
    for _ in range(8):
        g, h, dg, dh, d2g, d2h = _profile_derivatives(theta)
        eg = rho - length * g
        eh = z - length * h
        df = -2.0 * length * (eg * dg + eh * dh)
        d2f = 2.0 * length**2 * (dg**2 + dh**2) - 2.0 * length * (eg * d2g + eh * d2h)
        positive = d2f > 0.0
        step = np.where(positive, df / np.where(positive, d2f, 1.0), 0.0)
        theta = np.clip(theta - step, 0.0, np.pi)
    return theta


def _profile_derivatives(theta: np.ndarray) -> tuple[np.ndarray, ...]:
    """g = (1−cos θ)/θ, h = sin θ/θ and their first two θ-derivatives, finite at θ = 0."""
    g = _one_minus_cos_over(theta)
    h = _sin_over(theta)
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
    tip: np.ndarray, length: float, r: float, *, return_residual: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Cable lengths that put the tip at ``tip`` (analytic CCKA inverse kinematics).

    The workspace of an inextensible 2-DOF section is a 2-D surface; for a point off it, the
    lengths of the arc whose tip is nearest are returned (see :func:`arc_from_tip`).

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


def tip_rotation(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Orientation of the tip frame in R0: Rz(φ)·Ry(θ)·Rz(−φ).

    Args:
        theta: bending angle, shape (...), rad.
        phi: bending-plane angle, shape (...), rad.

    Returns:
        Rotation matrices, shape (..., 3, 3); the third column is the backbone tangent at the tip.
    """
    theta, phi = np.broadcast_arrays(
        np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64)
    )
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


def tip_pose(theta: np.ndarray, phi: np.ndarray, length: float) -> np.ndarray:
    """Homogeneous transform of the tip frame in R0, shape (..., 4, 4) (translation in m)."""
    theta, phi = np.broadcast_arrays(
        np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64)
    )
    pose = np.zeros(theta.shape + (4, 4))
    pose[..., :3, :3] = tip_rotation(theta, phi)
    pose[..., :3, 3] = tip_from_arc(theta, phi, length)
    pose[..., 3, 3] = 1.0
    return pose


def backbone_points(theta: np.ndarray, phi: np.ndarray, length: float, n: int = 50) -> np.ndarray:
    """Points along the constant-curvature backbone, evenly spaced in arc length.

    Args:
        theta: bending angle, shape (...), rad.
        phi: bending-plane angle, shape (...), rad.
        length: backbone length ℓ, m.
        n: number of points (>= 2), base and tip included.

    Returns:
        Points in R0, shape (..., n, 3), m; the first is the base (0, 0, 0), the last the tip.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n (number of backbone points) must be an integer >= 2, got {n!r}")
    length = _check_length(length)
    s = np.linspace(0.0, 1.0, n)  # fraction of the arc length
    theta = np.asarray(theta, dtype=np.float64)[..., None]
    phi = np.asarray(phi, dtype=np.float64)[..., None]
    # A sub-arc of length sℓ has bending angle sθ in the same plane.
    return tip_from_arc(theta * s, phi, length) * s[:, None]
