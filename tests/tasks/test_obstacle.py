"""The Obstacle task (cdcr_gym/{CCKA,Bullet,MuJoCo}Obstacle-v0), its collision geometry and
oracle."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest
from task_contracts import (
    batched_ids,
    batched_matches_single,
    check_env_both,
    combos,
    make,
    rollout,
)

from cdcr_gym.controllers import AnalyticIKController, ObstaclePlanner
from cdcr_gym.model.ik import solve_ik
from cdcr_gym.model.statics import cached_model
from cdcr_gym.params import RobotParams
from cdcr_gym.tasks.collision import (
    clearance,
    model_geometry,
    nearest_backbone_points,
    route_clearance,
)
from cdcr_gym.tasks.obstacle import Obstacle

COMBOS = combos("Obstacle")


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_check_env_passes(env_id, robot):
    env = make(env_id, robot)
    check_env_both(env)
    env.close()


@pytest.mark.parametrize("env_id, robot", COMBOS)
def test_same_seed_and_actions_give_identical_trajectories(env_id, robot):
    kwargs = {"terminate_on_collision": True}
    a, b = rollout(env_id, robot, **kwargs), rollout(env_id, robot, **kwargs)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("env_id", batched_ids("Obstacle"))
def test_batched_env_matches_single_envs(env_id):
    batched_matches_single(env_id, "paper", terminate_on_collision=True)


def test_clearance_of_rod_and_disks_is_exact_on_the_straight_robot():
    params = RobotParams.preset("paper")
    model = cached_model(params)
    geometry = model_geometry(model, np.zeros((1, 1, 2)))
    rod, disk = 0.5 * params.backbone_diameter, params.disk_radius
    # beside the backbone between two disks, level with none: the nearest part is a disk rim
    z_mid = 0.5 * params.disk_spacing
    sphere = np.array([[0.1, 0.0, z_mid, 0.01]])
    expected = np.hypot(0.1 - disk, z_mid) - 0.01
    np.testing.assert_allclose(clearance(geometry, sphere, rod, disk)[0, 0], expected, rtol=1e-12)
    # above the tip: the rod's round end cap (a capsule), d/2 above the tip disk's face
    sphere = np.array([[0.0, 0.0, params.length + 0.05, 0.02]])
    expected = 0.05 - rod - 0.02
    np.testing.assert_allclose(clearance(geometry, sphere, rod, disk)[0, 0], expected, rtol=1e-12)
    # padding (radius 0) never collides
    assert np.isinf(clearance(geometry, np.zeros((1, 4)), rod, disk)[0, 0])


@pytest.mark.parametrize("robot", ["paper", "tdcr2"])
def test_scenes_block_the_direct_route_and_keep_start_and_goal_free(robot):
    env = gym.make("cdcr_gym/CCKAObstacle-v0", robot=robot, initial_state="random")
    params = env.unwrapped.params
    model = cached_model(params)
    rod, disk = 0.5 * params.backbone_diameter, params.disk_radius
    for seed in range(6):
        _, info = env.reset(seed=seed)
        spheres = info["obstacles"]
        count = int(np.sum(spheres[:, 3] > 0))
        assert 1 <= count <= 3
        assert info["min_clearance"] > 0.01 and not info["collision"]
        start = info["tensions"]
        ik = solve_ik(info["goal"], params).tensions
        lam = np.linspace(0.0, 1.0, 201)[:, None]
        w = model.bending_from_tensions(start + lam * (ik - start))
        gap = clearance(model_geometry(model, w), spheres, rod, disk).min(axis=1)
        assert gap.min() < 0.0  # the direct route hits a sphere
        assert gap[-1] > 0.01  # the IK goal shape is free


def test_reach_ik_collides_and_the_planner_succeeds_on_the_same_episodes():
    env = gym.make("cdcr_gym/CCKAObstacle-v0")
    ik = AnalyticIKController.from_env(env)
    planner = ObstaclePlanner.from_env(env)
    results = {"ik": [], "planner": []}
    for seed in range(12):
        for name, policy in (("ik", ik), ("planner", planner)):
            obs, info = env.reset(seed=seed)
            truncated = False
            while not truncated:
                obs, _, _, truncated, info = env.step(policy(obs))
            results[name].append((info["is_success"], info["collided"]))
    ik_collided = np.mean([c for _, c in results["ik"]])
    planner_success = np.mean([s for s, _ in results["planner"]])
    assert ik_collided >= 0.8, ik_collided
    assert planner_success >= 0.95, planner_success
    assert not any(c for _, c in results["planner"])


def _path_steps(path: list[np.ndarray]) -> float:
    return float(np.sum(np.max(np.abs(np.diff(path, axis=0)), axis=1)))


def test_the_shortest_of_several_plans_is_kept_and_no_longer_than_the_first():
    env = gym.make("cdcr_gym/CCKAObstacle-v0")
    one = ObstaclePlanner.from_env(env)
    four = ObstaclePlanner.from_env(env, candidates=4)
    spec = env.unwrapped.observation_spec
    shorter = 0
    for seed in range(6):
        obs, _ = env.reset(seed=seed)
        goal = spec.decode(obs, "goal")
        radii = spec.decode(obs, "obstacle_radii")
        centres = spec.decode(obs, "obstacle_centres").reshape(-1, 3)
        spheres = np.concatenate([centres, radii[:, None]], axis=1)[radii > 0]
        first = one.plan(np.zeros(3), goal, spheres)
        best = four.plan(np.zeros(3), goal, spheres)
        assert four.last_plan_found and np.all(four.free(np.asarray(best), spheres))
        # candidate 0 is the single planner's plan: the kept one is never longer
        assert _path_steps(best) <= _path_steps(first) + 1e-12
        shorter += _path_steps(best) < _path_steps(first) - 1e-9
    assert shorter >= 1  # on some scene another candidate is shorter
    with pytest.raises(ValueError, match="candidates must be an integer >= 1, got 0"):
        ObstaclePlanner.from_env(env, candidates=0)


def test_collision_penalty_success_and_termination():
    env = gym.make("cdcr_gym/CCKAObstacle-v0", terminate_on_collision=True, collision_penalty=2.0)
    ik = AnalyticIKController.from_env(env)
    obs, info = env.reset(seed=0)
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(ik(obs))
        if info["collision"]:
            break
    assert info["collision"] and terminated and info["min_clearance"] < 0
    assert reward == pytest.approx(-info["distance"] - 2.0)
    assert not info["is_success"] and info["collided"]


def test_render_draws_the_obstacles():
    env = gym.make(
        "cdcr_gym/CCKAObstacle-v0",
        render_mode="rgb_array",
        render_width=96,
        render_height=96,
        min_obstacles=3,
    )
    env.reset(seed=0)
    with_spheres = env.render()
    env.unwrapped.task.obstacles[:] = 0.0
    without = env.render()
    assert with_spheres.shape == (96, 96, 3)
    assert np.sum(np.any(with_spheres != without, axis=-1)) > 50


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"collision_penalty": -1.0}, "collision_penalty"),
        ({"penetration_weight": -1.0}, "penetration_weight"),
        ({"terminate_on_collision": 1}, "terminate_on_collision"),
        ({"min_obstacles": 0}, "min_obstacles"),
        ({"min_obstacles": 3, "max_obstacles": 2}, "max_obstacles"),
        ({"radius_range": (0.05, 0.01)}, "radius_range"),
        ({"radius_range": (0.0, 0.01)}, "radius_range"),
        ({"clearance_margin": -0.01}, "clearance_margin"),
        ({"clearance_features": "yes"}, "clearance_features"),
        ({"route_features": 1}, "route_features"),
        ({"proximity_margin": -0.01}, "proximity_margin"),
        ({"proximity_weight": float("nan")}, "proximity_weight"),
        ({"success_bonus": -1.0}, "success_bonus"),
        ({"goal_conditioned": True}, "goal_conditioned"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("cdcr_gym/CCKAObstacle-v0", **kwargs)


def test_planner_refuses_other_action_modes():
    env = gym.make("cdcr_gym/CCKAObstacle-v0", action_mode="tension")
    with pytest.raises(ValueError, match="action_mode"):
        ObstaclePlanner.from_env(env)


def test_docstring_lists_the_arguments_and_the_observation_table():
    doc = inspect.getdoc(Obstacle)
    for name in inspect.signature(Obstacle.__init__).parameters:
        if name != "self":
            assert f"{name}:" in doc, name
    env = gym.make("cdcr_gym/CCKAObstacle-v0")
    assert env.unwrapped.observation_spec.table() in doc


def test_nearest_backbone_points_match_a_dense_search_along_the_polyline():
    params = RobotParams.preset("paper")
    model = cached_model(params)
    rng = np.random.default_rng(3)
    bending = rng.uniform(-1.0, 1.0, (4, 1, 2))
    geometry = model_geometry(model, bending)
    spheres = np.concatenate([rng.uniform(-0.4, 0.7, (4, 3, 3)), np.full((4, 3, 1), 0.05)], -1)
    nearest = nearest_backbone_points(geometry, spheres)
    a, b = geometry.points[:, :-1], geometry.points[:, 1:]
    t = np.linspace(0.0, 1.0, 2001)[:, None, None, None]
    dense = (a + t * (b - a)).transpose(1, 0, 2, 3).reshape(4, -1, 3)  # (M, many, 3)
    for m in range(4):
        for k in range(3):
            brute = np.linalg.norm(dense[m] - spheres[m, k, :3], axis=-1).min()
            found = np.linalg.norm(nearest[m, k] - spheres[m, k, :3])
            assert found <= brute + 1e-12
            assert found >= brute - 1e-3 * np.max(np.linalg.norm(b[m] - a[m], axis=-1))


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAObstacle-v0", "cdcr_gym/MuJoCoObstacle-v0"])
def test_clearance_features_describe_each_sphere_and_the_collided_flag(env_id):
    env = gym.make(env_id, clearance_features=True, min_obstacles=2, max_obstacles=3)
    spec = env.unwrapped.observation_spec
    assert env.observation_space.shape == (47,)
    ik = AnalyticIKController.from_env(env)
    obs, info = env.reset(seed=4)
    seen_collision = False
    for _ in range(60):
        s = spec.slices
        present = info["obstacles"][:, 3] > 0
        clear = obs[s["obstacle_clearances"]]
        directions = obs[s["obstacle_directions"]].reshape(3, 3)
        # padding: clearance 2l and no direction; spheres: unit directions
        assert np.all(clear[~present] == np.float32(2 * 0.641))
        assert np.all(directions[~present] == 0.0)
        np.testing.assert_allclose(np.linalg.norm(directions[present], axis=1), 1.0, rtol=1e-5)
        if env_id.startswith("cdcr_gym/CCKA"):  # the same geometry as min_clearance
            assert clear.min() == pytest.approx(info["min_clearance"], abs=1e-6)
        assert obs[s["collided"]][0] == float(info["collided"])
        seen_collision |= info["collided"]
        obs, _, _, _, info = env.step(ik(obs))
    assert seen_collision  # the reach IK runs into the blocking sphere: the flag was exercised
    assert env.observation_space.contains(obs)


def test_route_clearance_matches_a_dense_walk_along_the_route():
    params = RobotParams.preset("paper")
    model = cached_model(params)
    rng = np.random.default_rng(5)
    start = rng.uniform(0.0, params.max_tension, (3, 3))
    goal = rng.uniform(0.0, params.max_tension, (3, 3))
    spheres = np.concatenate([rng.uniform(-0.3, 0.6, (3, 2, 3)), np.full((3, 2, 1), 0.06)], -1)
    spheres[2, 1] = 0.0  # padding
    clear, where, side = route_clearance(model, start, goal, spheres, 0.0025, 0.01, samples=5)
    lam = np.linspace(0.0, 1.0, 5)
    for m in range(3):
        shapes = model.bending_from_tensions(start[m] + lam[:, None] * (goal[m] - start[m]))
        per = clearance(model_geometry(model, shapes), spheres[m], 0.0025, 0.01)  # (5, K)
        np.testing.assert_allclose(clear[m], per.min(0), rtol=0, atol=1e-12)
        for k in range(2 if m < 2 else 1):
            j = int(np.argmin(per[:, k]))
            assert where[m, k] == lam[j]
            geometry = model_geometry(model, shapes[j : j + 1])
            point = nearest_backbone_points(geometry, spheres[m, k : k + 1])[0, 0]
            away = point - spheres[m, k, :3]
            np.testing.assert_allclose(side[m, k], away / np.linalg.norm(away), atol=1e-12)
    assert clear[2, 1] == np.inf and where[2, 1] == 0.0 and np.all(side[2, 1] == 0.0)
    # a route of one point (start = goal) is the shape now: the clearance now, at fraction 0
    same, at, _ = route_clearance(model, start, start, spheres, 0.0025, 0.01)
    now = clearance(
        model_geometry(model, model.bending_from_tensions(start)), spheres, 0.0025, 0.01
    )
    np.testing.assert_allclose(same, now, rtol=0, atol=1e-12)
    assert np.all(at == 0.0)


@pytest.mark.parametrize("env_id", ["cdcr_gym/CCKAObstacle-v0", "cdcr_gym/MuJoCoObstacle-v0"])
def test_route_features_see_the_blocking_sphere_ahead(env_id):
    env = gym.make(env_id, clearance_features=True, route_features=True, max_obstacles=3)
    spec = env.unwrapped.observation_spec
    assert env.observation_space.shape == (47 + 15,)
    task = env.unwrapped.task
    ik = AnalyticIKController.from_env(env)
    for seed in range(4):
        obs, info = env.reset(seed=seed)
        s = spec.slices
        present = info["obstacles"][:, 3] > 0
        route = obs[s["route_clearances"]]
        # the scene is built so that the direct route runs through sphere 0, ahead of the robot
        assert route[0] < 0.0 < obs[s["obstacle_clearances"]][0]
        assert 0.0 < obs[s["route_fractions"]][0] <= 1.0
        np.testing.assert_allclose(
            task.goal_tensions[0], solve_ik(info["goal"], task.params).tensions
        )
        directions = obs[s["route_directions"]].reshape(3, 3)
        np.testing.assert_allclose(np.linalg.norm(directions[present], axis=1), 1.0, rtol=1e-5)
        assert np.all(directions[~present] == 0.0)
        assert np.all(route[~present] == np.float32(2 * 0.641))
        # the reach IK walks the direct route: the deepest clearance it meets on sphere 0 is
        # the one the route features predicted at reset (CCKA: the model is the robot; both
        # sample the route, 9 points against the IK's steps: a few mm apart)
        ahead, met = route[0], np.inf
        for _ in range(40):
            obs, _, _, _, info = env.step(ik(obs))
            assert env.observation_space.contains(obs)
            met = min(met, obs[s["obstacle_clearances"]][0])
        if env_id.startswith("cdcr_gym/CCKA"):
            assert info["collided"]
            assert abs(met - ahead) < 0.006


def test_route_features_in_the_batched_env_equal_single_envs():
    kwargs = {"route_features": True, "clearance_features": True}
    batched = gym.make_vec(
        "cdcr_gym/CCKAObstacle-v0", num_envs=3, vectorization_mode="vector_entry_point", **kwargs
    )
    obs, _ = batched.reset(seed=[7, 8, 9])
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (5, 3, 3)).astype(np.float32)
    trace = [obs]
    for a in actions:
        trace.append(batched.step(a)[0])
    for i, seed in enumerate((7, 8, 9)):
        single = gym.make("cdcr_gym/CCKAObstacle-v0", **kwargs)
        o, _ = single.reset(seed=seed)
        np.testing.assert_allclose(o, trace[0][i], atol=1e-6)
        for step, a in enumerate(actions):
            o = single.step(a[i])[0]
            np.testing.assert_allclose(o, trace[step + 1][i], atol=1e-6)


def test_proximity_cost_and_success_bonus_shape_the_reward_as_documented():
    kwargs = {"proximity_margin": 0.03, "proximity_weight": 2.0, "success_bonus": 0.5}
    env = gym.make("cdcr_gym/CCKAObstacle-v0", penetration_weight=5.0, **kwargs)
    plain = gym.make("cdcr_gym/CCKAObstacle-v0", penetration_weight=5.0)
    task = env.unwrapped.task
    near = bonus = 0
    for controller in (AnalyticIKController.from_env(env), ObstaclePlanner.from_env(env)):
        obs, info = env.reset(seed=1)
        plain.reset(seed=1)
        for _ in range(100):
            action = controller(obs)
            obs, reward, _, _, info = env.step(action)
            _, reward_plain, _, _, info_plain = plain.step(action)
            gap = info["min_clearance"]
            expected = reward_plain - 2.0 * max(0.0, 0.03 - gap) + 0.5 * info["is_success"]
            assert reward == pytest.approx(expected, abs=1e-12)
            assert info_plain["distance"] == info["distance"]
            keys = ("collided", "collision", "min_clearance")
            again = task.compute_reward(
                np.asarray(info["tip"])[None],
                np.asarray(info["goal"])[None],
                {k: np.asarray([info[k]]) for k in keys},
            )
            assert again[0] == pytest.approx(reward, abs=1e-12)
            near += 0.0 < gap < 0.03
            bonus += bool(info["is_success"])
    assert near > 0 and bonus > 0  # both terms were exercised


def test_difficulty_shrinks_the_spheres_and_their_count_and_one_is_the_task():
    easy = gym.make("cdcr_gym/CCKAObstacle-v0", difficulty=0.5, min_obstacles=1, max_obstacles=3)
    full = gym.make("cdcr_gym/CCKAObstacle-v0", min_obstacles=1, max_obstacles=3)
    ell = 0.641
    counts, radii = [], []
    for seed in range(25):
        _, info = easy.reset(seed=seed)
        present = info["obstacles"][:, 3] > 0
        counts.append(int(present.sum()))
        radii.extend(info["obstacles"][present, 3])
        assert info["min_clearance"] > 0.01  # start and goal still free
    assert max(counts) <= 2 and min(counts) >= 1  # 1 + floor(0.5 * (3 - 1))
    assert 0.5 * 0.06 * ell <= min(radii) and max(radii) <= 0.5 * 0.12 * ell
    # the curriculum hook: raising the difficulty to 1 draws the task's own scenes again
    easy.unwrapped.set_difficulty(1.0)
    _, a = easy.reset(seed=7)
    _, b = full.reset(seed=7)
    np.testing.assert_array_equal(a["obstacles"], b["obstacles"])


@pytest.mark.parametrize("value", [0.0, -0.5, 1.5, float("nan"), "easy"])
def test_bad_difficulty_raises_value_error_naming_it(value):
    with pytest.raises(ValueError, match="difficulty"):
        gym.make("cdcr_gym/CCKAObstacle-v0", difficulty=value)
    env = gym.make("cdcr_gym/CCKAObstacle-v0")
    with pytest.raises(ValueError, match="difficulty"):
        env.unwrapped.set_difficulty(value)


def test_tasks_without_a_curriculum_refuse_set_difficulty():
    for env_id in ("cdcr_gym/CCKAReach-v0", "cdcr_gym/CCKATrack-v0"):
        env = gym.make(env_id)
        with pytest.raises(ValueError, match="no curriculum"):
            env.unwrapped.set_difficulty(0.5)
