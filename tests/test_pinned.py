"""The paper robot's envs reproduce the trajectories pinned before the n-section refactor."""

from __future__ import annotations

import numpy as np
import pytest
from pinned_trajectories import PATH, trajectories


@pytest.fixture(scope="module")
def current():
    return trajectories()


def test_pinned_file_exists_and_covers_every_trajectory(current):
    pinned = np.load(PATH)
    assert sorted(pinned.files) == sorted(current)


@pytest.mark.parametrize("key", sorted(np.load(PATH).files))
def test_trajectory_matches_the_pinned_one_to_1e_12(current, key):
    pinned = np.load(PATH)[key]
    got = current[key]
    assert got.shape == pinned.shape
    np.testing.assert_allclose(got, pinned, rtol=0.0, atol=1e-12)
