"""The batched CCKA env against a SyncVectorEnv of single envs, and its SB3 adapter.

Equivalence: same seeds and actions give the same observations, rewards, terminations,
truncations and infos (to float rounding: a one-env core computes on Python floats where a batch
computes on rows, the same arithmetic, but a matrix product may sum in another order), across
autoresets, in every action mode. No timing here: throughput is
measured by ``cdcr-gym bench``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import cdcr_gym
from cdcr_gym.envs.vector import CDCRVectorEnv
from cdcr_gym.model.workspace import sample_arcs, sample_arcs_each
from cdcr_gym.params import RobotParams

ENV_ID = "cdcr_gym/CCKAReach-v0"
INFO_FLOAT_KEYS = ("distance", "tip", "goal", "tensions", "cable_lengths")

pytestmark = pytest.mark.filterwarnings("error")


def make_pair(n, autoreset_mode=AutoresetMode.NEXT_STEP, **kwargs):
    batched = gym.make_vec(
        ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        autoreset_mode=autoreset_mode,
        **kwargs,
    )
    sync = gym.make_vec(
        ENV_ID,
        num_envs=n,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": autoreset_mode},
        **kwargs,
    )
    return batched, sync


def assert_obs_close(a, b):
    if isinstance(b, dict):
        assert set(a) == set(b)
        for key in b:
            assert_obs_close(a[key], b[key])
        return
    assert a.shape == b.shape and a.dtype == b.dtype
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6)  # float32, values <= ~1.3


def assert_info_close(a, b, mask=None):
    for key in INFO_FLOAT_KEYS:
        m = np.ones(len(b[key]), bool) if mask is None else mask
        np.testing.assert_allclose(a[key][m], b[key][m], rtol=0, atol=1e-12, err_msg=key)
    m = slice(None) if mask is None else mask
    assert np.array_equal(a["is_success"][m], b["is_success"][m])


def run_equivalence(n, steps, seed, autoreset_mode=AutoresetMode.NEXT_STEP, **kwargs):
    batched, sync = make_pair(n, autoreset_mode, **kwargs)
    obs_b, info_b = batched.reset(seed=seed)
    obs_s, info_s = sync.reset(seed=seed)
    assert_obs_close(obs_b, obs_s)
    assert_info_close(info_b, info_s)
    rng = np.random.default_rng(seed)
    ends = 0
    for _ in range(steps):
        actions = rng.uniform(-1.3, 1.3, (n, 3)).astype(np.float32)  # some out of range
        out_b = batched.step(actions)
        out_s = sync.step(actions)
        assert_obs_close(out_b[0], out_s[0])
        np.testing.assert_allclose(out_b[1], out_s[1], rtol=0, atol=1e-12)
        assert np.array_equal(out_b[2], out_s[2])  # terminated
        assert np.array_equal(out_b[3], out_s[3])  # truncated
        assert_info_close(out_b[4], out_s[4])
        if "final_obs" in out_s[4]:
            done = out_s[4]["_final_obs"]
            assert np.array_equal(out_b[4]["_final_obs"], done)
            for i in np.flatnonzero(done):
                assert_obs_close(out_b[4]["final_obs"][i], out_s[4]["final_obs"][i])
            assert_info_close(out_b[4]["final_info"], out_s[4]["final_info"], done)
        else:
            assert "final_obs" not in out_b[4]
        ends += int(np.sum(out_s[2] | out_s[3]))
    batched.close()
    sync.close()
    return ends


@pytest.mark.parametrize("action_mode", ["tension_delta", "tension", "length_delta"])
@pytest.mark.parametrize("goal_conditioned", [False, True])
def test_batched_equals_sync_vector_env_across_autoresets(action_mode, goal_conditioned):
    ends = run_equivalence(
        5,
        230,
        seed=7,
        action_mode=action_mode,
        goal_conditioned=goal_conditioned,
        length_step=0.01,
    )
    assert ends == 2 * 5  # two truncations per env: the NEXT_STEP autoreset was exercised


def test_equivalence_with_random_starts_sparse_reward_and_terminations():
    ends = run_equivalence(
        6,
        150,
        seed=3,
        initial_state="random",
        reward_type="sparse",
        terminate_on_success=True,
        distance_threshold=0.25,
        tension_step=0.2,
    )
    assert ends > 6  # terminations (random lengths) as well as truncations


@pytest.mark.parametrize("goal_conditioned", [False, True])
def test_equivalence_same_step_autoreset(goal_conditioned):
    ends = run_equivalence(
        4,
        120,
        seed=11,
        autoreset_mode=AutoresetMode.SAME_STEP,
        goal_conditioned=goal_conditioned,
        initial_state="random",
        terminate_on_success=True,
        distance_threshold=0.25,
        tension_step=0.2,
    )
    assert ends > 4


def test_make_vec_registration_and_spaces():
    env = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point")
    assert isinstance(env, CDCRVectorEnv)
    assert env.max_episode_steps == cdcr_gym.MAX_EPISODE_STEPS
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    single = gym.make(ENV_ID)
    assert env.single_observation_space == single.observation_space
    assert env.single_action_space == single.action_space
    assert env.observation_space.shape == (3, 18) and env.action_space.shape == (3, 3)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    obs, reward, term, trunc, info = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs)
    assert reward.shape == term.shape == trunc.shape == (3,)
    assert reward.dtype == np.float64 and term.dtype == trunc.dtype == np.bool_
    assert info["tip"].shape == (3, 3) and info["is_success"].dtype == np.bool_
    assert info["_distance"].all()
    # the default vectorization mode picks the batched env too; the short id works
    assert isinstance(gym.make_vec("CCKAReach-v0", num_envs=2), CDCRVectorEnv)
    dict_env = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", goal_conditioned=True
    )
    assert (
        dict_env.single_observation_space
        == gym.make(ENV_ID, goal_conditioned=True).observation_space
    )


def test_params_and_kwargs_reach_the_batched_env():
    env = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        params=RobotParams(length=0.5),
        max_episode_steps=7,
    )
    _, info = env.reset(seed=0)
    assert np.allclose(info["tip"], [0.0, 0.0, 0.5])
    for t in range(7):
        _, _, _, trunc, _ = env.step(np.zeros((2, 3), np.float32))
        assert trunc.all() == (t == 6)


def test_reset_with_seed_list_mask_and_options_matches_single_envs():
    n = 4
    env = CDCRVectorEnv(n, initial_state="random")
    seeds = [10, None, 12, 13]
    obs, info = env.reset(seed=seeds)
    for i, s in enumerate(seeds):
        if s is not None:
            single_obs, single_info = gym.make(ENV_ID, initial_state="random").reset(seed=s)
            np.testing.assert_allclose(obs[i], single_obs, atol=1e-6)
    # options: one goal for all, per-env initial tensions
    goal = [0.1, 0.0, 0.7]  # off the surface: projected as by the single env
    tensions = np.array([[0.0, 0.0, 0.0], [80.0, 0.0, 0.0], [0.0, 40.0, 40.0], [1.0, 2.0, 3.0]])
    _, info = env.reset(seed=0, options={"goal": goal, "initial_tensions": tensions})
    for i in range(n):
        _, single_info = gym.make(ENV_ID).reset(
            seed=i, options={"goal": goal, "initial_tensions": tensions[i]}
        )
        for key in INFO_FLOAT_KEYS:
            np.testing.assert_allclose(info[key][i], single_info[key], atol=1e-12)
    # reset_mask: only the selected envs restart (step counters too)
    for _ in range(5):
        env.step(np.zeros((n, 3), np.float32))
    mask = np.array([True, False, True, False])
    before = env.step(np.zeros((n, 3), np.float32))[0].copy()
    obs, info = env.reset(options={"reset_mask": mask})
    assert np.array_equal(obs[~mask], before[~mask])
    assert np.array_equal(info["_tip"], mask)
    assert np.array_equal(env._steps, [0, 6, 0, 6])


def test_batched_sampler_draws_exactly_like_per_env_sampling():
    params = RobotParams(max_tension=50.0)  # a smaller hexagon: more rejections
    rngs = [np.random.default_rng(i) for i in range(300)]
    twins = [np.random.default_rng(i) for i in range(300)]
    for _ in range(3):
        theta, phi = sample_arcs_each(rngs, params)
        expected = [sample_arcs(r, 1, params) for r in twins]
        assert np.array_equal(theta, [t[0] for t, _ in expected])
        assert np.array_equal(phi, [p[0] for _, p in expected])


def test_returned_arrays_are_never_overwritten():
    env = CDCRVectorEnv(3)
    obs, info = env.reset(seed=0)
    kept_obs, kept_tip = obs, info["tip"]
    copies = obs.copy(), info["tip"].copy()
    row = obs[1]  # a view of the buffer keeps it alive too
    row_copy = row.copy()
    for _ in range(6):
        env.step(env.action_space.sample())
    assert np.array_equal(kept_obs, copies[0]) and np.array_equal(kept_tip, copies[1])
    assert np.array_equal(row, row_copy)


def test_validation():
    with pytest.raises(ValueError, match="num_envs"):
        CDCRVectorEnv(0)
    with pytest.raises(ValueError, match="action_mode"):
        CDCRVectorEnv(2, action_mode="torque")
    with pytest.raises(ValueError, match="render_mode"):
        CDCRVectorEnv(2, render_mode="rgb_array")
    with pytest.raises(ValueError, match="max_episode_steps"):
        CDCRVectorEnv(2, max_episode_steps=0)
    with pytest.raises(ValueError, match="initial_state"):
        CDCRVectorEnv(2, initial_state=["straight"])
    env = CDCRVectorEnv(2)
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros((2, 3)))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match="unknown"):
        env.reset(options={"gaol": [0, 0, 0.6]})
    with pytest.raises(ValueError, match="initial_tensions"):
        env.reset(options={"initial_tensions": [0.0, 100.0, 0.0]})


# -- stable-baselines3 adapter ---------------------------------------------------------------


def test_sb3_adapter_matches_dummy_vec_env():
    from stable_baselines3.common.vec_env import DummyVecEnv

    from training.run.sb3_vec import BatchedVecEnv

    n, states = 4, ["straight", "random"]
    kwargs = {"terminate_on_success": True, "distance_threshold": 0.25, "tension_step": 0.2}
    batched = BatchedVecEnv(
        n, seed=5, per_env_kwargs=[{"initial_state": s} for s in states], **kwargs
    )
    dummy = DummyVecEnv(
        [(lambda s=states[i % 2]: gym.make(ENV_ID, initial_state=s, **kwargs)) for i in range(n)]
    )
    dummy.seed(5)
    np.testing.assert_allclose(batched.reset(), dummy.reset(), atol=1e-6)
    rng = np.random.default_rng(0)
    terminal = 0
    for _ in range(120):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        obs_b, rew_b, done_b, infos_b = batched.step(actions)
        obs_d, rew_d, done_d, infos_d = dummy.step(actions)
        np.testing.assert_allclose(obs_b, obs_d, atol=1e-6)
        np.testing.assert_allclose(rew_b, rew_d, atol=1e-6)
        assert rew_b.dtype == rew_d.dtype and np.array_equal(done_b, done_d)
        for ib, id_ in zip(infos_b, infos_d):
            assert set(ib) == set(id_)
            assert ib["is_success"] == id_["is_success"]
            assert ib["TimeLimit.truncated"] == id_["TimeLimit.truncated"]
            np.testing.assert_allclose(ib["tip"], id_["tip"], atol=1e-12)
            if "terminal_observation" in id_:
                terminal += 1
                np.testing.assert_allclose(
                    ib["terminal_observation"], id_["terminal_observation"], atol=1e-6
                )
        for rb, rd in zip(batched.reset_infos, dummy.reset_infos):
            np.testing.assert_allclose(rb["goal"], rd["goal"], atol=1e-12)
    assert terminal > n  # terminations and truncations both happened
    assert batched.get_attr("action_mode") == ["tension_delta"] * n
    assert batched.get_attr("initial_state") == ["straight", "random"] * 2
    assert batched.get_attr("np_random_seed", indices=[1]) == [6]
    assert batched.env_is_wrapped(gym.Wrapper) == [False] * n


def test_sb3_adapter_takes_shared_per_env_keys_and_rejects_varying_ones():
    """A key equal in every per_env_kwargs entry (randomize, imperfections) applies to all
    envs, as in a DummyVecEnv of single envs with those kwargs; a key that differs is an error."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from training.run.sb3_vec import BatchedVecEnv

    n, states = 4, ["straight", "random"]
    shared = {
        "randomize": {"youngs_modulus": [26e9, 40e9], "cable_radius": [0.0275, 0.0305]},
        "imperfections": {"tip_noise": 0.001, "tension_response": 0.44, "actuator_noise": 0.5},
    }
    per_env = [{"initial_state": s, **shared} for s in states]
    batched = BatchedVecEnv(n, seed=3, per_env_kwargs=per_env)
    dummy = DummyVecEnv(
        [(lambda s=states[i % 2]: gym.make(ENV_ID, initial_state=s, **shared)) for i in range(n)]
    )
    dummy.seed(3)
    np.testing.assert_allclose(batched.reset(), dummy.reset(), atol=1e-6)
    e_values = {info["randomized/youngs_modulus"] for info in batched.reset_infos}
    assert len(e_values) == n and all(26e9 <= e <= 40e9 for e in e_values)
    rng = np.random.default_rng(1)
    for _ in range(30):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        obs_b, rew_b, _, infos_b = batched.step(actions)
        obs_d, rew_d, _, infos_d = dummy.step(actions)
        np.testing.assert_allclose(obs_b, obs_d, atol=1e-6)
        np.testing.assert_allclose(rew_b, rew_d, atol=1e-6)
        for ib, id_ in zip(infos_b, infos_d):
            np.testing.assert_allclose(ib["tip"], id_["tip"], atol=1e-12)
    with pytest.raises(ValueError, match=r"per_env_kwargs.*varying \['tension_step'\]"):
        BatchedVecEnv(2, per_env_kwargs=[{"tension_step": 0.1}, {"tension_step": 0.2}])
    with pytest.raises(ValueError, match=r"varying \['imperfections'\]"):
        BatchedVecEnv(2, per_env_kwargs=[{"imperfections": {"tip_noise": 0.001}}, {}])


