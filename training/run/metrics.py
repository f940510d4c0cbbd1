"""Each task's own episode metrics, for any policy (an oracle or a trained model).

:func:`run_task_episodes` runs a policy (flat observations in, actions out) in a single env for
episodes reset with seeds ``seed + i`` (the same scenes for every policy) and keeps each
episode's task metrics from its last step's ``info``:

* every task: ``return``, ``final_distance_mm``, ``success`` (the last step's ``is_success``);
* Track: ``tracking_rms_mm``, ``tracking_max_mm`` (after the settling window);
* Pose: ``final_angle_deg``;
* Obstacle: ``collided`` (any step), ``min_clearance_mm`` (smallest over the episode), and
  ``success`` = final distance within the threshold with no collision.

:func:`summarize_task` turns them into the numbers reported in README/docs (means, medians,
p95, max, rates). :func:`oracle_for` builds each task's oracle from an env.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from cdcr_gym import controllers

__all__ = ["run_task_episodes", "summarize_task", "oracle_for", "task_name", "is_physics"]


def task_name(env: Any) -> str:
    """The task of an env (``"Reach"``, ``"Track"``, ``"Pose"``, ``"Obstacle"``)."""
    return type(env.unwrapped.task).__name__


def is_physics(env: Any) -> bool:
    """Whether ``env`` runs a dynamic physics backend (pybullet, MuJoCo: a control timestep >
    0), on which the oracles are also evaluated closed loop."""
    return float(env.unwrapped.backend.control_timestep) > 0.0


def oracle_for(env: Any, kind: str = "oracle", **options: Any) -> Any:
    """The oracle policy of ``env``'s task: ``kind="oracle"`` open loop (the model's solution
    commanded as is), ``"closed_loop"`` the same oracle with ``feedback=True`` (corrected from
    the measured tip: the strong baseline on a physics backend), or ``"reach_ik"`` the plain
    reach IK controller on the task's goal (the baseline the Obstacle task must defeat).
    ``options``: keyword arguments of the controller (e.g. the planner's ``candidates``)."""

    if kind not in ("oracle", "closed_loop", "reach_ik"):
        raise ValueError(f"kind must be 'oracle', 'closed_loop' or 'reach_ik', got {kind!r}")
    feedback = kind == "closed_loop"
    task = env.unwrapped.task
    cls = controllers.AnalyticIKController if kind == "reach_ik" else controllers.oracle_for(task)
    return cls.from_env(env, feedback=feedback, **options)


def run_task_episodes(
    env_fn: Callable[[], gym.Env],
    policy: Callable[[np.ndarray], np.ndarray] | None,
    episodes: int,
    seed: int,
    record: int = 0,
) -> dict[str, Any]:
    """Per-episode metrics (arrays of length ``episodes``) of ``policy`` in ``env_fn()``.

    ``policy`` None runs the task's oracle (built from the env). ``record`` > 0 keeps the tip,
    target (Track) and obstacles (Obstacle) of the first ``record`` episodes in ``"paths"``.
    """
    env = env_fn()
    task = task_name(env)
    act = oracle_for(env) if policy is None else policy
    rows: dict[str, list[float]] = {}
    paths = []
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        total, clearance, collided, filtered, steps = 0.0, np.inf, False, 0, 0
        tips, targets = [info["tip"]], [info.get("target", info.get("goal"))]
        done = False
        while not done:
            action = np.asarray(act(obs[None]))[0]
            obs, reward, terminated, truncated, info = env.step(action)
            total += reward
            steps += 1
            done = terminated or truncated
            if task == "Obstacle":
                clearance = min(clearance, info["min_clearance"])
                collided = collided or bool(info["collision"])
                filtered += bool(info.get("safety_filtered", False))
            if i < record:
                tips.append(info["tip"])
                targets.append(info.get("target", info.get("goal")))
        row = {
            "return": total,
            "final_distance_mm": 1e3 * info["distance"],
            "success": float(info["is_success"]),
        }
        if task == "Track":
            row["tracking_rms_mm"] = 1e3 * info["tracking_rms"]
            row["tracking_max_mm"] = 1e3 * info["tracking_max"]
        elif task == "Pose":
            row["final_angle_deg"] = float(np.rad2deg(info["angle"]))
        elif task == "Obstacle":
            row["collided"] = float(collided)
            row["min_clearance_mm"] = 1e3 * clearance
            if "safety_filtered" in info:  # the env's safety filter is on
                row["filtered_step_fraction"] = filtered / max(steps, 1)
        for key, value in row.items():
            rows.setdefault(key, []).append(float(value))
        if i < record:
            entry = {"tip": np.array(tips), "target": np.array(targets)}
            if task == "Obstacle":
                entry["obstacles"] = info["obstacles"]
                entry["goal"] = info["goal"]
            paths.append(entry)
    env.close()
    out: dict[str, Any] = {key: np.array(v) for key, v in rows.items()}
    out["task"] = task
    if record:
        out["paths"] = paths
    return out


def _stats(values: np.ndarray) -> dict[str, float]:
    return {
        "mean": float(np.mean(values)),
        "median": float(np.median(values)),
        "p95": float(np.percentile(values, 95)),
        "max": float(np.max(values)),
    }


def summarize_task(metrics: dict[str, Any]) -> dict[str, Any]:
    """The reported numbers of :func:`run_task_episodes`' output (JSON-ready)."""
    task = metrics["task"]
    out: dict[str, Any] = {
        "task": task,
        "episodes": int(len(metrics["return"])),
        "success_rate": float(np.mean(metrics["success"])),
        "mean_return": float(np.mean(metrics["return"])),
        "final_distance_mm": _stats(metrics["final_distance_mm"]),
    }
    if task == "Track":
        out["tracking_rms_mm"] = _stats(metrics["tracking_rms_mm"])
        out["tracking_max_mm"] = _stats(metrics["tracking_max_mm"])
    elif task == "Pose":
        out["final_angle_deg"] = _stats(metrics["final_angle_deg"])
        out["within_1mm_1deg"] = float(
            np.mean((metrics["final_distance_mm"] <= 1.0) & (metrics["final_angle_deg"] <= 1.0))
        )
    elif task == "Obstacle":
        collided = metrics["collided"] > 0
        success = metrics["success"] > 0
        out["collision_rate"] = float(np.mean(collided))
        out["collisions_in_successful_episodes"] = int(np.sum(collided & success))
        out["min_clearance_mm"] = _stats(metrics["min_clearance_mm"])
        if "filtered_step_fraction" in metrics:  # the env's safety filter was on
            out["filtered_step_fraction"] = float(np.mean(metrics["filtered_step_fraction"]))
    return out
