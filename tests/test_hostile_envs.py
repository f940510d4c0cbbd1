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


# -- 2. a refused reset changes nothing ---------------------------------------------------------
def _record(env, actions):
    """Observation, reward and every info entry over ``actions``, then a reset without a seed
    (which draws from the generator): all bit for bit comparable."""
    out = []
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        out.append((obs, reward, terminated, info))
    out.append(env.reset())
    return out


def _assert_identical(a, b):
    if isinstance(a, dict):
        assert sorted(a) == sorted(b)
        for k in a:
            _assert_identical(a[k], b[k])
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _assert_identical(x, y)
    else:
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), strict=True)


_REACH_BAD = [
    {"initial_tensions": [-1.0, 0.0, 0.0]},
    {"initial_tensions": [0.0, 0.0]},
    {"initial_tensions": [np.nan, 0.0, 0.0]},
    {"goal": [0.1, 0.0]},
    {"goal": [np.inf, 0.0, 0.5]},
    {"goal": [1e10, 0.0, 0.0]},
    {"goal": [0.1, 0.0, 0.5], "initial_tensions": [0.0, 0.0, 999.0]},
    {"initial_tensions": [1.0, 0.0, 0.0], "goal": "far"},
    {"goal": [0.1, 0.0, 0.5], "unknown": 1},
    "not a dict",
]


@pytest.mark.parametrize("backend", ["CCKA", "MuJoCo"])
@pytest.mark.parametrize(
    ("task", "bad"),
    [("Reach", b) for b in _REACH_BAD]
    + [
        ("Pose", {"goal": [0.1, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0]}),
        ("Pose", {"goal": [0.1, 0.0, 0.5, 0.0, 0.0, 0.0]}),
        ("Obstacle", {"goal": [0.1, 0.0, 0.5]}),
        ("Obstacle", {"initial_tensions": [0.0, -1.0, 0.0]}),
        ("Track", {"goal": [0.1, 0.0, 0.5]}),
    ],
)
def test_a_refused_reset_leaves_the_env_as_it_was(backend, task, bad):
    """Two envs seeded and stepped alike; one is given a reset that raises (with and without
    a seed). Afterwards both step and reset (drawing from their generators) bit for bit alike:
    the refused reset drew no randomised parameter, moved no generator, changed no state."""
    env_id = f"cdcr_gym/{backend}{task}-v0"
    e0 = gym.make(env_id).unwrapped.params.youngs_modulus
    kw = dict(
        randomize={"youngs_modulus": [e0, 1.5 * e0]},
        imperfections={"tip_bias": 0.001, "tip_noise": 0.001},
    )
    envs = [gym.make(env_id, **kw) for _ in range(2)]
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (4, envs[0].action_space.shape[0]))
    for env in envs:
        env.reset(seed=3)
        for a in actions[:2]:
            env.step(a)
    for seed in (None, 11):
        with pytest.raises(ValueError):
            envs[0].reset(seed=seed, options=bad)
    _assert_identical(_record(envs[0], actions), _record(envs[1], actions))
    for env in envs:
        env.close()


def test_a_refused_vector_reset_leaves_every_generator_as_it_was():
    """A bad seed list or bad options in the vector env: no env is re-seeded."""
    venvs = [gym.make_vec("cdcr_gym/CCKAReach-v0", num_envs=3) for _ in range(2)]
    for v in venvs:
        v.reset(seed=1)
    with pytest.raises(gym.error.Error, match="Seed must be greater or equal to zero"):
        venvs[0].reset(seed=[5, 6, -1])
    with pytest.raises(ValueError):
        venvs[0].reset(seed=9, options={"goal": [0.0, 0.0, 1e9]})
    a = np.zeros((3, 3))
    _assert_identical(_record(venvs[0], [a]), _record(venvs[1], [a]))


