"""``python -m training.evaluate.ik_demo``: roll out the analytic-IK controller and print tip errors.

A quick, training-free check that an environment works: the IK oracle
(``cdcr_gym.controllers.AnalyticIKController``) drives the robot to seeded goals, and the final
tip errors are printed per episode and summarised. On ``CCKAReach-v0`` the errors are ~1e-8 m
(the model is exact); on ``BulletReach-v0`` they show how far open-loop CCKA is from physics.
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401  (registers the ids)
from cdcr_gym.controllers import AnalyticIKController
from training.run.argtypes import non_negative_int, positive_int
from training.run.rollout import check_env_id


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cdcr-gym demo", description=__doc__.split("\n")[0])
    parser.add_argument("--env-id", default="cdcr_gym/CCKAReach-v0")
    parser.add_argument(
        "--action-mode",
        default="tension_delta",
        choices=["tension", "tension_delta", "length_delta"],
    )
    parser.add_argument("--episodes", type=positive_int, default=10)
    parser.add_argument("--seed", type=non_negative_int, default=0)
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    if not 0 <= args.seed <= 2**32 - 1 - args.episodes:
        parser.error(f"--seed must be an integer in [0, 2**32 - 1 - episodes], got {args.seed}")
    try:
        check_env_id(args.env_id, "--env-id")
    except ValueError as exc:
        parser.error(str(exc))
    try:
        env = gym.make(args.env_id, action_mode=args.action_mode)
    except (ValueError, TypeError, gym.error.Error) as exc:
        parser.error(f"--env-id/--action-mode: {exc}")
    controller = AnalyticIKController.from_env(env)
    errors = []
    start = time.perf_counter()
    steps = 0
    print(f"{'episode':>7} {'goal x, y, z (mm)':>26} {'final tip error (mm)':>21}")
    for episode in range(args.episodes):
        obs, info = env.reset(seed=args.seed + episode)
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(controller(obs))
            steps += 1
            done = terminated or truncated
        errors.append(info["distance"] * 1000.0)
        goal = ", ".join(f"{v:7.1f}" for v in info["goal"] * 1000.0)
        print(f"{episode:>7} {goal:>26} {errors[-1]:>21.6f}")
    env.close()
    errors = np.asarray(errors)
    elapsed = time.perf_counter() - start
    print(
        f"\n{args.env_id} ({args.action_mode}), analytic-IK controller, {args.episodes} episodes: "
        f"tip error mean {errors.mean():.6f} mm, max {errors.max():.6f} mm "
        f"({steps} steps in {elapsed:.2f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
