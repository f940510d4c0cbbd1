"""The reachable workspace: its bending limit and sampling of shapes (as cable tensions) on it.

One section. The tips of an inextensible 2-DOF constant-curvature section form a 2-D surface
parameterised by (θ, φ): p(θ, φ) = ℓ·(g(θ) cos φ, g(θ) sin φ, h(θ)) with g = (1 − cos θ)/θ,
h = sin θ/θ. Its area element is

    dA = ℓ² · g(θ) · √(g'(θ)² + h'(θ)²) dθ dφ,

because ∂p/∂φ = ℓ g (−sin φ, cos φ, 0) is orthogonal to ∂p/∂θ = ℓ (g' cos φ, g' sin φ, h').
The region the cables can reach (tensions in [0, max_tension]) is θ <= θ_lim(φ)
(``statics.bending_limit``; a hexagon in the curvature plane for the paper's robot). Sampling
uniformly in area draws θ from the density ∝ g·√(g'² + h'²) on [0, θ_max] by inverse CDF, φ
uniformly, and rejects (θ, φ) outside the limit — exact: rejection of a uniform law leaves it
uniform on the kept region.

Several sections. :func:`sample_tensions` draws every cable tension independently and uniformly
in [0, max_tension] (C uniforms per sample, in cable order). Every sample is within the limits by
construction and the law is simple and documented; the tips it gives are *not* uniform in the
workspace (co-contraction makes moderate bends more likely than extreme ones).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from cdcr_gym.model.arc import bending_from_arc
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import bending_limit, cached_model, minimal_tensions

__all__ = [
    "area_density",
    "sample_arcs",
    "sample_arcs_each",
    "clip_to_workspace",
    "sample_tensions",
    "sample_tensions_each",
]

_TABLE_SIZE = 4097


def area_density(theta) -> np.ndarray:
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


def _one_section(params) -> RobotParams:
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    if params.n_sections != 1:
        raise ValueError(
            f"params must describe a one-section robot here, got {params.n_sections} sections "
            f"(use sample_tensions)"
        )
    return params


@lru_cache(maxsize=32)
def _theta_max(params: RobotParams) -> float:
    """Largest θ of the tension-reachable region of a one-section robot (rad).

    The region is the union over neighbouring cable pairs (a, b) of T_max·([0, v_a] + [0, v_b])
    scaled by ℓ/EI; its farthest points are T_max·v_a (norm T_max·r) and T_max·(v_a + v_b). For
    cables 120° apart or more the single cable is the farthest: params.max_bending_angle, kept
    bit for bit (the sampler's table depends on it).
    """
    angles = np.sort(np.mod(np.asarray(params.cable_angles), 2.0 * np.pi))
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2.0 * np.pi]))
    pair = 2.0 * np.cos(0.5 * np.min(gaps))  # |u_a + u_b| for the closest pair
    return params.max_bending_angle * (pair if pair > 1.0 + 1e-9 else 1.0)


def _check_count(n) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n (number of samples) must be an integer >= 1, got {n!r}")
    return int(n)


def sample_arcs(
    rng: np.random.Generator, n: int, params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """Draw ``n`` arcs whose tips are uniform in area over the tension-reachable workspace.

    Args:
        rng: the random generator (an env's ``np_random``); the only source of randomness.
        n: number of samples (>= 1).
        params: a one-section robot (its tension limit sets the workspace).

    Returns:
        ``(theta, phi)``, each of shape (n,), rad; θ in [0, θ_lim(φ)], φ in [−π, π).
    """
    params = _one_section(params)
    n = _check_count(n)
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
    cdf, table = _theta_table(_theta_max(params))
    cand_theta = np.interp(u[..., 0], cdf, table)
    cand_phi = (2.0 * u[..., 1] - 1.0) * np.pi
    # θ_lim(φ) is only evaluated where θ exceeds a lower bound of it (most candidates do not)
    keep = cand_theta <= _inscribed_theta(params)
    if not keep.all():
        edge = ~keep
        keep[edge] = cand_theta[edge] <= bending_limit(cand_phi[edge], params)
    return cand_theta, cand_phi, keep


@lru_cache(maxsize=32)
def _inscribed_theta(params: RobotParams) -> float:
    """A lower bound of θ_lim(φ) over all φ (rad): the minimum over a fine grid of φ, less 1 %.

    θ_lim is continuous and piecewise smooth in φ (its pieces vary on the scale of the angle
    between neighbouring cables), so on a grid of 2¹⁴ points the minimum is found to far better
    than 1 %; candidates below the bound are accepted without evaluating θ_lim, which gives the
    same decisions as evaluating it.
    """
    grid = np.linspace(-np.pi, np.pi, 1 << 14)
    return 0.99 * float(np.min(bending_limit(grid, params)))


def sample_arcs_each(
    rngs: Sequence[np.random.Generator], params: RobotParams
) -> tuple[np.ndarray, np.ndarray]:
    """One arc from each generator: ``[sample_arcs(rng, 1, params) for rng in rngs]``, batched.

    Draw for draw the same as the per-generator calls (each generator gives its two uniforms per
    candidate, rejected candidates are redrawn from the same generator); only the arithmetic is
    done for all candidates at once.

    Returns:
        ``(theta, phi)``, each of shape (len(rngs),), rad.
    """
    params = _one_section(params)
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


def clip_to_workspace(theta, phi, params: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """Clip the bending angle of a one-section robot to the limit θ_lim(φ), keeping φ.

    In the curvature plane this is the radial projection onto the reachable region.

    Returns:
        ``(theta, clipped)``: the clipped θ (rad) and a bool array, True where it was clipped.
    """
    limit = bending_limit(phi, _one_section(params))
    theta = np.asarray(theta, dtype=np.float64)
    return np.minimum(theta, limit), theta > limit


def _tensions_of_arcs(theta: np.ndarray, phi: np.ndarray, params: RobotParams) -> np.ndarray:
    tensions, _ = minimal_tensions(cached_model(params), bending_from_arc(theta, phi)[..., None, :])
    return tensions


def sample_tensions(rng: np.random.Generator, params: RobotParams, n: int) -> np.ndarray:
    """Draw ``n`` shapes within the tension limits, as cable tensions (n, C) in N.

    * One section: the arcs of :func:`sample_arcs` (tips area-uniform on the reachable surface,
      the same draws from ``rng``), converted to their minimal tensions
      (``statics.minimal_tensions``; one cable of each sample is slack).
    * Several sections: every tension independently uniform in [0, max_tension]
      (``rng.random((n, C))``); see the module docstring.

    Args:
        rng: the random generator; the only source of randomness.
        params: the robot.
        n: number of samples (>= 1).
    """
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    n = _check_count(n)
    if params.n_sections == 1:
        return _tensions_of_arcs(*sample_arcs(rng, n, params), params)
    return params.max_tension * rng.random((n, params.n_cables))


def sample_tensions_each(rngs: Sequence[np.random.Generator], params: RobotParams) -> np.ndarray:
    """One sample from each generator, ``(len(rngs), C)`` N: draw for draw the same as
    ``np.concatenate([sample_tensions(rng, params, 1) for rng in rngs])``, batched."""
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    if params.n_sections == 1:
        return _tensions_of_arcs(*sample_arcs_each(rngs, params), params)
    u = np.empty((len(rngs), params.n_cables))
    for k, rng in enumerate(rngs):
        rng.random(out=u[k])
    return params.max_tension * u