# -- 3. re-seeding is exact ----------------------------------------------------------------------
_GRID = {
    "CCKAReach": [
        {},
        {"randomize": {"youngs_modulus": [20e9, 50e9]}},
        {"randomize": {"cable_radius": [0.02, 0.03], "gravity": 0.5}},
        {"randomize": {"tip_payload": [0.0, 0.05], "friction_coefficient": [0.0, 0.3]}},
        {"imperfections": {"tip_bias": 0.001, "action_delay": 2, "tension_lag": 2.0}},
        {"initial_state": "random", "imperfections": {"actuator_noise": 0.5}},
    ],
    "CCKAObstacle": [{}, {"randomize": {"youngs_modulus": [20e9, 50e9]}}],
    "MuJoCoReach": [
        {},
        {"randomize": {"tip_payload": [0.0, 0.05]}},
        {"randomize": {"youngs_modulus": [30e9, 40e9], "gravity": 0.5}},
        {"randomize": {"friction_coefficient": [0.0, 0.3]}},
        {"friction_coefficient": 0.2},
        {"imperfections": {"tension_bias": 0.5, "action_delay": 1}},
    ],
    "MuJoCoObstacle": [
        {},
        {"randomize": {"tip_payload": [0.0, 0.05]}},
        {"randomize": {"tip_payload": [0.0, 0.05], "youngs_modulus": [30e9, 40e9]}},
        {"solid_obstacles": True, "randomize": {"tip_payload": [0.0, 0.05]}},
        {"randomize": {"friction_coefficient": [0.1, 0.3]}},
        {"imperfections": {"tip_noise": 0.001}},
    ],
}


@pytest.mark.parametrize(
    ("name", "kw"), [(name, kw) for name, grid in _GRID.items() for kw in grid]
)
def test_reseeding_a_used_env_is_bit_identical_to_a_fresh_one(name, kw):
    """``reset(seed=5)`` on an env that ran an episode (other seed, other parameters drawn)
    gives, bit for bit, what a fresh env gives: observations, rewards and every info entry."""
    env_id = f"cdcr_gym/{name}-v0"
    used, fresh = gym.make(env_id, **kw), gym.make(env_id, **kw)
    c = used.action_space.shape[0]
    actions = np.random.default_rng(1).uniform(-1, 1, (4, c))
    used.reset(seed=1)
    for a in actions[::-1]:
        used.step(a)
    _assert_identical(used.reset(seed=5), fresh.reset(seed=5))
    _assert_identical(_record(used, actions[:3]), _record(fresh, actions[:3]))
    used.close()
    fresh.close()


# -- 4. goals: shapes, finiteness, absurd distances ----------------------------------------------
@pytest.mark.parametrize("backend", ["CCKA", "MuJoCo"])
def test_absurd_goals_are_refused_not_projected(backend):
    env = gym.make(f"cdcr_gym/{backend}Reach-v0")
    env.reset(seed=0)
    for goal in ([1e100, 0, 0], [1e10, 0, 0], [0.0, 0.0, 7.0]):
        with pytest.raises(ValueError, match=r"options\['goal'\].*within 10 robot lengths"):
            env.reset(options={"goal": goal})
    for goal in ([np.nan, 0, 0.5], [0, np.inf, 0.5]):
        with pytest.raises(ValueError, match=r"options\['goal'\] must be finite"):
            env.reset(options={"goal": goal})
    with pytest.raises(ValueError, match=r"options\['goal'\] must have shape \(3,\)"):
        env.reset(options={"goal": [0.1, 0.0, 0.5, 0.0]})
    # a far but sane goal (outside the workspace, within 10 lengths) is still projected
    _, info = env.reset(options={"goal": [2.0, 0.0, 0.0]})
    assert np.linalg.norm(info["goal"]) <= env.unwrapped.params.length + 1e-9
    env.close()


