"""Each task's own episode metrics, for any policy (an oracle or a trained model).

:func:`task_metrics` reads each episode's task metrics from the rollouts of
:func:`training.run.rollout.run_episodes` (its last step's ``info`` and the per-step minima);
:func:`run_task_episodes` runs a policy for episodes reset with seeds ``seed + i`` (the same
scenes for every policy) and returns them:

* every task: ``return``, ``final_distance_mm``, ``success`` (the last step's ``is_success``);
* Track: ``tracking_rms_mm``, ``tracking_max_mm`` (after the settling window);
* Pose: ``final_angle_deg``;
* Obstacle: ``collided`` (any step), ``min_clearance_mm`` (smallest over the episode), and
  ``success`` = final distance within the threshold with no collision.

:func:`summarize_task` turns them into the numbers reported in README/docs (means, medians,
p95, max, rates); :func:`summarize` and :func:`error_stats` the final-error numbers of the Reach
report. :func:`oracle_for` builds each task's oracle (``cdcr_gym.controllers.ORACLES``) from an
env.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from cdcr_gym import controllers
from training.run.rollout import EpisodeSpecs, Rollouts, run_episodes

__all__ = [
    "task_metrics",
    "run_task_episodes",
    "summarize_task",
    "error_stats",
    "summarize",
    "oracle_for",
    "task_name",
    "is_physics",
]


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


def task_metrics(task: str, rollouts: Rollouts) -> dict[str, Any]:
    """Per-episode metrics (arrays of length n) of ``task`` from its rollouts (module
    docstring), with ``"task"`` and, if recorded, ``"paths"``."""
    final = rollouts.final_infos
    out: dict[str, Any] = {
        "return": rollouts.returns.astype(np.float64),
        "final_distance_mm": 1e3 * np.array([info["distance"] for info in final], np.float64),
        "success": np.array([float(info["is_success"]) for info in final]),
    }
    if task == "Track":
        out["tracking_rms_mm"] = 1e3 * np.array([info["tracking_rms"] for info in final])
        out["tracking_max_mm"] = 1e3 * np.array([info["tracking_max"] for info in final])
    elif task == "Pose":
        out["final_angle_deg"] = np.rad2deg(np.array([info["angle"] for info in final], float))
    elif task == "Obstacle":
        out["collided"] = rollouts.collided.astype(np.float64)
        out["min_clearance_mm"] = 1e3 * rollouts.min_clearance
        if final and "safety_filtered" in final[-1]:  # the env's safety filter is on
            out["filtered_step_fraction"] = rollouts.filtered_steps / np.maximum(
                rollouts.episode_length, 1
            )
    out["task"] = task
    if rollouts.paths:
        out["paths"] = rollouts.paths
    return out


def run_task_episodes(
    env_fn: Callable[[], gym.Env],
    policy: Callable[[np.ndarray], np.ndarray] | None,
    episodes: int,
    seed: int,
    record: int = 0,
) -> dict[str, Any]:
    """Per-episode metrics (:func:`task_metrics`) of ``policy`` in ``env_fn()`` over
    ``episodes`` episodes reset with seeds ``seed + i`` (:func:`training.run.rollout.run_episodes`
    in one env, for the env's own episode length).

    ``policy`` None runs the task's oracle (built from the env). ``record`` > 0 keeps the tip,
    target (Track) and obstacles (Obstacle) of the first ``record`` episodes in ``"paths"``.
    """
    env = env_fn()
    try:
        task = task_name(env)
        act = oracle_for(env) if policy is None else policy
        rollouts = run_episodes(
            env_fn, act, EpisodeSpecs.from_seeds(episodes, seed), batch_size=1, record=record
        )
    finally:
        env.close()
    return task_metrics(task, rollouts)


def summarize_task(metrics: dict[str, Any]) -> dict[str, Any]:
    """The reported numbers of :func:`run_task_episodes`' output (JSON-ready)."""
    task = metrics["task"]
    out: dict[str, Any] = {
        "task": task,
        "episodes": int(len(metrics["return"])),
        "success_rate": float(np.mean(metrics["success"])),
        "mean_return": float(np.mean(metrics["return"])),
        "final_distance_mm": error_stats(metrics["final_distance_mm"]),
    }
    if task == "Track":
        out["tracking_rms_mm"] = error_stats(metrics["tracking_rms_mm"])
        out["tracking_max_mm"] = error_stats(metrics["tracking_max_mm"])
    elif task == "Pose":
        out["final_angle_deg"] = error_stats(metrics["final_angle_deg"])
        out["within_1mm_1deg"] = float(
            np.mean((metrics["final_distance_mm"] <= 1.0) & (metrics["final_angle_deg"] <= 1.0))
        )
    elif task == "Obstacle":
        collided = metrics["collided"] > 0
        success = metrics["success"] > 0
        out["collision_rate"] = float(np.mean(collided))
        out["collisions_in_successful_episodes"] = int(np.sum(collided & success))
        out["min_clearance_mm"] = error_stats(metrics["min_clearance_mm"])
        if "filtered_step_fraction" in metrics:  # the env's safety filter was on
            out["filtered_step_fraction"] = float(np.mean(metrics["filtered_step_fraction"]))
    return out


def error_stats(values: np.ndarray, scale: float = 1.0) -> dict[str, float]:
    """``mean``, ``median``, ``p95``, ``max`` of ``values`` × ``scale``."""
    v = np.asarray(values, dtype=np.float64) * scale
    return {
        "mean": float(np.mean(v)),
        "median": float(np.median(v)),
        "p95": float(np.percentile(v, 95)),
        "max": float(np.max(v)),
    }


def summarize(final_distance: np.ndarray, threshold: float) -> dict[str, Any]:
    """Success rate (at ``threshold`` m), fraction within 1 mm and error statistics in mm."""
    d = np.asarray(final_distance, dtype=np.float64)
    return {
        "success_rate": float(np.mean(d <= threshold)),
        "within_1mm": float(np.mean(d <= 0.001)),
        "error_mm": error_stats(d, 1000.0),
    }