def test_sb3_ppo_learns_with_the_adapter_and_her_relabels():
    from stable_baselines3 import PPO, SAC, HerReplayBuffer
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from training.run.sb3_vec import BatchedVecEnv

    venv = VecNormalize(VecMonitor(BatchedVecEnv(4, seed=0, max_episode_steps=20)))
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=256)
    assert model.num_timesteps == 256
    assert len(model.ep_success_buffer) > 0  # is_success reached SB3's logger

    goal_env = BatchedVecEnv(2, seed=0, goal_conditioned=True, max_episode_steps=10)
    her = SAC(
        "MultiInputPolicy",
        goal_env,
        replay_buffer_class=HerReplayBuffer,
        learning_starts=40,
        batch_size=16,
        seed=0,
        device="cpu",
    )
    her.learn(total_timesteps=60)
    assert her.num_timesteps == 60


# -- the bench command (formatting only: timings are not asserted) ---------------------------
def test_bench_table_and_checks_format():
    from training.studies import bench

    rows = [
        {
            "key": "ccka_single",
            "name": "CCKAReach-v0 (gym.make)",
            "envs": 1,
            "note": "",
            "median": 2e5,
            "min": 1.9e5,
            "max": 2.1e5,
        },
        {
            "key": "pendulum",
            "name": "Pendulum-v1 (gym.make)",
            "envs": 1,
            "note": "",
            "median": 1e5,
            "min": 1e5,
            "max": 1e5,
        },
        {
            "key": "bullet",
            "name": "BulletReach-v0 (gym.make)",
            "envs": 1,
            "note": "unavailable: ImportError: no pybullet",
        },
    ]
    result = {
        "machine": bench.machine(),
        "rows": rows,
        "load_before": "0",
        "load_after": "0",
        "repeats": 1,
        "quick": True,
        "checks": bench._checks({r["key"]: r for r in rows}),
    }
    text = bench.to_markdown(result)
    assert "| CCKAReach-v0 (gym.make) | 1 | 200 k | 190 k–210 k |" in text
    assert "unavailable: ImportError" in text
    assert "| CCKAReach-v0 / Pendulum-v1 (gym.make) | 2 | ≥ 0.5 | yes |" in text
    measured = bench._single_env("Pendulum-v1", min_time=0.0, repeats=1)
    assert measured["median"] > 0
    with pytest.raises(SystemExit):
        bench.main(["--out", "bench.txt"])