@pytest.mark.parametrize("backend", ["CCKA", "MuJoCo"])
def test_pose_goal_must_have_six_entries(backend):
    env = gym.make(f"cdcr_gym/{backend}Pose-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"options\['goal'\] must have shape \(6,\)"):
        env.reset(options={"goal": [0.1, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0]})
    with pytest.raises(ValueError, match=r"options\['goal'\].*within 10 robot lengths"):
        env.reset(options={"goal": [1e10, 0.0, 0.5, 0.0, 0.0, 1.0]})
    env.close()


@pytest.mark.parametrize(
    ("env_id", "size"),
    [("cdcr_gym/CCKAReach-v0", 3), ("cdcr_gym/CCKAPose-v0", 6), ("cdcr_gym/MuJoCoReach-v0", 3)],
)
def test_compute_reward_checks_goal_shapes_and_values(env_id, size):
    env = gym.make(env_id, goal_conditioned=True)
    obs, info = env.reset(seed=0)
    u = env.unwrapped
    ok = u.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
    assert np.isfinite(ok)
    batch = np.tile(obs["achieved_goal"], (5, 1))
    assert u.compute_reward(batch, batch, None).shape == (5,)
    wrong = np.zeros(size + 1)
    with pytest.raises(ValueError, match=rf"achieved_goal must have shape \(\.\.\., {size}\)"):
        u.compute_reward(wrong, obs["desired_goal"], info)
    with pytest.raises(ValueError, match=rf"desired_goal must have shape \(\.\.\., {size}\)"):
        u.compute_reward(obs["achieved_goal"], list(wrong), info)
    with pytest.raises(ValueError, match="desired_goal must be finite"):
        u.compute_reward(obs["achieved_goal"], np.full(size, np.nan), info)
    with pytest.raises(ValueError, match="broadcastable"):
        u.compute_reward(np.zeros((4, size)), np.zeros((3, size)), info)
    env.close()


def test_obstacle_compute_reward_checks_goal_shapes():
    env = gym.make("cdcr_gym/CCKAObstacle-v0")
    _, info = env.reset(seed=0)
    with pytest.raises(ValueError, match=r"desired_goal must have shape \(\.\.\., 3\)"):
        env.unwrapped.task.compute_reward(np.zeros(3), [0, 0, 0, 5], info)


# -- 5. arguments that are accepted run --------------------------------------------------------
@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"links_per_span": 60}, r"links_per_span must be in \[1, 55\].*got 60"),
        ({"links_per_span": 10**9}, r"links_per_span must be in \[1, 55\]"),
        (
            {"damping_ratio": 0.05},
            r"damping_ratio=0.05 is below .* at physics_timestep=0.02 s.*physics_timestep <= 0.0025",
        ),
        (
            {"physics_timestep": 0.2, "control_timestep": 0.2},
            r"damping_ratio=0.7 is below .* at physics_timestep=0.2 s.*physics_timestep <= 0.1 s",
        ),
        ({"integrator": "RK4"}, r"physics_timestep=0.02 s is too long.*integrator='RK4'"),
    ],
)
def test_mujoco_refuses_arguments_it_cannot_run(kw, match):
    with pytest.raises(ValueError, match=match):
        MuJoCoBackend(**kw)


def test_mujoco_accepts_the_limits_and_they_run():
    """The largest accepted links_per_span builds; a low damping ratio at its stable timestep
    survives random tensions (bang-bang ones at its resonance swing it past 180°, a
    divergence by name)."""
    b = MuJoCoBackend(links_per_span=55, gravity=False)
    b.apply_tensions(np.array([[80.0, 0.0, 0.0]]))
    b.close()
    probe = MuJoCoBackend(damping_ratio=0.7)
    limit = probe.stable_timestep()  # the longest step whose β for ζ = 0.7 is stable
    MuJoCoBackend(damping_ratio=0.7, physics_timestep=0.98 * limit, control_timestep=0.98 * limit)
    with pytest.raises(ValueError, match="damping_ratio=0.7 is below"):
        MuJoCoBackend(
            damping_ratio=0.7, physics_timestep=1.02 * limit, control_timestep=1.02 * limit
        )
    zeta = 0.05
    h = MuJoCoBackend(damping_ratio=zeta, physics_timestep=0.002).stable_timestep()
    n = int(0.02 / h) + 1
    b = MuJoCoBackend(damping_ratio=zeta, physics_timestep=0.02 / n)
    rng = np.random.default_rng(0)
    for t in range(150):
        if t % 10 == 0:
            tensions = rng.uniform(0.0, 80.0, size=(1, 3))
        b.apply_tensions(tensions)
    b.close()


@pytest.mark.parametrize(
    ("randomize", "match"),
    [
        ({"tip_payload": [20.0, 50.0]}, r"randomize\['tip_payload'\]=\[20.0, 50.0\].*50.0 kg"),
        ({"youngs_modulus": [30e9, 1e13]}, r"too long.*randomize\['youngs_modulus'\]"),
    ],
)
def test_mujoco_refuses_randomisation_ranges_it_cannot_simulate(randomize, match):
    """Refused when the env is made (before: a payload of 20–50 kg diverged after 9–498
    steps), naming the range."""
    with pytest.raises(ValueError, match=match):
        gym.make("cdcr_gym/MuJoCoReach-v0", randomize=randomize)
    gym.make("cdcr_gym/CCKAReach-v0", randomize=randomize).close()  # CCKA: reported only


@pytest.mark.parametrize("backend", ["CCKA", "MuJoCo", "Bullet"])
def test_action_delay_is_bounded(backend):
    """A delay of 10⁹ steps allocated a 22 GiB queue; now refused naming its range."""
    if backend == "Bullet":
        pytest.importorskip("pybullet")
    with pytest.raises(ValueError, match=r"action_delay'\] must be an integer in \[0, 10000\]"):
        gym.make(f"cdcr_gym/{backend}Reach-v0", imperfections={"action_delay": 10**9})
    env = gym.make(f"cdcr_gym/{backend}Reach-v0", imperfections={"action_delay": 10_000})
    env.reset(seed=0)
    env.step(np.zeros(3))
    env.close()
