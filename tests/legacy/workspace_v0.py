"""The reachable workspace: its bending limit and area-uniform sampling of shapes on it.

The tips of an inextensible 2-DOF constant-curvature section form a 2-D surface parameterised
by (θ, φ): p(θ, φ) = ℓ·(g(θ) cos φ, g(θ) sin φ, h(θ)) with g = (1 − cos θ)/θ, h = sin θ/θ.
Its area element is

    dA = ℓ² · g(θ) · √(g'(θ)² + h'(θ)²) dθ dφ,

because ∂p/∂φ = ℓ g (−sin φ, cos φ, 0) is orthogonal to ∂p/∂θ = ℓ (g' cos φ, g' sin φ, h').
The region the cables can reach (tensions in [0, max_tension]) is θ <= θ_lim(φ), a hexagon in
the curvature plane (``statics.bending_limit``). Sampling uniformly in area draws θ from the
density ∝ g·√(g'² + h'²) on [0, θ_max] by inverse CDF, φ uniformly, and rejects (θ, φ) outside
the hexagon — which is exact: rejection of a uniform law leaves it uniform on the kept region.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from cdcr_gym.params import RobotParams
from legacy.statics_v0 import bending_limit

__all__ = ["area_density", "sample_arcs", "sample_arcs_each", "clip_to_workspace"]

_TABLE_SIZE = 4097


def area_density(theta: np.ndarray) -> np.ndarray:
    """Surface area per unit θ per unit φ, divided by ℓ²: g(θ)·√(g'² + h'²), shape of ``theta``."""
    theta = np.asarray(theta, dtype=np.float64)
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    s, c = np.sin(t), np.cos(t)
    g = 0.5 * theta * np.sinc(theta / (2.0 * np.pi)) ** 2
    dg = np.where(small, 0.5, (t * s - (1.0 - c)) / t**2)
    dh = np.where(small, -theta / 3.0, (t * c - s) / t**2)
    return g * np.hypot(dg, dh)


@lru_cache(maxsize=16)
def _theta_table(theta_max: float) -> tuple[np.ndarray, np.ndarray]:
    """(cdf, theta) tables of the normalised area CDF of θ on [0, theta_max]."""
    theta = np.linspace(0.0, theta_max, _TABLE_SIZE)
    dens = area_density(theta)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(theta))])
    cdf /= cdf[-1]
    return cdf, theta


def sample_arcs(
    rng: np.random.Generator, n: int, params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """Draw ``n`` arcs whose tips are uniform in area over the tension-reachable workspace.

    Args:
        rng: the random generator (an env's ``np_random``); the only source of randomness.
        n: number of samples (>= 1).
        params: the robot (its tension limit sets the workspace).

    Returns:
        ``(theta, phi)``, each of shape (n,), rad; θ in [0, θ_lim(φ)], φ in [−π, π).
    """
    theta = np.empty(n)
    phi = np.empty(n)
    filled = 0
    while filled < n:
        want = n - filled
        cand_theta, cand_phi, keep = _candidate_arcs(rng.random((want, 2)), params)
        k = int(keep.sum())
        theta[filled : filled + k] = cand_theta[keep]
        phi[filled : filled + k] = cand_phi[keep]
        filled += k
    return theta, phi


def _candidate_arcs(
    u: np.ndarray, params: RobotParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidates (θ, φ) from uniforms ``u`` (..., 2) in [0, 1), and whether each is kept.

    θ by the inverse area CDF of u[..., 0], φ = (2 u[..., 1] − 1)·π, kept where θ <= θ_lim(φ).
    """
    cdf, table = _theta_table(params.max_bending_angle)
    cand_theta = np.interp(u[..., 0], cdf, table)
    cand_phi = (2.0 * u[..., 1] - 1.0) * np.pi
    return cand_theta, cand_phi, cand_theta <= bending_limit(cand_phi, params)


def sample_arcs_each(
    rngs: Sequence[np.random.Generator], params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """One arc from each generator: ``[sample_arcs(rng, 1, params) for rng in rngs]``, batched.

    Draw for draw the same as the per-generator calls (each generator gives its two uniforms per
    candidate, rejected candidates are redrawn from the same generator), so a batch of envs that
    each own a generator samples exactly what the single envs would; only the arithmetic is done
    for all candidates at once. Used by the batched env when many envs reset in the same step.

    Returns:
        ``(theta, phi)``, each of shape (len(rngs),), rad.
    """
    m = len(rngs)
    theta = np.empty(m)
    phi = np.empty(m)
    pending = np.arange(m)
    u = np.empty((m, 2))
    while pending.size:
        for k, i in enumerate(pending.tolist()):
            rngs[i].random(out=u[k])
        cand_theta, cand_phi, keep = _candidate_arcs(u[: pending.size], params)
        theta[pending[keep]] = cand_theta[keep]
        phi[pending[keep]] = cand_phi[keep]
        pending = pending[~keep]
    return theta, phi


def clip_to_workspace(
    theta: np.ndarray, phi: np.ndarray, params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """Clip the bending angle to the tension-reachable limit θ_lim(φ), keeping φ.

    In the curvature plane this is the radial projection onto the hexagon of reachable shapes.

    Returns:
        ``(theta, clipped)``: the clipped θ (rad) and a bool array, True where it was clipped.
    """
    limit = bending_limit(phi, params)
    theta = np.asarray(theta, dtype=np.float64)
    return np.minimum(theta, limit), theta > limit