@pytest.mark.parametrize("action_mode", ["tension_delta", "tension"])
@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_single_env_equals_batched_rows(robot, action_mode):
    """The single env (the core at N = 1) gives the batched env's numbers and info entries,
    with Python scalars for the per-env scalars."""
    single = gym.make("cdcr_gym/CCKAReach-v0", robot=robot, action_mode=action_mode)
    vec = gym.make_vec(
        "cdcr_gym/CCKAReach-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        robot=robot,
        action_mode=action_mode,
    )
    o1, _ = single.reset(seed=3)
    ov, _ = vec.reset(seed=[3, 4])
    np.testing.assert_array_equal(o1, ov[0])
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1.2, 1.2, single.action_space.shape).astype(np.float32)
        o1, r1, _, _, i1 = single.step(a)
        ov, rv, _, _, iv = vec.step(np.stack([a, a]))
        assert o1.dtype == np.float32 and o1.shape == single.observation_space.shape
        np.testing.assert_allclose(o1, ov[0], rtol=0.0, atol=1e-6)
        assert type(r1) is float and abs(r1 - rv[0]) <= 1e-15
        assert set(i1) == {k for k in iv if not k.startswith("_")}
        assert type(i1["distance"]) is float and type(i1["is_success"]) is bool
        for key, value in i1.items():
            np.testing.assert_allclose(value, iv[key][0], rtol=0.0, atol=1e-15, err_msg=key)
            if key not in ("distance", "is_success"):
                assert value.shape == iv[key][0].shape, key


def test_bench_env_share_check_is_an_upper_bound():
    """The PPO env-share target is met when the share is at most 10 %, not at least."""
    from training.studies import bench

    def rows(share):
        return {"ppo_batched": {"key": "ppo_batched", "median": 1.0, "env_share": share}}

    def check(share):
        (row,) = [c for c in bench._checks(rows(share), "batched") if "env share" in c["name"]]
        return row

    assert check(0.05)["ok"] is True
    assert check(0.25)["ok"] is False
    assert all("env share" not in c["name"] for c in bench._checks(rows(0.05)))
    text = bench.to_markdown(
        {
            "machine": bench.machine(),
            "rows": [],
            "load_before": "0",
            "load_after": "0",
            "repeats": 1,
            "quick": True,
            "checks": [check(0.05)],
        }
    )
    assert "≤ 0.1 | yes |" in text
