"""The reach env's Gymnasium contract on the analytic backend (``cdcr_gym/CCKAReach-v0``)."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import cdcr_gym
from cdcr_gym import kinematics as K
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.envs.env import CDCREnv, GoalCDCREnv
from cdcr_gym.model.statics import bending_limit
from cdcr_gym.params import RobotParams

ENV_ID = "cdcr_gym/CCKAReach-v0"
MODES = ["tension", "tension_delta", "length_delta"]


@pytest.mark.parametrize("goal_conditioned", [False, True])
@pytest.mark.parametrize("mode", MODES)
def test_gymnasium_and_sb3_check_env_pass_without_warnings(mode, goal_conditioned):
    env = gym.make(ENV_ID, action_mode=mode, goal_conditioned=goal_conditioned)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)
    env.close()


def test_check_env_with_rgb_array_rendering():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # Gymnasium's render check also makes the env with render_mode="human", which needs a
        # display: that mode is tested below; the rgb_array frames in the rendering test
        gym_check_env(env.unwrapped, skip_render_check=True)
    assert env.reset(seed=0) and env.render().shape == (480, 480, 3)


def test_human_render_mode_without_a_display_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="display"):
        gym.make(ENV_ID, render_mode="human")


def test_module_colon_id_works_in_a_fresh_interpreter():
    code = (
        "import gymnasium as gym, sys\n"
        "assert 'cdcr_gym' not in sys.modules\n"
        "env = gym.make('cdcr_gym:CCKAReach-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(obs.shape, env.spec.max_episode_steps)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "(18,) 100"


def test_registered_ids():
    for env_id in ("cdcr_gym/CCKAReach-v0", "cdcr_gym/BulletReach-v0", "CCKAReach-v0"):
        assert env_id in gym.registry
        assert gym.registry[env_id].max_episode_steps == cdcr_gym.MAX_EPISODE_STEPS


def _rollout(env, seed, actions):
    obs, info = env.reset(seed=seed)
    trace = [obs]
    for a in actions:
        obs, reward, term, trunc, info = env.step(a)
        trace.append(np.concatenate([obs, [reward, term, trunc]]))
    return trace


@pytest.mark.parametrize("mode", MODES)
def test_same_seed_and_actions_give_identical_trajectories(mode):
    actions = np.random.default_rng(0).uniform(-1, 1, size=(120, 3)).astype(np.float32)
    env_a = gym.make(ENV_ID, action_mode=mode, initial_state="random")
    env_b = gym.make(ENV_ID, action_mode=mode, initial_state="random")
    ta = _rollout(env_a, 42, actions[:100])
    tb = _rollout(env_b, 42, actions[:100])
    assert all(np.array_equal(x, y) for x, y in zip(ta, tb))
    # re-seeding the same env reproduces it too, whatever happened before
    tc = _rollout(env_a, 42, actions[:100])
    assert all(np.array_equal(x, y) for x, y in zip(ta, tc))


def test_different_seeds_give_different_goals():
    env = gym.make(ENV_ID)
    goals = {tuple(env.reset(seed=s)[1]["goal"]) for s in range(20)}
    assert len(goals) == 20


def test_goals_lie_on_the_reachable_surface_within_limits():
    env = gym.make(ENV_ID)
    p = env.unwrapped.params
    for s in range(50):
        goal = env.reset(seed=s)[1]["goal"]
        theta, phi, residual = K.arc_from_tip(goal, p.length)
        assert residual < 1e-12
        assert theta <= bending_limit(phi, p) + 1e-12


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises_value_error(bad):
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.unwrapped.step(np.array([0.0, bad, 0.0], dtype=np.float32))


def test_out_of_range_actions_are_clipped():
    env = gym.make(ENV_ID, action_mode="tension")
    env.reset(seed=0)
    _, _, _, _, info_big = env.step(np.array([5.0, -3.0, 0.0], dtype=np.float32))
    _, _, _, _, info_one = env.step(np.array([1.0, -1.0, 0.0], dtype=np.float32))
    assert np.array_equal(info_big["tensions"], info_one["tensions"])
    assert info_one["tensions"].tolist() == [80.0, 0.0, 40.0]


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"action_mode": "torque"}, "action_mode"),
        ({"tension_step": 0.0}, "tension_step"),
        ({"tension_step": 1.5}, "tension_step"),
        ({"length_step": -0.001}, "length_step"),
        ({"reward_type": "shaped"}, "reward_type"),
        ({"distance_threshold": float("nan")}, "distance_threshold"),
        ({"initial_state": "bent"}, "initial_state"),
        ({"render_mode": "ansi"}, "render_mode"),
        ({"render_width": 4}, "render_width"),
        ({"terminate_on_success": "yes"}, "terminate_on_success"),
        ({"goal_conditioned": "yes"}, "goal_conditioned"),
        ({"params": {"length": 1.0}}, "params"),
    ],
)
def test_bad_constructor_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, **kwargs)


def test_bad_reset_options_raise_value_error():
    env = gym.make(ENV_ID)
    with pytest.raises(ValueError, match="unknown"):
        env.reset(options={"gaol": [0, 0, 0.6]})
    with pytest.raises(ValueError, match="initial_tensions"):
        env.reset(options={"initial_tensions": [0.0, 100.0, 0.0]})
    with pytest.raises(ValueError, match="goal"):
        env.reset(options={"goal": [0.0, np.nan, 0.5]})


def test_params_reach_the_backend():
    env = gym.make(ENV_ID, params=RobotParams(length=0.5, n_disks=5))
    obs, info = env.reset(seed=0, options={"initial_tensions": [0.0, 0.0, 0.0]})
    assert info["tip"].tolist() == [0.0, 0.0, 0.5]
    assert env.unwrapped.params.n_disks == 5


def test_dense_reward_is_minus_distance_and_info_is_complete():
    env = gym.make(ENV_ID, initial_state="random")
    env.reset(seed=3)
    for _ in range(20):
        _, reward, term, trunc, info = env.step(env.action_space.sample())
        assert reward == -info["distance"]
        assert set(info) >= {"distance", "is_success", "tip", "tensions", "cable_lengths"}
        assert info["distance"] == pytest.approx(np.linalg.norm(info["goal"] - info["tip"]))
        assert info["is_success"] == (info["distance"] <= 0.005)
        assert not term and not trunc


def test_sparse_reward():
    env = gym.make(ENV_ID, reward_type="sparse", distance_threshold=0.01)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert reward == (0.0 if info["distance"] <= 0.01 else -1.0)


def test_episode_truncates_at_max_episode_steps():
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    for t in range(100):
        _, _, term, trunc, _ = env.step(np.zeros(3, dtype=np.float32))
        assert not term
        assert trunc == (t == 99)


def test_goal_reset_option_projects_onto_the_surface():
    env = gym.make(ENV_ID)
    _, info = env.reset(seed=0, options={"goal": [0.1, 0.0, 0.7]})  # off the surface
    goal = info["goal"]
    assert K.arc_from_tip(goal, 0.641)[2] < 1e-12
    assert np.linalg.norm(goal - [0.1, 0.0, 0.7]) == pytest.approx(
        K.arc_from_tip(np.array([0.1, 0.0, 0.7]), 0.641)[2]
    )


def test_length_delta_keeps_the_backbone_length_and_the_workspace():
    env = gym.make(ENV_ID, action_mode="length_delta", length_step=0.01)
    env.reset(seed=0)
    p = env.unwrapped.params
    for _ in range(50):
        _, _, _, _, info = env.step(np.array([-1.0, 1.0, 0.3], dtype=np.float32))
        lengths = info["cable_lengths"]
        assert lengths.sum() == pytest.approx(3 * p.length, abs=1e-12)
        theta, phi, _ = K.arc_from_lengths(lengths, p.cable_radius)
        assert theta <= bending_limit(phi, p) + 1e-12
    # pulling the same way for long ends on the limit, held by tensions within range
    assert theta == pytest.approx(bending_limit(phi, p))
    assert np.all(info["tensions"] <= p.max_tension + 1e-9)


def test_tension_delta_holds_tensions_and_clips_at_the_limits():
    env = gym.make(ENV_ID, tension_step=0.25)
    env.reset(seed=0)
    for _ in range(6):
        _, _, _, _, info = env.step(np.array([1.0, -1.0, 0.5], dtype=np.float32))
    assert info["tensions"].tolist() == [80.0, 0.0, 60.0]


def test_goal_conditioned_variant_and_vectorised_compute_reward():
    env = gym.make(ENV_ID, goal_conditioned=True)
    assert isinstance(env.unwrapped, GoalCDCREnv)
    obs, info = env.reset(seed=1)
    obs, reward, _, _, info = env.step(env.action_space.sample())
    assert reward == env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
    achieved = np.random.default_rng(0).normal(size=(7, 5, 3))
    desired = np.random.default_rng(1).normal(size=(7, 5, 3))
    batched = env.unwrapped.compute_reward(achieved, desired, None)
    assert batched.shape == (7, 5)
    assert np.allclose(batched, -np.linalg.norm(achieved - desired, axis=-1))
    assert not hasattr(gym.make(ENV_ID).unwrapped, "compute_reward")  # flat env is no GoalEnv


def test_sac_with_her_runs_on_the_goal_conditioned_variant():
    import torch
    from stable_baselines3 import SAC, HerReplayBuffer

    torch.set_num_threads(1)
    env = gym.make(ENV_ID, goal_conditioned=True, reward_type="sparse")
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
        learning_starts=200,
        batch_size=64,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
        verbose=0,
    )
    model.learn(total_timesteps=300)
    assert model.num_timesteps == 300
    assert model.replay_buffer.size() > 0


def test_rgb_array_render_has_the_right_shape_and_is_not_blank():
    env = gym.make(
        ENV_ID, render_mode="rgb_array", render_width=320, render_height=240, initial_state="random"
    )
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
    assert frame.std() > 10  # not one flat colour
    env.step(np.array([1.0, -1.0, -1.0], dtype=np.float32))  # bend towards cable 1
    assert not np.array_equal(env.render(), frame)  # the drawing follows the robot


def test_the_env_takes_a_backend_object_and_reaches_by_default():
    with pytest.raises(ValueError, match="backend"):
        CDCREnv("ccka")  # type: ignore[arg-type]
    env = CDCREnv(AnalyticBackend(), action_mode="tension")
    assert type(env.task).__name__ == "Reach"
    env.reset(seed=0)
    assert env.step(np.zeros(3, dtype=np.float32))[4]["tensions"].tolist() == [40.0] * 3


def test_observations_stay_in_the_space_over_long_random_runs():
    for mode in MODES:
        env = gym.make(ENV_ID, action_mode=mode, initial_state="random")
        obs, _ = env.reset(seed=5)
        rng = np.random.default_rng(5)
        for t in range(2000):
            action = rng.choice([-1.0, 1.0], size=3) if t % 2 else rng.uniform(-1, 1, 3)
            obs, _, term, trunc, _ = env.step(action.astype(np.float32))
            assert env.observation_space.contains(obs)
            if term or trunc:
                obs, _ = env.reset()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(3,), (6,), (2, 3), (20,)])
def test_clipped_action_equals_numpy_clip_of_the_float64_action(dtype, shape):
    """The action path of both envs (validation.clipped_action) against numpy."""
    from cdcr_gym import validation

    rng = np.random.default_rng(3)
    for _ in range(50):
        action = rng.uniform(-3.0, 3.0, shape).astype(dtype)
        want = np.clip(action.astype(np.float64), -1.0, 1.0)
        got = validation.clipped_action(action, shape)
        assert got.dtype == np.float64 and got.shape == shape
        np.testing.assert_array_equal(got, want)
    for bad in (np.nan, np.inf, -np.inf):
        action = np.zeros(shape, dtype)
        action.flat[-1] = bad
        with pytest.raises(ValueError, match="action must be finite"):
            validation.clipped_action(action, shape)
