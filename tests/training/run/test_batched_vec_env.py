"""``vec_env: batched`` beyond CCKA: the SB3 adapter over the MuJoCo backend (issue 21 item 6)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401 - registers the ids
from training.run.config import ConfigError, config_from_dict

pytest.importorskip("mujoco")

MJ_ID = "cdcr_gym/MuJoCoReach-v0"


def test_batched_vec_env_on_mujoco_equals_a_dummy_vec_env_of_single_envs():
    """Same seeds, same actions: the batched MuJoCo VecEnv and a DummyVecEnv of single
    ``MuJoCoReach-v0`` envs give the same observations, rewards, dones and tips."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from training.run.sb3_vec import BatchedVecEnv

    n, states = 3, ["straight", "random"]
    kwargs = {"gravity": True, "tension_step": 0.2, "max_episode_steps": 6}
    batched = BatchedVecEnv(
        n,
        seed=11,
        backend="MuJoCo",
        task="Reach",
        per_env_kwargs=[{"initial_state": s} for s in states],
        **kwargs,
    )
    dummy = DummyVecEnv(
        [(lambda s=states[i % 2]: gym.make(MJ_ID, initial_state=s, **kwargs)) for i in range(n)]
    )
    dummy.seed(11)
    try:
        assert batched.observation_space == dummy.observation_space
        assert batched.action_space == dummy.action_space
        np.testing.assert_allclose(batched.reset(), dummy.reset(), atol=1e-6)
        rng = np.random.default_rng(0)
        resets = 0
        for _ in range(9):  # past one truncation at step 6 (autoreset within the step)
            actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
            obs_b, rew_b, done_b, infos_b = batched.step(actions)
            obs_d, rew_d, done_d, infos_d = dummy.step(actions)
            np.testing.assert_allclose(obs_b, obs_d, atol=1e-5)
            np.testing.assert_allclose(rew_b, rew_d, atol=1e-6)
            assert np.array_equal(done_b, done_d)
            for ib, id_ in zip(infos_b, infos_d):
                np.testing.assert_allclose(ib["tip"], id_["tip"], atol=1e-9)
                assert ib["TimeLimit.truncated"] == id_["TimeLimit.truncated"]
                if "terminal_observation" in id_:
                    resets += 1
                    np.testing.assert_allclose(
                        ib["terminal_observation"], id_["terminal_observation"], atol=1e-5
                    )
        assert resets == n
    finally:
        batched.close()
        dummy.close()


def test_training_builds_the_batched_vec_env_for_mujoco_and_rejects_bullet():
    from training.run.envs import build_vec_env

    base = {
        "name": "t",
        "env": {
            "id": MJ_ID,
            "n_envs": 2,
            "vec_env": "batched",
            "kwargs": {"gravity": True},
            "per_env_kwargs": [{"initial_state": "straight"}, {"initial_state": "random"}],
        },
    }
    venv = build_vec_env(config_from_dict(base), seed=0)
    try:
        assert type(venv.venv.venv.core.backend).__name__ == "MuJoCoBackend"
        obs = venv.reset()
        assert obs.shape == (2, venv.observation_space.shape[0])
        obs, rew, done, infos = venv.step(np.zeros((2, 3), dtype=np.float32))
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rew))
        assert infos[0]["tip"].shape == (3,)
    finally:
        venv.close()
    bullet = {**base, "env": {**base["env"], "id": "cdcr_gym/BulletReach-v0"}}
    with pytest.raises(ConfigError, match="batched backends"):
        build_vec_env(config_from_dict(bullet), seed=0)
