"""Rollouts of every registered id on fixed seeds and actions, pinned across the one-step-path
refactor (issue 22).

``python tests/pinned_trajectories_v1.py`` writes ``tests/data/pinned_v1.npz`` from the code as
it is; ``tests/test_pinned.py`` checks that the current code reproduces it within the tolerances of ``tests/tolerances.py``. The file
was written once, before the scalar lane was deleted (commit "Pin every registered id (v1)"),
and must not be regenerated to make a refactor pass (v0 keeps the older, paper-robot pin).

Pinned, 20 steps each (bullet: 8): every id (CCKA and Bullet × Reach/Track/Pose/Obstacle) in
every action mode it supports, flat and goal-conditioned where the task has a goal; sparse
rewards; random starts; domain randomisation and imperfections; the batched vector env in both
autoreset modes across several autoresets. Each rollout is stored per quantity as
``<rollout>|<quantity>`` (steps stacked, reset first): the observation, reward, terminated,
truncated and every numeric ``info`` entry.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

import cdcr_gym  # noqa: F401  (registers the ids)

PATH = Path(__file__).with_name("data") / "pinned_v1.npz"
N_STEPS = 20
N_BULLET = 8
TASKS = ("Reach", "Track", "Pose", "Obstacle")
GOAL_TASKS = ("Reach", "Pose")


def _actions(seed: int, shape: tuple[int, ...]) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size=shape).astype(np.float32)


def _flat(value: Any) -> np.ndarray:
    if isinstance(value, dict):
        return np.concatenate([_flat(value[k]) for k in sorted(value)])
    return np.asarray(value, dtype=np.float64).ravel()


def _numeric(info: dict[str, Any]) -> dict[str, np.ndarray]:
    """The numeric entries of ``info`` as float64 vectors (``final_info`` entries flattened)."""
    out: dict[str, np.ndarray] = {}
    for key in sorted(info):
        value = info[key]
        if key == "final_info":
            for sub, v in _numeric(value).items():
                out[f"final_info.{sub}"] = v
            continue
        if key == "final_obs":
            rows = [_flat(o) if o is not None else np.zeros(0) for o in value]
            out["final_obs"] = np.concatenate(rows) if rows else np.zeros(0)
            continue
        arr = np.asarray(value)
        if arr.dtype.kind in "biuf":
            out[key] = arr.astype(np.float64).ravel()
    return out


class _Recorder:
    def __init__(self) -> None:
        self.rows: list[dict[str, np.ndarray]] = []

    def add(self, obs: Any, info: dict[str, Any], reward=0.0, term=False, trunc=False) -> None:
        row = {"obs": _flat(obs), "reward": _flat(reward), "terminated": _flat(term)}
        row["truncated"] = _flat(trunc)
        row.update({f"info.{k}": v for k, v in _numeric(info).items()})
        self.rows.append(row)

    def arrays(self, name: str) -> dict[str, np.ndarray]:
        keys = sorted({k for r in self.rows for k in r})
        out = {}
        for k in keys:
            vals = [r.get(k, np.zeros(0)) for r in self.rows]
            width = max(v.size for v in vals)
            if all(v.size == width for v in vals):
                out[f"{name}|{k}"] = np.stack(vals)
            else:  # present at some steps only (final_info): pad with NaN, count the presence
                padded = np.full((len(vals), width), np.nan)
                for i, v in enumerate(vals):
                    padded[i, : v.size] = v
                out[f"{name}|{k}"] = padded
        return out


def _rollout(env, seed: int, actions: np.ndarray, options=None) -> _Recorder:
    rec = _Recorder()
    obs, info = env.reset(seed=seed, options=options)
    rec.add(obs, info)
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        rec.add(obs, info, reward, terminated, truncated)
    return rec


def _single(out: dict[str, np.ndarray], name: str, env_id: str, steps: int, seed: int, **kw):
    env = gym.make(env_id, **kw)
    c = env.action_space.shape[0]
    out.update(_rollout(env, seed, _actions(1000 + seed, (steps, c))).arrays(name))
    env.close()


def trajectories(bullet: bool = True) -> dict[str, np.ndarray]:
    """Every pinned quantity by ``<rollout>|<quantity>``; ``bullet=False`` leaves out pybullet."""
    out: dict[str, np.ndarray] = {}
    for task in TASKS:
        env_id = f"cdcr_gym/CCKA{task}-v0"
        for mode in ("tension", "tension_delta", "length_delta"):
            for gc in (False, True) if task in GOAL_TASKS else (False,):
                name = f"CCKA{task}/{mode}/gc{int(gc)}"
                _single(out, name, env_id, N_STEPS, 3, action_mode=mode, goal_conditioned=gc)
        _single(
            out,
            f"CCKA{task}/random_start",
            env_id,
            N_STEPS,
            5,
            initial_state="random",
            terminate_on_success=True,
        )
    for task in GOAL_TASKS:
        _single(
            out, f"CCKA{task}/sparse", f"cdcr_gym/CCKA{task}-v0", N_STEPS, 4, reward_type="sparse"
        )
    _single(
        out,
        "CCKAObstacle/collisions",
        "cdcr_gym/CCKAObstacle-v0",
        N_STEPS,
        8,
        action_mode="tension",
        penetration_weight=2.0,
        terminate_on_collision=True,
    )
    realism = dict(
        randomize={"youngs_modulus": [30e9, 40e9], "cable_radius": [0.027, 0.031]},
        imperfections={"tip_noise": 0.001, "tension_bias": 0.5, "actuator_noise": 0.2},
    )
    for mode in ("tension", "tension_delta"):
        _single(
            out,
            f"CCKAReach/realism/{mode}",
            "cdcr_gym/CCKAReach-v0",
            N_STEPS,
            6,
            action_mode=mode,
            **realism,
        )
    _single(
        out,
        "CCKAReach/realism/gc1",
        "cdcr_gym/CCKAReach-v0",
        N_STEPS,
        6,
        goal_conditioned=True,
        **realism,
    )
    _single(
        out,
        "CCKAReach/delay_lag",
        "cdcr_gym/CCKAReach-v0",
        N_STEPS,
        6,
        imperfections={"action_delay": 2, "tension_lag": 3.0, "tension_rate_limit": 2.0},
    )
    _single(
        out,
        "CCKAReach/length_realism",
        "cdcr_gym/CCKAReach-v0",
        N_STEPS,
        6,
        action_mode="length_delta",
        randomize={"cable_radius": [0.027, 0.031]},
        imperfections={"cable_length_noise": 0.0005},
    )
    env = gym.make("cdcr_gym/CCKAReach-v0")
    out.update(
        _rollout(
            env,
            2,
            _actions(9, (N_STEPS, 3)),
            {"goal": [0.1, -0.2, 0.5], "initial_tensions": [10.0, 0.0, 30.0]},
        ).arrays("CCKAReach/options")
    )
    env.close()

    # the batched env: several autoresets (max_episode_steps=7 over 20 steps), both modes
    for task in TASKS:
        for autoreset in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            for gc in (False, True) if task in GOAL_TASKS else (False,):
                venv = gym.make_vec(
                    f"cdcr_gym/CCKA{task}-v0",
                    num_envs=3,
                    vectorization_mode="vector_entry_point",
                    max_episode_steps=7,
                    autoreset_mode=autoreset,
                    goal_conditioned=gc,
                    initial_state=["straight", "random", "straight"],
                    terminate_on_success=True,
                )
                c = venv.single_action_space.shape[0]
                name = f"vector/CCKA{task}/{autoreset.value}/gc{int(gc)}"
                rec = _rollout(venv, 13, _actions(14, (N_STEPS, 3, c)))
                out.update(rec.arrays(name))
                venv.close()
    venv = gym.make_vec(
        "cdcr_gym/CCKAReach-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        max_episode_steps=6,
        action_mode="tension",
        **realism,
    )
    out.update(_rollout(venv, 21, _actions(22, (N_STEPS, 2, 3))).arrays("vector/CCKAReach/realism"))
    venv.close()
    if not bullet:
        return out

    for task in TASKS:
        env_id = f"cdcr_gym/Bullet{task}-v0"
        for mode in ("tension", "tension_delta"):
            for gc in (False, True) if task in GOAL_TASKS else (False,):
                name = f"Bullet{task}/{mode}/gc{int(gc)}"
                _single(
                    out,
                    name,
                    env_id,
                    N_BULLET,
                    3,
                    action_mode=mode,
                    goal_conditioned=gc,
                    routing="disk",  # the routing these rollouts were pinned with
                )
    _single(
        out,
        "BulletReach/realism",
        "cdcr_gym/BulletReach-v0",
        N_BULLET,
        6,
        gravity=False,
        routing="disk",
        randomize={"youngs_modulus": [30e9, 40e9], "tip_payload": [0.0, 0.01]},
        imperfections={"tip_noise": 0.001, "actuator_noise": 0.2},
    )
    return out


if __name__ == "__main__":
    PATH.parent.mkdir(parents=True, exist_ok=True)
    data = trajectories()
    np.savez_compressed(PATH, **data)
    print(f"wrote {PATH}: {len(data)} arrays")
