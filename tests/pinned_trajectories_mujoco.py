"""Rollouts of every MuJoCo id on fixed seeds and actions, pinned when the backend landed.

``python tests/pinned_trajectories_mujoco.py`` writes ``tests/data/pinned_mujoco_v1.npz`` from
the code as it is; ``tests/test_pinned.py`` checks that the current code reproduces it within the
tolerances of ``tests/tolerances.py``. Written once, on the commit that wired the MuJoCo backend into the tasks (before the
single-env speed work on the core), and not to be regenerated to make a refactor pass.

Pinned (the quantities of ``pinned_trajectories_v1``: observation, reward, terminated,
truncated, every numeric ``info`` entry), 12 steps each: every MuJoCo id in the tension and
tension-delta action modes, flat and goal-conditioned where the task has a goal; solid
obstacles; friction; randomisation and imperfections; the batched vector env (3 robots in one
backend) across autoresets.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from pinned_trajectories_v1 import GOAL_TASKS, TASKS, _actions, _rollout, _single

import cdcr_gym  # noqa: F401  (registers the ids)

PATH = Path(__file__).with_name("data") / "pinned_mujoco_v1.npz"
N_STEPS = 12


def trajectories() -> dict[str, np.ndarray]:
    """Every pinned MuJoCo quantity by ``<rollout>|<quantity>``."""
    out: dict[str, np.ndarray] = {}
    for task in TASKS:
        env_id = f"cdcr_gym/MuJoCo{task}-v0"
        for mode in ("tension", "tension_delta"):
            for gc in (False, True) if task in GOAL_TASKS else (False,):
                name = f"MuJoCo{task}/{mode}/gc{int(gc)}"
                _single(out, name, env_id, N_STEPS, 3, action_mode=mode, goal_conditioned=gc)
    _single(
        out,
        "MuJoCoObstacle/solid",
        "cdcr_gym/MuJoCoObstacle-v0",
        N_STEPS,
        8,
        action_mode="tension",
        solid_obstacles=True,
    )
    _single(
        out,
        "MuJoCoReach/friction",
        "cdcr_gym/MuJoCoReach-v0",
        N_STEPS,
        5,
        action_mode="tension",
        friction_coefficient=0.2,
    )
    _single(
        out,
        "MuJoCoReach/realism",
        "cdcr_gym/MuJoCoReach-v0",
        N_STEPS,
        6,
        randomize={"youngs_modulus": [30e9, 40e9], "tip_payload": [0.0, 0.01]},
        imperfections={"tip_noise": 0.001, "actuator_noise": 0.2},
    )
    for task in ("Reach", "Obstacle"):
        venv = gym.make_vec(
            f"cdcr_gym/MuJoCo{task}-v0",
            num_envs=3,
            vectorization_mode="vector_entry_point",
            max_episode_steps=5,
            autoreset_mode=AutoresetMode.NEXT_STEP,
            initial_state=["straight", "random", "straight"],
        )
        c = venv.single_action_space.shape[0]
        rec = _rollout(venv, 13, _actions(14, (N_STEPS, 3, c)))
        out.update(rec.arrays(f"vector/MuJoCo{task}"))
        venv.close()
    return out


if __name__ == "__main__":
    PATH.parent.mkdir(parents=True, exist_ok=True)
    data = trajectories()
    np.savez_compressed(PATH, **data)
    print(f"wrote {PATH}: {len(data)} arrays")
