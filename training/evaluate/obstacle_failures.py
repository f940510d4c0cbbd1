"""Why an Obstacle policy fails: its model replayed on evaluate's episodes, failures sorted.

    python -m training.evaluate.obstacle_failures RUN [--episodes 100] [--seed 1000000]
                                                      [--model best|final]

Runs ``RUN/best_model`` (``final_model`` with ``--model final``; by default the model the run's
config names in ``evaluate.model``, as ``cdcr-gym evaluate`` does), with its normalisation and
for any algorithm, on the episodes ``cdcr-gym evaluate`` uses
(reset seeds ``seed + i``, the run's env arguments, straight start) and sorts every failed
episode into one of three kinds, printed with counts and per-episode lines:

* ``collided``: a sphere was touched (the step of the first contact is listed);
* ``waited``: collision-free, but the tip never came within 10 % of its starting distance to the
  goal (the policy waited behind a sphere);
* ``missed``: collision-free and it came close, but ended outside the success radius (closest
  and final distance listed).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from training.run.argtypes import non_negative_int, positive_int
from training.run.config import EVALUATE_MODELS, load_config
from training.run.rollout import SB3Policy

__all__ = ["classify", "main"]


def classify(run: Path, episodes: int, seed: int, model: str = "best") -> dict[str, Any]:
    """Per-episode outcome of ``run``'s ``model`` ("best" or "final"): {"success": n,
    "collided": [...], "waited": [...], "missed": [...]} (lists of per-episode dicts)."""

    config = load_config(run / "config.yaml")
    kwargs = {**config.env.kwargs, "initial_state": "straight"}
    model_dir = run / f"{model}_model"
    vecnorm = model_dir / "vecnormalize.pkl"
    policy = SB3Policy(
        model_dir / "model.zip", vecnorm if vecnorm.exists() else None, algo=config.algo
    )
    env = gym.make(config.env.id, **kwargs)
    out: dict[str, Any] = {"success": 0, "collided": [], "waited": [], "missed": []}
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        start, first, closest = info["distance"], None, info["distance"]
        truncated = terminated = False
        t = 0
        while not (truncated or terminated):
            obs, _, terminated, truncated, info = env.step(policy(obs[None])[0])
            if info["collision"] and first is None:
                first = t
            closest = min(closest, info["distance"])
            t += 1
        row = {
            "episode": i,
            "spheres": int(np.sum(info["obstacles"][:, 3] > 0)),
            "final_mm": 1000 * info["distance"],
            "closest_mm": 1000 * closest,
            "first_contact_step": first,
        }
        if info["is_success"]:
            out["success"] += 1
        elif info["collided"]:
            out["collided"].append(row)
        elif closest > 0.9 * start:
            out["waited"].append(row)
        else:
            out["missed"].append(row)
    env.close()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m training.evaluate.obstacle_failures", description=__doc__
    )
    parser.add_argument("run", type=Path)
    parser.add_argument("--episodes", type=positive_int, default=100)
    parser.add_argument("--seed", type=non_negative_int, default=1_000_000)
    parser.add_argument(
        "--model",
        choices=EVALUATE_MODELS,
        default=None,
        help="which saved model (default: the config's evaluate.model, normally best)",
    )
    args = parser.parse_args(argv)
    if args.model is None:  # the config's evaluate.model, as cdcr-gym evaluate
        args.model = "best"
        if (args.run / "config.yaml").is_file():
            args.model = load_config(args.run / "config.yaml").evaluate.model
    if not (args.run / f"{args.model}_model" / "model.zip").exists():
        print(f"error: run: no {args.model}_model/model.zip in {args.run}", file=sys.stderr)
        return 2
    if args.episodes < 1:
        print(f"error: --episodes must be >= 1, got {args.episodes}", file=sys.stderr)
        return 2
    result = classify(args.run, args.episodes, args.seed, args.model)
    print(
        f"{args.run} ({args.model} model): success {result['success']} of {args.episodes}; failures: "
        f"collided {len(result['collided'])}, waited {len(result['waited'])}, "
        f"missed {len(result['missed'])}"
    )
    for kind in ("collided", "waited", "missed"):
        for row in result[kind]:
            print(
                f"  {kind:8s} episode {row['episode']:3d}: {row['spheres']} spheres, final "
                f"{row['final_mm']:.1f} mm, closest {row['closest_mm']:.1f} mm, first contact "
                f"at step {row['first_contact_step']}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
