"""The task oracles' numbers on fixed-seed episodes (the baselines of README/docs).

Usage::

    python -m training.evaluate.oracles --task track --episodes 200 [--backend CCKA] [--robot paper]
                               [--seed 1000000] [--out DIR] [--figures N] [--env-kwarg K=V ...]

Runs the task's oracle (``training.run.metrics.oracle_for``: tracking IK, pose IK, the
RRT-Connect planner) for ``--episodes`` episodes reset with seeds ``seed + i``
(``training.run.rollout.run_episodes``) and prints and writes its summary
(``training.run.metrics.summarize``, the same numbers as ``cdcr-gym evaluate``) (``DIR/oracle_<task>_<backend>_<robot>.json``). For the Obstacle task
the plain reach IK controller runs on the same episodes too (``reach_ik``: how often the direct
route collides). On the pybullet backend the oracles are open loop (they command the model's
solution). ``--figures N`` draws the first N episodes: target vs tip paths (Track), scenes with
the robot's tip path (Obstacle).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym import controllers
from training.evaluate import tables
from training.run.argtypes import non_negative_int, positive_int
from training.run.metrics import oracle_for, summarize, task_name
from training.run.rollout import EpisodeSpecs, parse_env_kwarg, run_episodes

__all__ = ["main", "run_oracle"]

#: --task name -> task class name (the tasks that have an oracle, cdcr_gym.controllers.ORACLES)
TASKS = {task.__name__.lower(): task.__name__ for task in controllers.ORACLES}


def run_oracle(
    task: str,
    episodes: int,
    backend: str = "CCKA",
    robot: str | None = None,
    seed: int = 1_000_000,
    env_kwargs: dict[str, Any] | None = None,
    record: int = 0,
) -> dict[str, Any]:
    """Summaries of the oracle (and, for Obstacle, the reach IK) on the same episodes."""

    env_id = f"cdcr_gym/{backend}{TASKS[task]}-v0"
    kwargs = dict(env_kwargs or {})
    if robot is not None:
        kwargs["robot"] = robot
    if backend == "Bullet":
        kwargs.setdefault("gravity", False)

    def env_fn() -> Any:
        return gym.make(env_id, **kwargs)

    probe = env_fn()
    robot_name = robot or ("tdcr2" if probe.unwrapped.params.n_sections == 2 else "paper")
    name = task_name(probe)
    policies = {"oracle": oracle_for(probe)}
    if "collision" in probe.unwrapped.task.info_keys():  # the direct route: how often it collides
        policies["reach_ik"] = oracle_for(probe, "reach_ik")
    probe.close()
    out: dict[str, Any] = {
        "env_id": env_id,
        "robot": robot_name,
        "env_kwargs": {k: v for k, v in kwargs.items() if k != "robot"},
        "seed": seed,
    }
    specs = EpisodeSpecs.from_seeds(episodes, seed)
    paths = {}
    for who, policy in policies.items():
        t0 = time.perf_counter()
        rollouts = run_episodes(env_fn, policy, specs, record=record)
        out[who] = summarize(name, rollouts)
        out[who]["wall_time_s"] = time.perf_counter() - t0
        paths["planner" if name == "Obstacle" and who == "oracle" else who] = rollouts.paths
    out["_paths"] = paths
    return out


def plot_paths(task: str, runs: dict[str, list[dict[str, Any]]], path: Path) -> None:
    """Target vs tip paths (Track) or scenes with tip paths (Obstacle), one panel per episode;
    ``runs`` maps a policy name to its recorded episodes (``Rollouts.paths``), the
    first drawn solid, the others dashed, on the same episodes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(runs)
    n = min(len(v) for v in runs.values()) if runs else 0
    if n == 0 or task not in ("Track", "Obstacle"):
        return
    colours = ["g", "r", "b", "m"]
    fig = plt.figure(figsize=(4 * n, 4))
    for i in range(n):
        ax = fig.add_subplot(1, n, i + 1, projection="3d")
        first = runs[names[0]][i]
        if task == "Track":
            ax.plot(*first["target"].T * 1e3, "c-", lw=3, alpha=0.6, label="target")
        else:
            u, v = np.mgrid[0 : 2 * np.pi : 16j, 0 : np.pi : 9j]
            for x, y, z, r in first["obstacles"]:
                if r <= 0:
                    continue
                ax.plot_wireframe(
                    1e3 * (x + r * np.cos(u) * np.sin(v)),
                    1e3 * (y + r * np.sin(u) * np.sin(v)),
                    1e3 * (z + r * np.cos(v)),
                    color="saddlebrown",
                    alpha=0.3,
                    lw=0.5,
                )
            ax.scatter(*first["goal"] * 1e3, color="purple", s=30, label="goal")
        for k, name in enumerate(names):
            style = "-" if k == 0 else "--"
            tip = runs[name][i]["tip"]
            ax.plot(*tip.T * 1e3, style, color=colours[k % 4], lw=1.5, label=f"tip ({name})")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
        ax.set_title(f"episode {i}")
        if i == 0:
            ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cdcr-gym oracles", description=__doc__)
    parser.add_argument("--task", required=True, choices=sorted(TASKS))
    parser.add_argument("--episodes", type=positive_int, default=200)
    parser.add_argument("--backend", default="CCKA", choices=["CCKA", "Bullet"])
    parser.add_argument("--robot", default=None, help="robot preset (default: the id's)")
    parser.add_argument("--seed", type=non_negative_int, default=1_000_000)
    parser.add_argument("--out", type=Path, default=Path("docs/figures/tasks"))
    parser.add_argument("--figures", type=non_negative_int, default=0, help="episodes to draw")
    parser.add_argument("--env-kwarg", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument(
        "--wide", action="store_true", help="every column (default: the ones that fit 100 columns)"
    )
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    try:
        env_kwargs = dict(parse_env_kwarg(t) for t in args.env_kwarg)
        result = run_oracle(
            args.task,
            args.episodes,
            args.backend,
            args.robot,
            args.seed,
            env_kwargs,
            record=args.figures,
        )
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    stem = f"oracle_{args.task}_{args.backend}_{result['robot']}"
    if args.figures:
        plot_paths(result["oracle"]["task"], result["_paths"], args.out / f"{stem}.png")
    result.pop("_paths")
    result["command"] = "cdcr-gym oracles " + " ".join(argv if argv is not None else sys.argv[1:])
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{stem}.json").write_text(json.dumps(result, indent=2) + "\n")
    where = f"{args.backend} {result['robot']}"
    rows = [(where, who, result[who]) for who in ("oracle", "reach_ik") if who in result]
    columns = tables.task_columns(result["oracle"]["task"], ("on", "backend and robot"))
    print(f"{result['env_id']}: {args.episodes} episodes from seed {args.seed}")
    print(tables.text_table(columns, rows, args.wide))
    print(tables.legend(columns, args.wide))
    print(tables.wrap(f"wrote {args.out / f'{stem}.json'}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
