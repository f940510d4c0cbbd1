"""Open-loop vs closed-loop oracles on the same episodes, per task and backend.

Usage::

    python -m experiments.oracle_feedback [--backend Bullet CCKA] [--task reach pose track obstacle]
                                       [--episodes 100] [--seed 1000000] [--gain 0.08]
                                       [--no-gravity] [--modes open closed]
                                       [--params PARAMS_YAML] [--action-mode MODE ...]
                                       [--initial-state straight random]
                                       [--displacement-step 0.001] [--tag TAG]
                                       [--out docs/figures/tasks]

For every backend and task it runs the task's oracle (``cdcr_gym.controllers``: reach IK on
Reach, tracking IK on Track, pose IK on Pose, the RRT-Connect planner on Obstacle) twice on the
same episodes — reset seeds ``seed + i``, so the same goals, paths and scenes — once open loop
(``feedback=False``: the model's solution commanded as is) and once closed loop
(``feedback=True``: resolved-rate correction from the measured tip, ``gain`` per step;
``--modes`` runs only one of the two). Robots:
each id's default (Reach, Track, Obstacle: the paper robot; Pose: tdcr2), or a fitted robot
``--params PARAMS_YAML`` (a physics backend then also gets the fit's backend arguments,
``calibration.backend_kwargs_from_yaml``, e.g. the FTDCR v4 twin). Physics backends run with
gravity on unless ``--no-gravity``. ``--action-mode`` (one row set per mode; default the env's)
and ``--displacement-step`` set the drive; ``--initial-state`` the starts (one row set each,
default straight). Every episode is the env's full 100 steps.

Per controller it reports: task success (``info["is_success"]`` at the last step: Pose also
needs 5°, Obstacle no collision in the episode), the fraction of episodes whose final tip is
within 5 mm of the goal, the final distance (median, p95, max, mm), and per task the final angle
(Pose), the tracking RMS over the steps after the settling window (Track) and the collision rate
and smallest clearance (Obstacle). It writes ``OUT/oracle_feedback_<backends>.json`` (every
number, the command, the environment arguments) and ``OUT/oracle_feedback_<backends>_table.txt``
(the command and the Markdown table; ``_<TAG>`` before the suffix with ``--tag``) and prints
the table.
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
from gymnasium import error as gym_error

import cdcr_gym  # noqa: F401
from cdcr_gym import controllers
from cdcr_gym.calibration.report import backend_kwargs_from_yaml
from cdcr_gym.controllers.ik import FEEDBACK_GAIN
from training.run.argtypes import non_negative_int, positive_float, positive_int

__all__ = ["run_study", "run_episodes", "summarize", "markdown_table", "main"]

TASKS = {task.__name__.lower(): task.__name__ for task in controllers.ORACLES}
WITHIN = 0.005  # m, the "within 5 mm" radius of the table


def _controller(env: Any, task: str, feedback: bool, gain: float) -> Any:

    cls: Any = controllers.oracle_for(env.unwrapped.task)
    return cls.from_env(env, feedback=feedback, gain=gain)


def run_episodes(env: Any, policy: Any, episodes: int, seed: int) -> dict[str, np.ndarray]:
    """Per-episode final metrics (arrays of length ``episodes``) of ``policy`` on ``env``,
    reset with seeds ``seed + i``."""
    task = type(env.unwrapped.task).__name__
    rows: dict[str, list[float]] = {}
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        collided, clearance = False, np.inf
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(policy(obs))
            done = terminated or truncated
            if task == "Obstacle":
                collided = collided or bool(info["collision"])
                clearance = min(clearance, float(info["min_clearance"]))
        row = {
            "final_distance_mm": 1e3 * float(info["distance"]),
            "success": float(info["is_success"]),
        }
        if task == "Pose":
            row["final_angle_deg"] = float(np.rad2deg(info["angle"]))
        elif task == "Track":
            row["tracking_rms_mm"] = 1e3 * float(info["tracking_rms"])
        elif task == "Obstacle":
            row["collided"] = float(collided)
            row["min_clearance_mm"] = 1e3 * clearance
        for key, value in row.items():
            rows.setdefault(key, []).append(value)
    return {key: np.asarray(values) for key, values in rows.items()}


def _stats(values: np.ndarray) -> dict[str, float]:
    return {
        "mean": float(np.mean(values)),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "max": float(np.max(values)),
    }


def summarize(metrics: dict[str, np.ndarray]) -> dict[str, Any]:
    """The reported numbers (JSON-ready) of :func:`run_episodes`' output."""
    distance = metrics["final_distance_mm"]
    out: dict[str, Any] = {
        "episodes": int(distance.size),
        "success_rate": float(np.mean(metrics["success"])),
        "within_5mm": float(np.mean(distance <= 1e3 * WITHIN)),
        "final_distance_mm": _stats(distance),
    }
    for key in ("final_angle_deg", "tracking_rms_mm", "min_clearance_mm"):
        if key in metrics:
            out[key] = _stats(metrics[key])
    if "collided" in metrics:
        out["collision_rate"] = float(np.mean(metrics["collided"]))
    return out


