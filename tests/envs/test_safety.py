"""The model-based safety filter (``cdcr_gym.envs.safety``, env kwarg ``safety_filter``).

The projection on known barriers (exact numbers), its fall-backs, and on the Obstacle env: the
greedy reach IK — which runs into the spheres without the filter — never touches one with it
(the analytic backend is the filter's own model), safe commands pass unchanged, the batched env
filters row by row as the single envs do, and bad arguments are errors.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.envs.safety import SLACK_FRACTION, SafetyFilter
from training.run.metrics import oracle_for

pytestmark = pytest.mark.filterwarnings("error")

ENV_ID = "cdcr_gym/CCKAObstacle-v0"


def linear_barrier(normal, offset):
    """h(T) = offset − normal·T per row (a plane in tension space)."""
    normal = np.asarray(normal, float)
    return lambda tensions, rows: offset - tensions @ normal


def test_safe_commands_pass_unchanged_and_are_not_copied():
    f = SafetyFilter(linear_barrier([1.0, 0.0, 0.0], 10.0), 80.0, None, 0.0)
    commanded = np.array([[2.0, 3.0, 0.0], [9.0, 0.0, 1.0]])
    out, changed = f(commanded, np.zeros((2, 3)))
    assert out is commanded
    assert not changed.any()


def test_projection_removes_only_the_motion_into_the_barrier():
    # h = 1 − T_0; held at T_0 = 0.5 (h = 0.5): the step may use half of it, to h = 0.25
    f = SafetyFilter(linear_barrier([1.0, 0.0, 0.0], 1.0), 80.0, None, 0.0)
    held = np.array([[0.5, 1.0, 2.0]])
    commanded = np.array([[2.0, 4.0, 0.0]])
    out, changed = f(commanded, held)
    assert changed.tolist() == [True]
    target = 1.0 - SLACK_FRACTION * 0.5
    np.testing.assert_allclose(out, [[target, 4.0, 0.0]], atol=1e-9)
    assert commanded.tolist() == [[2.0, 4.0, 0.0]]  # inputs untouched


def test_projection_is_along_an_oblique_gradient_and_respects_the_margin():
    normal = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    f = SafetyFilter(linear_barrier(normal, 20.0), 80.0, None, 0.5)
    held = np.array([[10.0, 10.0, 0.0]])
    slack = 20.0 - held[0] @ normal - 0.5
    commanded = np.array([[20.0, 10.0, 3.0]])
    out, _ = f(commanded, held)
    np.testing.assert_allclose(20.0 - out @ normal, [0.5 + SLACK_FRACTION * slack], atol=1e-9)
    assert out[0, 2] == pytest.approx(3.0)  # tangential motion kept
    # the nearest such command: the correction is parallel to the gradient (−normal)
    correction = out[0] - commanded[0]
    np.testing.assert_allclose(np.cross(correction, normal), 0.0, atol=1e-9)


def test_projection_stays_within_the_tension_bounds():
    # from the straight robot T_1 cannot go below 0: the correction moves T_0 alone
    normal = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    f = SafetyFilter(linear_barrier(normal, 2.0), 80.0, None, 0.5)
    out, _ = f(np.array([[4.0, 0.0, 3.0]]), np.zeros((1, 3)))
    target = 0.5 + SLACK_FRACTION * 1.5
    np.testing.assert_allclose(out, [[(2.0 - target) * np.sqrt(2.0), 0.0, 3.0]], atol=1e-9)


def test_measured_clearance_shifts_every_prediction():
    # the model says h = 1 − T_0 (0.5 at the held 0.5); the robot measures 0.3: the model is
    # 0.2 optimistic, so a command the model finds safe (h = 0.1) is unsafe, and the projection
    # keeps the measured slack's half: measured h after the step = 0.15
    f = SafetyFilter(linear_barrier([1.0, 0.0, 0.0], 1.0), 80.0, None, 0.0)
    held, commanded = np.array([[0.5, 0.0, 0.0]]), np.array([[0.9, 2.0, 0.0]])
    out, changed = f(commanded, held)
    assert not changed.any()
    out, changed = f(commanded, held, measured=np.array([0.3]))
    assert changed.tolist() == [True]
    np.testing.assert_allclose(out, [[0.5 + 0.15, 2.0, 0.0]], atol=1e-9)
    # an infinite measurement (no sphere) leaves the model's prediction alone
    out, changed = f(commanded, held, measured=np.array([np.inf]))
    assert not changed.any()


def test_gradient_is_one_sided_at_a_tension_bound():
    f = SafetyFilter(linear_barrier([2.0, -1.0, 0.5], 5.0), 80.0, None, 0.0)
    held = np.array([[0.0, 80.0, 40.0]])  # at the lower bound, the upper bound, inside
    np.testing.assert_allclose(f.gradient(held, np.arange(1)), [[-2.0, 1.0, -0.5]], atol=1e-9)


def test_step_bound_then_fallbacks_hold_the_tensions_when_nothing_is_safe():
    # a barrier that the linearisation misses: h = 0.1 − |T − 1|² near the held T = 1 (h = 0.1
    # there), the command leaves it sideways; a flat gradient at T = held gives no projection
    def bowl(tensions, rows):
        return 0.1 - np.sum((tensions - 1.0) ** 2, axis=1)

    f = SafetyFilter(bowl, 80.0, 4.0, 0.0)
    held = np.ones((1, 3))
    out, changed = f(np.array([[3.0, 1.0, 1.0]]), held)  # h = −3.9; halved thrice: 0.0375
    assert changed.tolist() == [True]
    np.testing.assert_allclose(out, [[1.25, 1.0, 1.0]])
    commanded = np.array([[5.0, 1.0, 1.0]])  # h = −15.9: even 1/8 of the step is unsafe
    out, _ = f(commanded, held)
    np.testing.assert_allclose(out, held)
    # every motion lowers the clearance (a peak at the held tensions, below the margin): hold
    f_peak = SafetyFilter(lambda t, r: -np.sum((t - 1.0) ** 2, axis=1), 80.0, 4.0, 0.01)
    out, _ = f_peak(commanded, held)
    np.testing.assert_allclose(out, held)


def test_inside_the_margin_motion_may_slide_but_not_come_closer():
    f = SafetyFilter(linear_barrier([1.0, 0.0, 0.0], 1.0), 80.0, None, 5.0)  # never >= 5
    held = np.array([[0.5, 0.0, 0.0]])  # h = 0.5 < margin
    out, changed = f(np.array([[3.0, 2.0, 0.0]]), held)
    assert changed.tolist() == [True]
    np.testing.assert_allclose(out, [[0.5, 2.0, 0.0]], atol=1e-9)
    out, changed = f(np.array([[0.2, 2.0, 0.0]]), held)  # moving away passes unchanged
    assert not changed.any()


def run(env, policy, seeds):
    collided, filtered, successes = [], 0, 0
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        hit = False
        for _ in range(100):
            obs, _, _, _, info = env.step(np.asarray(policy(obs[None]))[0])
            hit |= bool(info["collision"])
            filtered += bool(info.get("safety_filtered", False))
        collided.append(hit)
        successes += bool(info["is_success"])
    return np.array(collided), filtered, successes


def test_reach_ik_never_touches_a_sphere_under_the_filter():
    seeds = range(1_000_000, 1_000_012)
    plain = gym.make(ENV_ID, tension_step=0.1)
    hits, _, _ = run(plain, oracle_for(plain, "reach_ik"), seeds)
    assert hits.sum() >= 6  # the direct route runs into the blocking sphere
    safe = gym.make(ENV_ID, tension_step=0.1, safety_filter=True)
    hits, filtered, successes = run(safe, oracle_for(safe, "reach_ik"), seeds)
    assert not hits.any()
    assert filtered > 0
    assert successes >= 6  # it slides around the sphere rather than stopping at it


def test_safe_commands_give_the_unfiltered_trajectory():
    plain = gym.make(ENV_ID)
    safe = gym.make(ENV_ID, safety_filter=True, safety_margin=0.001)
    rng = np.random.default_rng(0)
    plain.reset(seed=7)
    safe.reset(seed=7)
    for _ in range(5):  # small steps from the straight start keep far from the spheres
        action = 0.2 * rng.uniform(-1.0, 1.0, 3)
        _, r1, _, _, i1 = plain.step(action)
        _, r2, _, _, i2 = safe.step(action)
        assert i2["safety_filtered"] is False and i2["safety_correction"] == 0.0
        assert r1 == r2
        np.testing.assert_array_equal(i1["tensions"], i2["tensions"])


def test_penalty_is_charged_per_unit_of_correction():
    a = gym.make(ENV_ID, tension_step=0.1, safety_filter=True)
    b = gym.make(ENV_ID, tension_step=0.1, safety_filter=True, safety_penalty=2.0)
    ik_a, ik_b = oracle_for(a, "reach_ik"), oracle_for(b, "reach_ik")
    oa, _ = a.reset(seed=1_000_000)
    ob, _ = b.reset(seed=1_000_000)
    seen = 0
    for _ in range(60):
        oa, ra, _, _, ia = a.step(np.asarray(ik_a(oa[None]))[0])
        ob, rb, _, _, ib = b.step(np.asarray(ik_b(ob[None]))[0])
        assert ia["safety_correction"] == ib["safety_correction"]
        assert rb == pytest.approx(ra - 2.0 * ia["safety_correction"], abs=1e-12)
        seen += ia["safety_correction"] > 0.0
    assert seen > 0


def test_batched_env_filters_like_single_envs():
    kwargs = {"tension_step": 0.1, "safety_filter": True}
    n, seeds = 3, [1_000_000, 1_000_001, 1_000_002]
    batched = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    singles = [gym.make(ENV_ID, **kwargs) for _ in range(n)]
    obs_b, _ = batched.reset(seed=seeds)
    obs_s = [env.reset(seed=s)[0] for env, s in zip(singles, seeds)]
    ik = oracle_for(singles[0], "reach_ik")
    filtered = 0
    for _ in range(40):
        actions = np.stack([np.asarray(ik(o[None]))[0] for o in obs_s])
        obs_b, _, _, _, info_b = batched.step(actions)
        for k, env in enumerate(singles):
            obs_s[k], _, _, _, info = env.step(actions[k])
            np.testing.assert_allclose(info_b["tensions"][k], info["tensions"], atol=1e-9)
            assert info_b["safety_filtered"][k] == info["safety_filtered"]
            filtered += info["safety_filtered"]
    assert filtered > 0


@pytest.mark.parametrize(
    ("env_id", "kwargs", "message"),
    [
        ("cdcr_gym/CCKAReach-v0", {"safety_filter": True}, "needs a task with obstacles"),
        (ENV_ID, {"safety_filter": True, "action_mode": "length_delta"}, "tension action mode"),
        (ENV_ID, {"safety_margin": 0.01}, "need safety_filter=True"),
        (ENV_ID, {"safety_penalty": 1.0}, "need safety_filter=True"),
        (ENV_ID, {"safety_filter": True, "safety_margin": -0.01}, "safety_margin"),
        (ENV_ID, {"safety_filter": True, "safety_penalty": float("nan")}, "safety_penalty"),
        (ENV_ID, {"safety_filter": "yes"}, "safety_filter"),
    ],
)
def test_bad_arguments_are_value_errors(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


def test_task_metrics_report_the_share_of_filtered_steps():
    from training.run.metrics import summarize
    from training.run.rollout import EpisodeSpecs, run_episodes

    def env_fn(**extra):
        return lambda: gym.make(ENV_ID, tension_step=0.1, max_episode_steps=100, **extra)

    def run(fn, policy):
        return summarize(
            "Obstacle", run_episodes(fn, policy, EpisodeSpecs.from_seeds(4, 1_000_000))
        )

    safe = run(env_fn(safety_filter=True), oracle_for(env_fn(safety_filter=True)()))
    ik = oracle_for(env_fn(safety_filter=True)(), "reach_ik")
    pushed = run(env_fn(safety_filter=True), ik)
    assert 0.0 < pushed["filtered_step_fraction"] <= 1.0
    assert pushed["collision_rate"] == 0.0
    assert "filtered_step_fraction" in safe
    plain = run(env_fn(), ik)
    assert "filtered_step_fraction" not in plain
