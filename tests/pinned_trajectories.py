"""Trajectories of the paper robot's envs on fixed seeds and actions, pinned across refactors.

``python tests/pinned_trajectories.py`` writes
``tests/data/pinned_v0.npz`` from the code as it is; ``tests/test_pinned.py`` checks that the
current code reproduces the file to 1e-12. The file was written once, before the n-section
core replaced the one-section code (commit "Pin today's paper-robot trajectories"), and must
not be regenerated to make a refactor pass.

Pinned: ``CCKAReach-v0`` for every action mode, flat and goal-conditioned, straight and random
starts, seeded goals; the batched vector env across autoresets; ``BulletReach-v0`` (gravity on
and off) from given goals and initial tensions (goal *sampling* on bullet changed on purpose:
goals now come from the bullet backend's own statics).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401  (registers the ids)

PATH = Path(__file__).with_name("data") / "pinned_v0.npz"
N_STEPS = 25


def _actions(seed: int, n: int, dim: int = 3) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size=(n, dim)).astype(np.float32)


def _flatten_obs(obs) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate(
            [
                np.asarray(obs[k], np.float64).ravel()
                for k in ("observation", "achieved_goal", "desired_goal")
            ]
        )
    return np.asarray(obs, np.float64).ravel()


def _rollout(env, seed: int, actions: np.ndarray, options=None) -> np.ndarray:
    obs, info = env.reset(seed=seed, options=options)
    rows = [
        np.concatenate(
            [
                _flatten_obs(obs),
                [0.0],
                info["tip"],
                info["tensions"],
                info["cable_lengths"],
                info["goal"],
            ]
        )
    ]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        rows.append(
            np.concatenate(
                [
                    _flatten_obs(obs),
                    [reward],
                    info["tip"],
                    info["tensions"],
                    info["cable_lengths"],
                    info["goal"],
                ]
            )
        )
    return np.stack(rows)


def trajectories(bullet: bool = True) -> dict[str, np.ndarray]:
    """Every pinned trajectory, by name (rows: obs, reward, tip, tensions, lengths, goal);
    ``bullet=False`` leaves out the pybullet ones."""
    out: dict[str, np.ndarray] = {}
    for mode in ("tension", "tension_delta", "length_delta"):
        for goal_conditioned in (False, True):
            for initial_state in ("straight", "random"):
                env = gym.make(
                    "cdcr_gym/CCKAReach-v0",
                    action_mode=mode,
                    goal_conditioned=goal_conditioned,
                    initial_state=initial_state,
                )
                for seed in (0, 7):
                    key = f"ccka/{mode}/gc{int(goal_conditioned)}/{initial_state}/seed{seed}"
                    out[key] = _rollout(env, seed, _actions(100 + seed, N_STEPS))
                env.close()
    env = gym.make("cdcr_gym/CCKAReach-v0", action_mode="length_delta")
    out["ccka/length_delta/goal_option"] = _rollout(
        env,
        3,
        _actions(5, N_STEPS),
        options={"goal": [0.1, -0.2, 0.5], "initial_tensions": [10.0, 0.0, 30.0]},
    )
    env.close()

    venv = gym.make_vec(
        "cdcr_gym/CCKAReach-v0",
        num_envs=4,
        vectorization_mode="vector_entry_point",
        initial_state="random",
    )
    obs, info = venv.reset(seed=11)
    rows = [np.concatenate([obs.ravel(), info["goal"].ravel()])]
    acts = _actions(12, 120 * 4).reshape(120, 4, 3)
    for a in acts:  # 120 steps > 100: crosses the autoreset at the time limit
        obs, reward, terminated, truncated, info = venv.step(a)
        rows.append(np.concatenate([obs.ravel(), reward, truncated.astype(np.float64)]))
    out["ccka_vector/random/seed11"] = np.stack(
        [np.resize(r, max(len(x) for x in rows)) for r in rows]
    )
    venv.close()
    if not bullet:
        return out

    for gravity in (False, True):
        env = gym.make("cdcr_gym/BulletReach-v0", gravity=gravity, routing="disk")
        out[f"bullet/gravity{int(gravity)}"] = _rollout(
            env,
            0,
            _actions(21, 15),
            options={"goal": [0.15, 0.1, 0.55], "initial_tensions": [20.0, 5.0, 0.0]},
        )
        env.close()
    env = gym.make("cdcr_gym/BulletReach-v0", action_mode="tension", gravity=True, routing="disk")
    out["bullet/tension"] = _rollout(env, 0, _actions(22, 10), options={"goal": [0.0, 0.2, 0.5]})
    env.close()
    return out


if __name__ == "__main__":
    PATH.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(PATH, **trajectories())
    print(f"wrote {PATH}")