def run_study(
    backends: list[str],
    tasks: list[str],
    episodes: int,
    seed: int = 1_000_000,
    gain: float | None = None,
    gravity: bool = True,
    modes: tuple[str, ...] = ("open", "closed"),
    params: str | None = None,
    action_modes: tuple[str | None, ...] = (None,),
    initial_states: tuple[str | None, ...] = (None,),
    displacement_step: float | None = None,
) -> list[dict[str, Any]]:
    """One result row per (backend, task, action mode, initial state, mode in ``modes``: "open"
    and/or "closed" loop), on the same episodes; ``params`` a fitted robot's yaml (None: each
    id's default robot), ``None`` in ``action_modes``/``initial_states`` the env's default."""

    gain = FEEDBACK_GAIN if gain is None else gain
    results = []
    for backend, key, action_mode, initial_state in [
        (b, k, a, i) for b in backends for k in tasks for a in action_modes for i in initial_states
    ]:
        task = TASKS[key]
        env_id = f"cdcr_gym/{backend}{task}-v0"
        kwargs: dict[str, Any] = {}
        if params is not None:
            kwargs["params"] = params
            if backend != "CCKA":
                kwargs.update(backend_kwargs_from_yaml(params))
        if backend != "CCKA":
            kwargs["gravity"] = gravity
        for name, value in (
            ("action_mode", action_mode),
            ("initial_state", initial_state),
            ("displacement_step", displacement_step),
        ):
            if value is not None:
                kwargs[name] = value
        env = gym.make(env_id, **kwargs)
        robot_params = env.unwrapped.params  # type: ignore[attr-defined]
        if params is not None:
            robot = Path(params).parent.name
        else:
            robot = "tdcr2" if robot_params.n_sections == 2 else "paper"
        for feedback in [m == "closed" for m in modes]:
            policy = _controller(env, task, feedback, gain)
            t0 = time.perf_counter()
            metrics = run_episodes(env, policy, episodes, seed)
            row = {
                "task": task,
                "backend": backend,
                "env_id": env_id,
                "env_kwargs": kwargs,
                "robot": robot,
                "action_mode": env.unwrapped.action_mode,  # type: ignore[attr-defined]
                "initial_state": initial_state or "straight",
                "controller": type(policy).__name__,
                "mode": policy.mode,
                "gain": gain if feedback else None,
                "seed": seed,
                **summarize(metrics),
                "wall_time_s": time.perf_counter() - t0,
            }
            results.append(row)
            print(_row_text(row), flush=True)
        env.close()
    return results


