"""Names of the evaluation conditions: a starting state and an episode length.

``cdcr-gym evaluate`` runs every (starting state, horizon) of a config's ``evaluate`` section
and stores each as a condition named ``<state>_<horizon>steps`` (``straight_100steps``: from the
straight robot, 100 control steps). Evaluations written before that name read
``straight_h100``; every reader here (results tables, task results, sweep aggregation, sim2sim)
goes through :func:`read_eval`, which accepts both and returns the current names.

:func:`read_eval` also reads the shapes of before the one evaluation pipeline: a Reach file whose
conditions held the policy's numbers at their top level (``success_rate``, ``error_mm``) beside
``ik``, ``ik_closed_loop`` and ``random`` becomes the shape of every task — per condition one
summary per policy (``policy``, ``oracle``, ``oracle_closed_loop``, ``random``) with
``final_distance_mm`` for ``error_mm`` and the policy's distance to the IK solution as
``to_oracle``; a Track/Pose/Obstacle file gets its conditions' ``initial_state`` and
``horizon`` from their names. The numbers are not changed.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

__all__ = ["condition_name", "canonical_condition", "canonical_eval", "read_eval"]

_OLD = re.compile(r"(?P<state>[A-Za-z]+)_h(?P<steps>\d+)")
_NAME = re.compile(r"(?P<state>[A-Za-z]+)_(?P<steps>\d+)steps")
#: the old Reach file's baseline keys -> the names every task uses
_REACH_BASELINES = {"ik": "oracle", "ik_closed_loop": "oracle_closed_loop", "random": "random"}
_TO_ORACLE = ("cable_length_distance_mm", "tension_distance_n", "tension_distance_bending_n")


def condition_name(initial_state: str, horizon: int) -> str:
    """``straight``, 100 -> ``straight_100steps``."""
    return f"{initial_state}_{int(horizon)}steps"


def canonical_condition(name: str) -> str:
    """The current name of a condition: ``straight_h100`` (the former name) ->
    ``straight_100steps``; any other name unchanged."""
    m = _OLD.fullmatch(name)
    return condition_name(m["state"], int(m["steps"])) if m else name


def _old_reach_summary(block: dict[str, Any], episodes: Any) -> dict[str, Any]:
    """A summary of the old Reach shape (``success_rate``, ``within_1mm``, ``error_mm``, ...)
    in the shape of :func:`training.run.metrics.summarize`."""
    out: dict[str, Any] = {"task": "Reach"}
    if episodes is not None:
        out["episodes"] = episodes
    out["success_rate"] = block["success_rate"]
    if "within_1mm" in block:
        out["within_1mm"] = block["within_1mm"]
    if "mean_return" in block:
        out["mean_return"] = block["mean_return"]
    out["final_distance_mm"] = block["error_mm"]
    if "error_mm_at_train_horizon" in block:
        out["final_distance_mm_at_train_horizon"] = block["error_mm_at_train_horizon"]
    if "max_error_after_train_horizon_mm" in block:
        out["max_distance_after_train_horizon_mm"] = block["max_error_after_train_horizon_mm"]
    return out


def _old_reach_condition(cond: dict[str, Any], episodes: Any) -> dict[str, Any]:
    out: dict[str, Any] = {k: cond[k] for k in ("initial_state", "horizon") if k in cond}
    out["policy"] = _old_reach_summary(cond, episodes)
    ik = cond.get("ik", {})
    if all(k in ik for k in _TO_ORACLE):
        out["policy"]["to_oracle"] = {k: ik[k] for k in _TO_ORACLE}
    for old, new in _REACH_BASELINES.items():
        if old in cond:
            out[new] = _old_reach_summary(cond[old], episodes)
    return out


def canonical_eval(data: dict[str, Any]) -> dict[str, Any]:
    """An evaluation's data with current condition names (``conditions`` keys,
    ``headline_condition``) in the shape of every task (module docstring); other keys unchanged.
    A new dict; ``data`` is not modified."""
    out = dict(data)
    conditions = data.get("conditions")
    if isinstance(conditions, dict):
        conditions = {canonical_condition(k): v for k, v in conditions.items()}
        if any(isinstance(c, dict) and "error_mm" in c for c in conditions.values()):
            episodes = data.get("episodes")
            conditions = {k: _old_reach_condition(c, episodes) for k, c in conditions.items()}
            out["task"] = data.get("task", "Reach")
            for key in ("success_rate", "within_1mm", "error_mm", "ik", "ik_closed_loop"):
                out.pop(key, None)
        for name, cond in conditions.items():
            m = _NAME.fullmatch(name)
            if m and isinstance(cond, dict) and "initial_state" not in cond:
                conditions[name] = {
                    "initial_state": m["state"],
                    "horizon": int(m["steps"]),
                    **cond,
                }
        out["conditions"] = conditions
    if isinstance(data.get("headline_condition"), str):
        out["headline_condition"] = canonical_condition(data["headline_condition"])
    elif isinstance(conditions, dict) and conditions:
        out["headline_condition"] = next(iter(conditions))
    if isinstance(conditions, dict) and out.get("headline_condition") in conditions:
        head = conditions[out["headline_condition"]]
        out.update({k: v for k, v in head.items() if k not in ("initial_state", "horizon")})
    return out


def read_eval(path: str | Path) -> dict[str, Any]:
    """An ``eval*.json`` of ``cdcr-gym evaluate``, old or new, with current condition names."""
    return canonical_eval(json.loads(Path(path).read_text()))
