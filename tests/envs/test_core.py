"""envs.core: the one batched reset/step; the single env is the core at N = 1."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.controllers import AnalyticIKController
from cdcr_gym.defaults import NOMINAL_TIMESTEP
from cdcr_gym.envs.core import OPTION_KEYS, EnvCore
from cdcr_gym.model.params import RobotParams
from cdcr_gym.tasks.obstacle import Obstacle
from cdcr_gym.tasks.pose import Pose
from cdcr_gym.tasks.reach import Reach
from cdcr_gym.tasks.track import Track

PAPER = RobotParams()


def _core(n, task=None, **kwargs):
    return EnvCore(AnalyticBackend(PAPER, num_robots=n), task or Reach(), **kwargs)


def test_no_scalar_lane_is_left():
    import cdcr_gym.backends.analytic as analytic
    import cdcr_gym.backends.base as base
    import cdcr_gym.envs.actuation as actuation
    import cdcr_gym.envs.core as core
    import cdcr_gym.model.chain as chain
    import cdcr_gym.tasks.base as tasks_base
    import cdcr_gym.tasks.reach as reach

    for module in (analytic, base, actuation, core, chain, tasks_base, reach):
        owners = [module] + [
            v for v in vars(module).values() if getattr(v, "__module__", "") == module.__name__
        ]
        for owner in owners:
            names = [n for n in dir(owner) if n.endswith("_one") and not n.startswith("__")]
            assert not names, (module.__name__, owner, names)


@pytest.mark.parametrize("task", [Reach, Pose, Track, Obstacle])
def test_rows_of_n_envs_equal_n_cores_of_one_env(task):
    """One core of 3 envs and 3 cores of one env: the same outputs row by row (the one-env
    core computes on Python floats where the batch computes on rows: same arithmetic)."""
    n, steps = 3, 6
    params = RobotParams.preset("tdcr2") if task is Pose else PAPER
    big = EnvCore(AnalyticBackend(params, num_robots=n), task(), action_mode="tension")
    ones = [EnvCore(AnalyticBackend(params), task(), action_mode="tension") for _ in range(n)]
    rngs = [np.random.default_rng(i) for i in range(n)]
    big.reset(np.arange(n), rngs)
    for i, core in enumerate(ones):
        core.reset(np.arange(1), [np.random.default_rng(i)])
    actions = np.random.default_rng(9).uniform(-1, 1, (steps, n, params.n_cables))
    for a in actions:
        big.step(a)
        obs, reward, success, info = big.observe()
        for i, core in enumerate(ones):
            core.step(a[i : i + 1])
            o, r, s, inf = core.observe()
            np.testing.assert_allclose(o[0], obs[i], rtol=0, atol=1e-6)
            np.testing.assert_allclose(r[0], reward[i], rtol=0, atol=1e-12)
            assert s[0] == success[i]
            for key in info:
                np.testing.assert_allclose(inf[key][0], info[key][i], rtol=0, atol=1e-12)


def test_reset_options_are_parsed_in_one_place():
    core = _core(2)
    assert core.reset_options(None) == (None, None, None)
    idx, tensions, goal = core.reset_options({"goal": [0.1, 0.0, 0.6]})
    assert idx is None and tensions is None and goal.tolist() == [[0.1, 0.0, 0.6]] * 2
    idx, _, _ = core.reset_options({"reset_mask": np.array([False, True])}, allow_mask=True)
    assert idx.tolist() == [1]
    with pytest.raises(ValueError, match="unknown keys"):
        core.reset_options({"reset_mask": np.array([True, True])})
    with pytest.raises(ValueError, match="select at least one"):
        core.reset_options({"reset_mask": np.array([False, False])}, allow_mask=True)
    with pytest.raises(ValueError, match="options must be None or a dict"):
        core.reset_options("goal")
    assert OPTION_KEYS == ("goal", "initial_tensions", "initial_displacements")


def test_termination_in_one_place():
    core = _core(3, terminate_on_success=True)
    success = np.array([True, False, False])
    assert core.terminated(success).tolist() == [True, False, False]
    core = _core(3, Obstacle(terminate_on_collision=True))
    core.task.collision[:] = [False, True, False]
    assert core.terminated(np.ones(3, bool)).tolist() == [False, True, False]


def test_the_single_env_is_a_core_of_one_env():
    env = gym.make("cdcr_gym/CCKAReach-v0")
    assert isinstance(env.unwrapped.core, EnvCore) and env.unwrapped.core.num_envs == 1
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(np.zeros(3, np.float32))
    assert isinstance(reward, float) and isinstance(terminated, bool)
    assert isinstance(info["distance"], float) and isinstance(info["is_success"], bool)
    assert info["tip"].shape == (3,) and obs.dtype == np.float32


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"initial_state": "bent"}, "initial_state"),
        ({"goal_conditioned": 1}, "goal_conditioned"),
        ({"terminate_on_success": "yes"}, "terminate_on_success"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        _core(1, **kwargs)


@pytest.mark.parametrize(
    "env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/MuJoCoReach-v0", "cdcr_gym/CCKAObstacle-v0"]
)
def test_tip_velocity_field_is_the_tip_displacement_per_control_timestep(env_id):
    plain = gym.make(env_id)
    env = gym.make(env_id, observe_tip_velocity=True)
    size = plain.observation_space.shape[0]
    assert env.observation_space.shape == (size + 3,)
    assert env.unwrapped.observation_spec.names[-1] == "tip_velocity"
    dt = env.unwrapped.backend.control_timestep or NOMINAL_TIMESTEP
    obs, info = env.reset(seed=2)
    obs_plain, _ = plain.reset(seed=2)
    assert np.array_equal(obs[:size], obs_plain) and np.all(obs[size:] == 0.0)
    rng = np.random.default_rng(0)
    for _ in range(15):
        tip = info["tip"]
        action = rng.uniform(-1, 1, 3).astype(np.float32)
        obs, _, _, _, info = env.step(action)
        obs_plain, *_ = plain.step(action)
        assert np.array_equal(obs[:size], obs_plain)  # the task's fields are unchanged
        expected = ((info["tip"] - tip) / dt).astype(np.float32)
        np.testing.assert_allclose(obs[size:], expected, rtol=1e-5, atol=1e-9)
        assert env.observation_space.contains(obs)
    assert np.abs(obs[size:]).max() > 0.0
    obs, _ = env.reset(seed=3)
    assert np.all(obs[size:] == 0.0)  # a reset starts from rest


def test_tip_velocity_in_the_batched_env_matches_single_envs_across_autoresets():
    kwargs = {"observe_tip_velocity": True, "initial_state": "random"}
    vec = gym.make_vec(
        "cdcr_gym/CCKAReach-v0",
        num_envs=3,
        vectorization_mode="vector_entry_point",
        max_episode_steps=4,
        **kwargs,
    )
    singles = [gym.make("cdcr_gym/CCKAReach-v0", max_episode_steps=4, **kwargs) for _ in range(3)]
    obs, _ = vec.reset(seed=[5, 6, 7])
    rows = [e.reset(seed=s)[0] for e, s in zip(singles, [5, 6, 7])]
    np.testing.assert_array_equal(obs, np.stack(rows))
    rng = np.random.default_rng(1)
    for t in range(9):
        actions = rng.uniform(-1, 1, (3, 3)).astype(np.float32)
        obs, *_ = vec.step(actions)
        for i, e in enumerate(singles):
            if t % 5 == 4:  # next-step autoreset: the vector env resets this step
                row, _ = e.reset()
                np.testing.assert_array_equal(obs[i, -3:], 0.0)
                continue
            row, *_ = e.step(actions[i])
            np.testing.assert_allclose(obs[i], row, rtol=1e-6, atol=1e-9)


def test_observe_tip_velocity_must_be_a_bool():
    with pytest.raises(ValueError, match="observe_tip_velocity"):
        gym.make("cdcr_gym/CCKAReach-v0", observe_tip_velocity="yes")


@pytest.mark.parametrize(
    "imperfections",
    [None, {"actuator_noise": 0.5}, {"tension_rate_limit": 2.0}, {"action_delay": 1}],
)
def test_the_task_moves_on_every_step_whatever_the_actuator_imperfections(imperfections):
    """Track's target moves and Obstacle's collision check runs on every step also when an
    actuator imperfection shapes the held tensions (it used to skip Task.advance)."""
    track = gym.make("cdcr_gym/CCKATrack-v0", imperfections=imperfections)
    track.reset(seed=0)
    start = track.unwrapped.task.goal.copy()
    for _ in range(10):
        track.step(np.zeros(3, np.float32))
    assert np.linalg.norm(track.unwrapped.task.goal - start) > 0.009  # 10 steps at 1 mm/step
    obstacle = gym.make("cdcr_gym/CCKAObstacle-v0", imperfections=imperfections)
    ik = AnalyticIKController.from_env(obstacle)
    obs, info = obstacle.reset(seed=0)
    clearances = [info["min_clearance"]]
    for _ in range(40):
        obs, _, _, _, info = obstacle.step(ik(obs))
        clearances.append(info["min_clearance"])
    assert len(set(clearances)) > 10 and info["collided"]  # the reach IK runs into the sphere
