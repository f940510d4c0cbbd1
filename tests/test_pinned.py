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


# -- v1: every registered id, bit for bit ------------------------------------------------------
@pytest.fixture(scope="module")
def current_v1():
    import pinned_trajectories_v1

    return pinned_trajectories_v1.trajectories()


def test_pinned_v1_covers_every_registered_id(current_v1):
    import pinned_trajectories_v1

    pinned = np.load(pinned_trajectories_v1.PATH)
    assert sorted(pinned.files) == sorted(current_v1)
    rollouts = {key.split("|")[0] for key in pinned.files}
    for backend in ("CCKA", "Bullet"):
        for task in ("Reach", "Track", "Pose", "Obstacle"):
            assert any(r.startswith(f"{backend}{task}/") for r in rollouts), (backend, task)


def test_pinned_v1_is_reproduced_bit_for_bit(current_v1):
    """Same code path arithmetic: every quantity equal (atol 0; NaN marks absent entries)."""
    import pinned_trajectories_v1

    pinned = np.load(pinned_trajectories_v1.PATH)
    bad = []
    for key in pinned.files:
        got, want = current_v1[key], pinned[key]
        if got.shape != want.shape or not np.array_equal(got, want, equal_nan=True):
            bad.append(key)
    assert not bad, f"{len(bad)} pinned quantities differ, e.g. {bad[:10]}"
