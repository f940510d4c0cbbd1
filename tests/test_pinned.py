"""Every id reproduces the rollouts pinned on another machine, within stated tolerances
(``tests/tolerances.py``), and repeats itself exactly within one process."""

from __future__ import annotations

import numpy as np
import pytest
from pinned_trajectories import PATH, trajectories
from tolerances import ATOL_MODEL, ATOL_PHYSICS, RTOL_MODEL, RTOL_PHYSICS, close


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


# -- v1: every registered id ------------------------------------------------------
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


def _differing(current: dict, pinned, rtol: float, atol: float) -> list[str]:
    """The pinned quantities that today's code does not reproduce within the tolerances."""
    return [key for key in pinned.files if not close(current[key], pinned[key], rtol, atol)]


def test_pinned_v1_is_reproduced_within_tolerance(current_v1):
    """Every quantity of every rollout within :data:`tolerances.RTOL_MODEL` (CCKA) or
    :data:`tolerances.RTOL_PHYSICS` (pybullet) of the pin, which another machine wrote."""
    import pinned_trajectories_v1

    pinned = np.load(pinned_trajectories_v1.PATH)
    model = [k for k in pinned.files if not k.startswith("Bullet")]
    physics = [k for k in pinned.files if k.startswith("Bullet")]
    assert model and physics
    bad = [k for k in model if not close(current_v1[k], pinned[k], RTOL_MODEL, ATOL_MODEL)]
    bad += [k for k in physics if not close(current_v1[k], pinned[k], RTOL_PHYSICS, ATOL_PHYSICS)]
    assert not bad, f"{len(bad)} pinned quantities differ, e.g. {bad[:10]}"


def test_pinned_v1_tolerance_is_tight_enough_to_catch_a_change(current_v1):
    """The comparison fails for a change far below anything observable (1e-7 relative)."""
    import pinned_trajectories_v1

    pinned = np.load(pinned_trajectories_v1.PATH)
    key = next(k for k in pinned.files if k.startswith("CCKAReach/tension/gc0|obs"))
    assert close(current_v1[key], pinned[key])
    assert not close(current_v1[key] * (1 + 1e-7), pinned[key])


# -- MuJoCo: every MuJoCo id --------------------------------------------------------
@pytest.fixture(scope="module")
def current_mujoco():
    import pinned_trajectories_mujoco

    return pinned_trajectories_mujoco.trajectories()


def test_pinned_mujoco_covers_every_mujoco_id_and_is_reproduced_within_tolerance(current_mujoco):
    import pinned_trajectories_mujoco

    pinned = np.load(pinned_trajectories_mujoco.PATH)
    assert sorted(pinned.files) == sorted(current_mujoco)
    rollouts = {key.split("|")[0] for key in pinned.files}
    for task in ("Reach", "Track", "Pose", "Obstacle"):
        assert any(r.startswith(f"MuJoCo{task}/") for r in rollouts), task
    bad = _differing(current_mujoco, pinned, RTOL_PHYSICS, ATOL_PHYSICS)
    assert not bad, f"{len(bad)} pinned quantities differ, e.g. {bad[:10]}"


# -- determinism: same seed, same process -> identical, bit for bit ---------------------------
@pytest.mark.parametrize(
    "env_id, kwargs",
    [
        ("cdcr_gym/CCKAReach-v0", {"randomize": {"youngs_modulus": [30e9, 40e9]}}),
        ("cdcr_gym/CCKAObstacle-v0", {"action_mode": "tension"}),
        ("cdcr_gym/BulletReach-v0", {}),
        ("cdcr_gym/MuJoCoPose-v0", {"imperfections": {"tip_noise": 0.001}}),
    ],
)
def test_same_seed_gives_identical_rollouts_within_one_process(env_id, kwargs):
    import pinned_trajectories_v1 as v1

    runs = []
    for _ in range(2):
        out: dict[str, np.ndarray] = {}
        v1._single(out, "r", env_id, 6, 11, **kwargs)
        runs.append(out)
    assert sorted(runs[0]) == sorted(runs[1])
    for key, value in runs[0].items():
        assert np.array_equal(value, runs[1][key], equal_nan=True), key
