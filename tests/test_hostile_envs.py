"""Hostile but legal use of the envs, tasks and MuJoCo backend: bang-bang actions against solid
obstacles, failing resets, re-seeding, absurd goals and arguments at their limits."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)

pytest.importorskip("mujoco")

from cdcr_gym.backends.mujoco import MuJoCoBackend  # noqa: E402
from cdcr_gym.backends.mujoco.backend import SimulationDivergedError  # noqa: E402


# -- 1. solid obstacles under the safety filter ----------------------------------------------
def _bang_bang(pattern: int, t: int, period: int, c: int = 3) -> np.ndarray:
    """a = ±1 per cable, switching every ``period`` steps (three phase patterns)."""
    i = np.arange(c)
    if pattern == 0:
        return np.where((t // period + i) % 2, 1.0, -1.0)
    if pattern == 1:
        return np.where((t // period) % 2, 1.0, -1.0) * np.where(i % 2, 1.0, -1.0)
    return np.where((t // period + i * (i + 1) // 2) % 2, 1.0, -1.0)


def _solid_filtered_episode(seed: int, pattern: int, period: int, steps: int = 100):
    """Observations in the Box, tip moves per step and clearances of one bang-bang episode."""
    env = gym.make(
        "cdcr_gym/MuJoCoObstacle-v0",
        safety_filter=True,
        action_mode="tension",
        safety_margin=0.005,
        safety_penalty=1.0,
        solid_obstacles=True,
    )
    obs, info = env.reset(seed=seed)
    inside, moves, clearances = [env.observation_space.contains(obs)], [], []
    tip = info["tip"]
    for t in range(steps):
        obs, _, terminated, truncated, info = env.step(_bang_bang(pattern, t, period))
        inside.append(env.observation_space.contains(obs))
        moves.append(float(np.linalg.norm(info["tip"] - tip)))
        clearances.append(float(info["min_clearance"]))
        tip = info["tip"]
        if terminated or truncated:
            break
    env.close()
    return np.array(inside), np.array(moves), np.array(clearances)


def test_solid_obstacle_bang_bang_under_safety_filter_keeps_observation_in_box():
    """The probe's episode: the robot sank 60 mm into a solid sphere and the contact then threw
    it ~0.7 m in one step, bent past 180° (a cable length outside the Box). Now the contact
    pushes it out: no step moves the tip more than free bang-bang motion does (~0.15 m)."""
    inside, moves, clearances = _solid_filtered_episode(seed=0, pattern=1, period=3)
    assert inside.all(), f"observation left its Box at step {np.flatnonzero(~inside)[0]}"
    assert moves.max() < 0.2, moves.max()
    assert clearances.min() > -0.07


@pytest.mark.parametrize(
    ("seed", "pattern", "period"), [(2, 2, 3), (2, 2, 5), (0, 0, 5), (1, 1, 3), (3, 0, 2)]
)
def test_solid_obstacle_bang_bang_property(seed, pattern, period):
    """Over seeds and bang-bang patterns: the observation stays in its Box, the physics does not
    explode (no step moves the tip by more than free motion does) and no error is raised."""
    inside, moves, clearances = _solid_filtered_episode(seed, pattern, period, steps=80)
    assert inside.all()
    assert moves.max() < 0.2, moves.max()
    assert clearances.min() > -0.07


def test_robot_held_against_solid_sphere_rests_at_its_surface():
    """Cable 0 at 20/40/80 N pulls the robot into a sphere beside it: it comes to rest within
    ~1 mm of the surface (before: 0.4/7/… mm, and at 80 N it was pushed through the sphere to
    rest 61 mm on its far side)."""
    b = MuJoCoBackend(solid_obstacles=True)
    length = b.params.length
    b.set_obstacles(np.array([0]), np.array([[[0.12, 0.0, 0.75 * length, 0.05]]]))
    for tension in (20.0, 40.0, 80.0):
        b.reset(np.zeros((1, 3)))
        for _ in range(100):
            b.apply_tensions(np.array([[tension, 0.0, 0.0]]))
        assert -2e-3 < b.obstacle_clearance[0] < 0.0, (tension, b.obstacle_clearance)
        assert b.contact_forces[0] > 0.5
    b.close()


def test_solid_obstacles_refuse_an_implicit_integrator():
    with pytest.raises(ValueError, match="solid_obstacles=True needs integrator='Euler'"):
        MuJoCoBackend(solid_obstacles=True, integrator="implicitfast")


def test_a_section_bent_past_180_degrees_is_a_divergence():
    """A state whose cable length is beyond every shape's (|l − L| > π r m) raises instead of
    being observed outside the Box."""
    b = MuJoCoBackend(gravity=False)
    data = b._datas[0]
    angle = 2.0  # rad per joint about y: far past 180° per section in total
    data.qpos[0::4] = np.cos(angle / 2)
    data.qpos[2::4] = np.sin(angle / 2)
    b._mj.mj_forward(b.model, data)
    assert b._max_joint_angle(data.qpos) > np.pi / 2
    data.qpos[0::4], data.qpos[2::4] = np.cos(0.6), np.sin(0.6)  # 69° per joint: not caught
    b._mj.mj_forward(b.model, data)
    assert b._max_joint_angle(data.qpos) <= np.pi / 2
    with pytest.raises(SimulationDivergedError):
        b._check_state(0)
    b.close()
