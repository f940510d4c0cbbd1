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
    assert set(pinned.files) <= set(current_v1), "a pinned quantity is gone"
    # added since the pin: the Obstacle task's contact force (0 without simulated obstacles)
    added = set(current_v1) - set(pinned.files)
    # (and the vector env's presence masks of it, ``info._contact_force``)
    assert all(key.endswith(("info.contact_force", "._contact_force")) for key in added)
    forces = [key for key in added if key.endswith("info.contact_force")]
    assert forces and all(not np.nansum(np.abs(current_v1[key])) for key in forces)
    rollouts = {key.split("|")[0] for key in pinned.files}
    for backend in ("CCKA", "Bullet"):
        for task in ("Reach", "Track", "Pose", "Obstacle"):
            assert any(r.startswith(f"{backend}{task}/") for r in rollouts), (backend, task)


#: Rollouts compared to 1e-12 instead of bit for bit. The single env's two-section (tdcr2)
#: rollouts were pinned from the scalar lane that issue 22 deleted: it summed the statics'
#: matrix products in Python floats, where the one path now multiplies matrices in numpy (as
#: the batched env always did, whose pins stay bit-identical). The two orders of summation
#: differ in the last bits only: measured at most 4.4e-16 (2 ulp) on any quantity.
LAST_BITS = ("CCKAPose/",)


def test_pinned_v1_is_reproduced_bit_for_bit(current_v1):
    """Same arithmetic: every quantity equal (atol 0; NaN marks absent entries), except the
    :data:`LAST_BITS` rollouts (to 1e-12)."""
    import pinned_trajectories_v1

    pinned = np.load(pinned_trajectories_v1.PATH)
    bad = []
    for key in pinned.files:
        got, want = current_v1[key], pinned[key]
        if got.shape != want.shape:
            bad.append(key)
        elif key.startswith(LAST_BITS):
            if not np.allclose(got, want, rtol=0.0, atol=1e-12, equal_nan=True):
                bad.append(key)
        elif not np.array_equal(got, want, equal_nan=True):
            bad.append(key)
    assert not bad, f"{len(bad)} pinned quantities differ, e.g. {bad[:10]}"


# -- MuJoCo: every MuJoCo id, bit for bit --------------------------------------------------------
@pytest.fixture(scope="module")
def current_mujoco():
    import pinned_trajectories_mujoco

    return pinned_trajectories_mujoco.trajectories()


def test_pinned_mujoco_covers_every_mujoco_id_and_is_reproduced_bit_for_bit(current_mujoco):
    import pinned_trajectories_mujoco

    pinned = np.load(pinned_trajectories_mujoco.PATH)
    assert sorted(pinned.files) == sorted(current_mujoco)
    rollouts = {key.split("|")[0] for key in pinned.files}
    for task in ("Reach", "Track", "Pose", "Obstacle"):
        assert any(r.startswith(f"MuJoCo{task}/") for r in rollouts), task
    bad = [
        key
        for key in pinned.files
        if not np.array_equal(current_mujoco[key], pinned[key], equal_nan=True)
    ]
    assert not bad, f"{len(bad)} pinned quantities differ, e.g. {bad[:10]}"
