"""model.workspace: today's one-section draws, tension samples, the several-section law."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cdcr_gym.model import workspace as W
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams

pytestmark = pytest.mark.filterwarnings("error")

PAPER = RobotParams()
TDCR2 = RobotParams.preset("tdcr2")
#: The legacy one-section model's outputs on fixed inputs (tests/data/write_legacy_arrays.py).
OLD = np.load(Path(__file__).parent / "data" / "legacy_workspace.npz")


def test_one_section_draws_are_todays():
    b = W.sample_arcs(np.random.default_rng(9), 3000, PAPER)
    assert np.array_equal(OLD["sample_arcs_9_0"], b[0]) and np.array_equal(
        OLD["sample_arcs_9_1"], b[1]
    )
    b = W.sample_arcs_each([np.random.default_rng(i) for i in range(40)], PAPER)
    assert np.array_equal(OLD["sample_arcs_each_0"], b[0])
    assert np.array_equal(OLD["sample_arcs_each_1"], b[1])
    theta = np.linspace(0, 2, 50)
    phi = np.linspace(-3, 3, 50)
    assert np.array_equal(W.area_density(theta), OLD["area_density"])
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
