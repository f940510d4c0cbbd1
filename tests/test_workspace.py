"""Goal sampling is area-uniform on the reachable surface: a chi-square test against a mesh."""

from __future__ import annotations

import numpy as np
import pytest

from cdcr_gym import kinematics as K
from cdcr_gym.model.statics import bending_limit
from cdcr_gym.model.workspace import clip_to_workspace, sample_arcs
from cdcr_gym.params import RobotParams

P = RobotParams()
N_THETA_BINS, N_PHI_BINS = 8, 6
# chi-square critical value, 47 degrees of freedom, p = 0.001
CHI2_CRIT_47_P001 = 82.72


def _mesh_bin_probabilities():
    """Probability of each (θ, φ) bin under area-uniform sampling, from a triangulated mesh of
    the surface (independent of the density formula used by the sampler)."""
    theta_max = P.max_bending_angle
    th = np.linspace(0.0, theta_max, 601)
    ph = np.linspace(-np.pi, np.pi, 1441)
    pts = K.tip_from_arc(th[:, None], ph[None, :], P.length)  # (601, 1441, 3)
    a, b, c, d = pts[:-1, :-1], pts[1:, :-1], pts[1:, 1:], pts[:-1, 1:]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=-1) + 0.5 * np.linalg.norm(
        np.cross(c - a, d - a), axis=-1
    )
    th_c = 0.5 * (th[1:] + th[:-1])[:, None]
    ph_c = 0.5 * (ph[1:] + ph[:-1])[None, :]
    inside = th_c <= bending_limit(ph_c, P)
    area = np.where(inside, area, 0.0)
    ti = np.minimum((th_c / theta_max * N_THETA_BINS).astype(int), N_THETA_BINS - 1)
    pi = np.minimum(((ph_c + np.pi) / (2 * np.pi) * N_PHI_BINS).astype(int), N_PHI_BINS - 1)
    probs = np.zeros((N_THETA_BINS, N_PHI_BINS))
    np.add.at(probs, (np.broadcast_to(ti, area.shape), np.broadcast_to(pi, area.shape)), area)
    return probs / probs.sum()


def _chi2(theta, phi, probs):
    ti = np.minimum((theta / P.max_bending_angle * N_THETA_BINS).astype(int), N_THETA_BINS - 1)
    pi = np.minimum(((phi + np.pi) / (2 * np.pi) * N_PHI_BINS).astype(int), N_PHI_BINS - 1)
    counts = np.zeros_like(probs)
    np.add.at(counts, (ti, pi), 1)
    expected = probs * len(theta)
    return np.sum((counts - expected) ** 2 / expected)


def test_samples_are_area_uniform_chi_square():
    probs = _mesh_bin_probabilities()
    theta, phi = sample_arcs(np.random.default_rng(123), 60_000, P)
    assert _chi2(theta, phi, probs) < CHI2_CRIT_47_P001


def test_the_chi_square_test_detects_non_uniform_sampling():
    # Negative control: θ uniform in [0, θ_lim] (not area-uniform) must fail the same test.
    probs = _mesh_bin_probabilities()
    rng = np.random.default_rng(123)
    phi = rng.uniform(-np.pi, np.pi, 60_000)
    theta = rng.uniform(0, 1, 60_000) * bending_limit(phi, P)
    assert _chi2(theta, phi, probs) > 10 * CHI2_CRIT_47_P001


def test_samples_lie_within_the_tension_limits_and_are_reproducible():
    theta, phi = sample_arcs(np.random.default_rng(7), 5000, P)
    assert np.all(theta >= 0) and np.all(theta <= bending_limit(phi, P))
    again = sample_arcs(np.random.default_rng(7), 5000, P)
    assert np.array_equal(theta, again[0]) and np.array_equal(phi, again[1])


def test_clip_to_workspace():
    theta, clipped = clip_to_workspace(np.array([0.5, 3.0]), np.array([0.0, np.radians(30)]), P)
    assert theta[0] == 0.5 and not clipped[0]
    assert clipped[1] and theta[1] == pytest.approx(bending_limit(np.radians(30), P))
