"""Step response of the tip: the physics backend vs CCKA with a modelled actuator response.

``python -m experiments.step_response [--tension 40] [--omega 0.44] [--steps 30]``: from the
straight robot, cable 1 is commanded ``--tension`` N at step 0 (``action_mode="tension"``) and
held; printed is the remaining fraction of the tip's way to its final position,
|tip_k − tip_final| / |tip_0 − tip_final|, after k control steps, for bullet (gravity on and off)
and for CCKA with ``imperfections={"tension_response": omega}``. The fit of ``omega`` that
``configs/ppo_ccka_dr_reach.yaml`` uses comes from this comparison (docs/experiments/sim2real.md).
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from training.run.argtypes import positive_float, positive_int

SHOWN = (1, 2, 3, 5, 8, 11, 16, 21)


def remaining(env_id: str, tension: float, steps: int, **kwargs) -> np.ndarray:
    """Remaining fraction (steps,) of the way to the final tip after each step."""

    env = gym.make(env_id, action_mode="tension", max_episode_steps=steps + 1, **kwargs)
    _, info = env.reset(seed=0)
    start = info["tip"].copy()
    action = np.full(env.action_space.shape, -1.0, np.float32)
    action[0] = 2.0 * tension / env.unwrapped.params.max_tension - 1.0
    tips = np.array([env.step(action)[4]["tip"] for _ in range(steps)])
    env.close()
    return np.linalg.norm(tips - tips[-1], axis=1) / np.linalg.norm(start - tips[-1])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.step_response", description=__doc__
    )
    parser.add_argument("--tension", type=positive_float, default=40.0)
    parser.add_argument("--omega", type=positive_float, default=0.44)
    parser.add_argument("--steps", type=positive_int, default=30)
    args = parser.parse_args(argv)
    rows = {
        "bullet, gravity on": ("cdcr_gym/BulletReach-v0", {"gravity": True}),
        "bullet, gravity off": ("cdcr_gym/BulletReach-v0", {"gravity": False}),
        f"CCKA, tension_response {args.omega}": (
            "cdcr_gym/CCKAReach-v0",
            {"imperfections": {"tension_response": args.omega}},
        ),
    }
    shown = [k for k in SHOWN if k <= args.steps]
    print(f"{'step':<34}" + "".join(f"{k:>7d}" for k in shown))
    for name, (env_id, kwargs) in rows.items():
        r = remaining(env_id, args.tension, args.steps, **kwargs)
        print(f"{name:<34}" + "".join(f"{r[k - 1]:7.3f}" for k in shown))


if __name__ == "__main__":
    main()
