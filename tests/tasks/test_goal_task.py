"""tasks.base.GoalTask: one distance, one reward, compute_reward vectorised over axis −1 (HER),
the observation written once from named values (numbers for one env, rows for a batch)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.tasks.base import GoalTask, goal_distance
from cdcr_gym.tasks.obstacle import Obstacle
from cdcr_gym.tasks.pose import Pose
from cdcr_gym.tasks.reach import Reach
from cdcr_gym.tasks.track import Track


@pytest.mark.parametrize("task", [Reach, Pose, Track, Obstacle])
def test_every_goal_task_is_a_goal_task(task):
    assert issubclass(task, GoalTask)


def test_goal_distance_is_the_euclidean_norm_over_the_last_axis():
    rng = np.random.default_rng(0)
    a, d = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    np.testing.assert_allclose(goal_distance(a, d), np.linalg.norm(a - d, axis=-1), rtol=1e-15)
    assert goal_distance([0.0, 0.0, 0.0], [3.0, 4.0, 0.0]) == 5.0


@pytest.mark.parametrize("reward_type", ["dense", "sparse"])
def test_compute_reward_relabels_batches_as_the_env_rewards(reward_type):
    env = gym.make("cdcr_gym/CCKAReach-v0", goal_conditioned=True, reward_type=reward_type)
    obs, _ = env.reset(seed=0)
    achieved, desired, rewards = [], [], []
    for a in np.random.default_rng(1).uniform(-1, 1, (20, 3)).astype(np.float32):
        obs, reward, _, _, info = env.step(a)
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(reward)
        assert reward == env.unwrapped.compute_reward(
            obs["achieved_goal"], obs["desired_goal"], info
        )
    batch = env.unwrapped.compute_reward(np.array(achieved)[None], np.array(desired)[None], None)
    assert batch.shape == (1, 20) and np.array_equal(batch[0], rewards)


def test_obstacle_compute_reward_agrees_with_evaluate():
    env = gym.make("cdcr_gym/CCKAObstacle-v0", action_mode="tension", penetration_weight=2.0)
    env.reset(seed=8)
    task = env.unwrapped.task
    for a in np.random.default_rng(8).uniform(-1, 1, (15, 3)).astype(np.float32):
        _, reward, _, _, info = env.step(a)
        batched = {k: np.asarray(v)[None] for k, v in info.items()}
        again = task.compute_reward(info["tip"][None], info["goal"][None], batched)
        assert again[0] == reward
    with pytest.raises(ValueError, match="needs info"):
        task.compute_reward(np.zeros(3), np.zeros(3), None)


@pytest.mark.parametrize("task_id", ["Reach", "Pose", "Track", "Obstacle"])
@pytest.mark.parametrize("reward_type", ["dense", "sparse"])
def test_the_single_env_returns_env_0_of_evaluate(task_id, reward_type):
    """The single env's reward, success and task info are env 0 of the batched ``evaluate``
    (the one path at N = 1): the same values and bits, as Python scalars where per-env
    numbers."""
    kwargs = {} if task_id in ("Track", "Obstacle") else {"reward_type": reward_type}
    env = gym.make(f"cdcr_gym/CCKA{task_id}-v0", **kwargs)
    env.reset(seed=3)
    task = env.unwrapped.task
    shape = (10, *env.action_space.shape)
    for a in np.random.default_rng(3).uniform(-1, 1, shape).astype(np.float32):
        _, reward, _, _, info = env.step(a)
        rewards, successes, infos = task.evaluate(env.unwrapped.core.readings)
        assert type(reward) is float
        assert np.float64(reward).tobytes() == rewards[:1].tobytes()
        assert type(info["is_success"]) is bool and info["is_success"] == successes[0]
        for key, value in infos.items():
            want = value.item() if value.ndim == 1 else value[0]
            assert type(info[key]) is type(want), key
            assert np.array_equal(info[key], want), key


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAReach-v0", "cdcr_gym/CCKAPose-v0"])
def test_a_pickled_env_keeps_its_goal_and_goal_rows_linked(env_id):
    """A snapshot (pickle) of an env must step like the original after a reset: the task's
    ``goal`` stays a view of ``goal_rows`` (a resumed training depended on it)."""
    import pickle

    env = gym.make(env_id).unwrapped
    env.reset(seed=1)
    copy = pickle.loads(pickle.dumps(env))
    task = copy.task
    assert np.shares_memory(task.goal, task.goal_rows)
    for e in (env, copy):
        e.reset(seed=2)
    a = env.action_space.sample()
    np.testing.assert_array_equal(env.step(a)[0], copy.step(a)[0])
    np.testing.assert_array_equal(copy.task.goal, copy.task.goal_rows.T)


@pytest.mark.parametrize("task", [Reach, Pose, Track, Obstacle])
def test_every_goal_task_takes_its_defaults_from_one_place(task):
    import inspect

    from cdcr_gym import defaults

    params = inspect.signature(task.__init__).parameters
    assert params["distance_threshold"].default == defaults.DISTANCE_THRESHOLD
    if "reward_type" in params:
        assert params["reward_type"].default == defaults.REWARD_TYPE
    assert task().distance_threshold == defaults.DISTANCE_THRESHOLD


@pytest.mark.parametrize("name", ["CCKAReach-v0", "CCKATrack-v0", "CCKAPose-v0", "CCKAObstacle-v0"])
def test_a_pickled_task_reallocates_its_scratch_and_observes_the_same(name):
    """The per-step float64 scratch is not pickled (nor needed in an older pickle's state): an
    unpickled task observes and evaluates exactly like the original."""
    import pickle

    env = gym.make(f"cdcr_gym/{name}")
    env.reset(seed=3)
    env.step(np.full(env.action_space.shape, 0.7, dtype=np.float32))
    core = env.unwrapped.core
    task = core.task
    state = task.__getstate__()
    assert not {"_work", "_work_points", "_work_cables"} & set(state)
    copy = pickle.loads(pickle.dumps(task))
    size = task.observation_spec(False).size
    want, got = np.empty((size, 1), np.float32), np.empty((size, 1), np.float32)
    task.observe(core.readings, want, False)
    copy.observe(core.readings, got, False)
    np.testing.assert_array_equal(got, want)
    (r1, s1, i1), (r2, s2, i2) = task.evaluate(core.readings), copy.evaluate(core.readings)
    np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_array_equal(i1["distance"], i2["distance"])
