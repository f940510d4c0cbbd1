"""The numbers of evaluation episodes, for any task and any policy: one function,
:func:`summarize`.

:func:`summarize` reads the rollouts of :func:`training.run.rollout.run_episodes` (the last
step's ``info`` of each episode, the per-step distances and minima) and returns the JSON-ready
summary reported by ``cdcr-gym evaluate``, ``oracles`` and the sweep tables. Which metrics a
summary holds is named by the task itself, through the ``info`` keys its env reports:

* every task: ``episodes``, ``success_rate`` (the last step's ``is_success``), ``within_1mm``
  (final tip-to-goal distance ≤ 1 mm), ``mean_return``, ``final_distance_mm`` (statistics);
* ``tracking_rms`` in ``info`` (Track): ``tracking_rms_mm``, ``tracking_max_mm``;
* ``angle`` in ``info`` (Pose): ``final_angle_deg``, ``within_1mm_1deg``;
* ``collision`` in ``info`` (Obstacle): ``collision_rate``, ``collisions_in_successful_episodes``,
  ``min_clearance_mm``, and, with the safety filter on, ``filtered_step_fraction``;
* episodes longer than the training horizon: ``final_distance_mm_at_train_horizon`` and
  ``max_distance_after_train_horizon_mm`` (per episode the largest distance from the training
  episode length to the end: does the policy hold the goal);
* beside a reference run on the same episodes (the task's oracle): ``to_oracle``, the distance
  of the final cable state from the reference's — ``cable_length_distance_mm`` (Euclidean over
  the cables), ``tension_distance_n`` and ``tension_distance_bending_n`` (after removing each
  side's common-mode tension, min_i T_i, which does not bend the robot).

Statistics (:func:`error_stats`) are ``mean``, ``median``, ``p95``, ``max``; distances in mm,
angles in degrees, rates in [0, 1]. :func:`oracle_for` builds each task's oracle
(``cdcr_gym.controllers.ORACLES``) from an env.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import controllers
from training.run.rollout import Rollouts

__all__ = [
    "summarize",
    "error_stats",
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


def error_stats(values: Any, scale: float = 1.0) -> dict[str, float]:
    """``mean``, ``median``, ``p95``, ``max`` of ``values`` (array-like, (n,)) × ``scale``."""
    v = np.asarray(values, dtype=np.float64) * scale
    return {
        "mean": float(np.mean(v)),
        "median": float(np.median(v)),
        "p95": float(np.percentile(v, 95)),
        "max": float(np.max(v)),
    }


def _state_distances(run: Rollouts, reference: Rollouts) -> dict[str, dict[str, float]]:
    """Statistics of the distance between two runs' final cable states, episode by episode."""
    t, t_ref = run.final_tensions, reference.final_tensions
    bend = t - t.min(axis=-1, keepdims=True)
    bend_ref = t_ref - t_ref.min(axis=-1, keepdims=True)
    return {
        "cable_length_distance_mm": error_stats(
            np.linalg.norm(run.final_lengths - reference.final_lengths, axis=-1), 1000.0
        ),
        "tension_distance_n": error_stats(np.linalg.norm(t - t_ref, axis=-1)),
        "tension_distance_bending_n": error_stats(np.linalg.norm(bend - bend_ref, axis=-1)),
    }


def summarize(
    task: str,
    rollouts: Rollouts,
    train_horizon: int | None = None,
    reference: Rollouts | None = None,
) -> dict[str, Any]:
    """The reported numbers of ``rollouts`` (n episodes of ``task``; module docstring).

    Args:
        task: the task's name (``"Reach"``, ...), recorded in the summary.
        rollouts: the episodes (:func:`training.run.rollout.run_episodes`).
        train_horizon: the training episode length; episodes longer than it get the
            hold-the-goal numbers.
        reference: another policy's rollouts on the same episodes (the oracle's): adds
            ``to_oracle``.

    Returns:
        A JSON-ready dict.
    """
    final = rollouts.final_infos
    n = len(final)
    if n == 0:
        raise ValueError("rollouts: no episodes to summarize")
    distance_mm = 1e3 * rollouts.final_distance
    success = np.array([bool(info["is_success"]) for info in final])
    out: dict[str, Any] = {
        "task": task,
        "episodes": int(n),
        "success_rate": float(np.mean(success)),
        "within_1mm": float(np.mean(distance_mm <= 1.0)),
        "mean_return": float(np.mean(rollouts.returns)),
        "final_distance_mm": error_stats(distance_mm),
    }
    keys = set(final[-1])
    if "tracking_rms" in keys:
        out["tracking_rms_mm"] = error_stats([info["tracking_rms"] for info in final], 1e3)
        out["tracking_max_mm"] = error_stats([info["tracking_max"] for info in final], 1e3)
    if "angle" in keys:
        angle_deg = np.rad2deg(np.array([info["angle"] for info in final], np.float64))
        out["final_angle_deg"] = error_stats(angle_deg)
        out["within_1mm_1deg"] = float(np.mean((distance_mm <= 1.0) & (angle_deg <= 1.0)))
    if "collision" in keys:
        out["collision_rate"] = float(np.mean(rollouts.collided))
        out["collisions_in_successful_episodes"] = int(np.sum(rollouts.collided & success))
        out["min_clearance_mm"] = error_stats(rollouts.min_clearance, 1e3)
        if "safety_filtered" in keys:  # the env's safety filter is on
            fraction = rollouts.filtered_steps / np.maximum(rollouts.episode_length, 1)
            out["filtered_step_fraction"] = float(np.mean(fraction))
    steps = rollouts.distances.shape[1] - 1
    if train_horizon is not None and steps > train_horizon:
        d = rollouts.distances
        out["final_distance_mm_at_train_horizon"] = error_stats(d[:, train_horizon], 1e3)
        out["max_distance_after_train_horizon_mm"] = error_stats(
            d[:, train_horizon:].max(axis=1), 1e3
        )
    if reference is not None:
        out["to_oracle"] = _state_distances(rollouts, reference)
    return out