def _extra(row: dict[str, Any]) -> str:
    if "final_angle_deg" in row:
        a = row["final_angle_deg"]
        return f"angle median {a['median']:.2f}°, p95 {a['p95']:.2f}°"
    if "tracking_rms_mm" in row:
        r = row["tracking_rms_mm"]
        return (
            f"tracking RMS mean {r['mean']:.2f} mm (median {r['median']:.2f}, p95 {r['p95']:.2f})"
        )
    if "collision_rate" in row:
        c = row["min_clearance_mm"]
        return f"collisions {100 * row['collision_rate']:.0f} %, min clearance median {c['median']:.1f} mm"
    return ""


def _backend_text(row: dict[str, Any]) -> str:
    if row["backend"] == "CCKA":
        return "CCKA"
    gravity = row["env_kwargs"].get("gravity", True)
    return f"{row['backend']} (gravity {'on' if gravity else 'off'})"


def _row_text(row: dict[str, Any]) -> str:
    d = row["final_distance_mm"]
    mode = "closed loop" if row["mode"] == "closed_loop" else "open loop"
    drive = f"{row.get('action_mode', '')}, {row.get('initial_state', 'straight')}"
    return (
        f"| {row['task']} | {row['robot']} | {_backend_text(row)} | {drive} | {mode} "
        f"| {row['episodes']} "
        f"| {100 * row['success_rate']:.0f} % | {100 * row['within_5mm']:.0f} % "
        f"| {d['median']:.3f} / {d['p95']:.3f} / {d['max']:.3f} | {_extra(row)} "
        f"| {row['wall_time_s']:.0f} s |"
    )


def markdown_table(results: list[dict[str, Any]]) -> str:
    """The study's table in Markdown, one row per (task, backend, mode)."""
    head = (
        "| task | robot | backend | action mode, start | oracle | episodes | task success "
        "| within 5 mm | final distance median / p95 / max (mm) | task metric | wall time |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    return head + "\n".join(_row_text(row) for row in results) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.oracle_feedback", description=__doc__
    )
    parser.add_argument("--backend", nargs="+", default=["Bullet", "CCKA"])
    parser.add_argument("--task", nargs="+", default=list(TASKS), choices=list(TASKS))
    parser.add_argument("--episodes", type=positive_int, default=100)
    parser.add_argument("--seed", type=non_negative_int, default=1_000_000)
    parser.add_argument(
        "--gain", type=positive_float, default=None, help="closed-loop gain per step"
    )
    parser.add_argument(
        "--no-gravity", action="store_true", help="physics backends without gravity"
    )
    parser.add_argument(
        "--modes", nargs="+", default=["open", "closed"], choices=["open", "closed"]
    )
    parser.add_argument("--params", default=None, help="a fitted robot's params.yaml")
    parser.add_argument("--action-mode", nargs="+", default=[None], help="default: the env's")
    parser.add_argument(
        "--initial-state", nargs="+", default=[None], choices=["straight", "random"]
    )
    parser.add_argument("--displacement-step", type=positive_float, default=None)
    parser.add_argument("--tag", default="", help="suffix of the output files' names")
    parser.add_argument("--out", type=Path, default=Path("docs/figures/tasks"))
    args = parser.parse_args(argv)

    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    try:
        results = run_study(
            args.backend,
            args.task,
            args.episodes,
            args.seed,
            args.gain,
            not args.no_gravity,
            tuple(args.modes),
            args.params,
            tuple(args.action_mode),
            tuple(args.initial_state),
            args.displacement_step,
        )
    except (ValueError, gym_error.Error) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    command = "python -m experiments.oracle_feedback " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    table = markdown_table(results)
    stem = "oracle_feedback_" + "_".join(args.backend) + (f"_{args.tag}" if args.tag else "")
    args.out.mkdir(parents=True, exist_ok=True)
    payload = {"command": command, "results": results}
    (args.out / f"{stem}.json").write_text(json.dumps(payload, indent=2) + "\n")
    # .txt, not .md: under docs/ a .md file would be a (navless) page of the mkdocs site
    (args.out / f"{stem}_table.txt").write_text(f"Command: `{command}`\n\n{table}")
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
