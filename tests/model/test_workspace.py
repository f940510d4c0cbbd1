"""model.workspace: today's one-section draws, tension samples, the several-section law."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tolerances import close

from cdcr_gym import kinematics as K
from cdcr_gym.model import workspace as W
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import bending_limit
from cdcr_gym.model.workspace import clip_to_workspace, sample_arcs

pytestmark = pytest.mark.filterwarnings("error")

PAPER = RobotParams()
TDCR2 = RobotParams.preset("tdcr2")
#: The legacy one-section model's outputs on fixed inputs (tests/data/write_legacy_arrays.py).
OLD = np.load(Path(__file__).parents[1] / "data" / "legacy_workspace.npz")


def test_one_section_draws_are_todays():
    b = W.sample_arcs(np.random.default_rng(9), 3000, PAPER)
    assert close(b[0], OLD["sample_arcs_9_0"]) and close(b[1], OLD["sample_arcs_9_1"])
    b = W.sample_arcs_each([np.random.default_rng(i) for i in range(40)], PAPER)
    assert close(b[0], OLD["sample_arcs_each_0"])
    assert close(b[1], OLD["sample_arcs_each_1"])
    theta = np.linspace(0, 2, 50)
    phi = np.linspace(-3, 3, 50)
    assert close(W.area_density(theta), OLD["area_density"])
    for i, x in enumerate(W.clip_to_workspace(theta, phi, PAPER)):
        y = OLD[f"clip_to_workspace_{i}"]
        assert np.allclose(x, y, rtol=0, atol=1e-12) and x.dtype == y.dtype


def test_one_section_tension_samples_give_todays_goals_and_rng_state():
    model = PCCModel(PAPER)
    rng_new = np.random.default_rng(3)
    tensions = W.sample_tensions(rng_new, PAPER, 500)
    tips = model.tip_from_bending(model.bending_from_tensions(tensions))
    assert np.max(np.abs(tips - OLD["tips_3_500"])) <= 1e-12
    assert rng_new.random() == OLD["next_random_3_500"]  # the same consumption
    assert np.all(tensions >= 0) and np.all(tensions <= PAPER.max_tension)
    assert np.all(np.min(tensions, axis=-1) == 0.0)  # minimal: one slack cable


@pytest.mark.parametrize("params", [PAPER, TDCR2], ids=["paper", "tdcr2"])
def test_each_equals_per_generator_calls(params):
    seeds = range(25)
    each = W.sample_tensions_each([np.random.default_rng(s) for s in seeds], params)
    one = np.concatenate([W.sample_tensions(np.random.default_rng(s), params, 1) for s in seeds])
    assert np.array_equal(each, one) and each.shape == (25, params.n_cables)


def test_several_sections_tensions_are_uniform_in_the_box():
    samples = W.sample_tensions(np.random.default_rng(0), TDCR2, 20_000)
    assert samples.shape == (20_000, 6)
    assert np.all(samples >= 0) and np.all(samples <= TDCR2.max_tension)
    # chi-square per cable, 10 bins (9 dof): critical value 27.88 at p = 0.001
    for i in range(6):
        counts = np.histogram(samples[:, i], bins=10, range=(0, TDCR2.max_tension))[0]
        assert np.sum((counts - 2000) ** 2 / 2000) < 27.88
    # independence of neighbouring cables: near-zero correlation
    corr = np.corrcoef(samples.T)
    assert np.max(np.abs(corr - np.eye(6))) < 0.03
    # negative control: the same test rejects squared uniforms
    skewed = TDCR2.max_tension * np.random.default_rng(1).random(20_000) ** 2
    counts = np.histogram(skewed, bins=10, range=(0, TDCR2.max_tension))[0]
    assert np.sum((counts - 2000) ** 2 / 2000) > 10 * 27.88


def test_bad_input():
    with pytest.raises(ValueError, match="n"):
        W.sample_tensions(np.random.default_rng(0), PAPER, 0)
    with pytest.raises(ValueError, match="params"):
        W.sample_tensions(np.random.default_rng(0), "paper", 2)
    with pytest.raises(ValueError, match="params"):
        W.sample_arcs(np.random.default_rng(0), 3, TDCR2)


# -- area-uniform goal sampling, chi-square (was tests/test_workspace.py) ----------------------
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
