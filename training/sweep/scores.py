"""A sweep's runs and their scores: what each trial's ``eval.json``, ``eval_log.csv`` and
``run.json`` say, grouped by task and algorithm and aggregated (IQM, bootstrap CIs)."""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from training.evaluate.conditions import read_eval
from training.sweep.statistics import stratified_bootstrap_ci
from training.sweep.tune import TARGET_KEYS

METRICS = {
    # key: (title, unit, lower is better)
    "median_error_mm": ("median final error", "mm", True),
    "success_rate": ("success", "%", False),
    "within_1mm": ("within 1 mm", "%", False),
    "tracking_rms_mm": ("median tracking RMS", "mm", True),
    "final_angle_deg": ("median final angle", "°", True),
    "within_1mm_1deg": ("within 1 mm and 1°", "%", False),
    "collision_rate": ("collision rate", "%", True),
}
RATE_METRICS = ("success_rate", "within_1mm")
#: the baselines in eval.json's conditions (every task) -> their row labels
BASELINES = {
    "oracle": "oracle",
    "oracle_closed_loop": "oracle, closed loop",
    "reach_ik": "reach IK (ignores the spheres)",
    "random": "random policy",
}
#: what "success" means per task (the env's ``is_success`` at the last step)
SUCCESS = {
    "Reach": "final tip error ≤ 5 mm",
    "Track": "tip within 5 mm of the moving target at the last step",
    "Pose": "final tip error ≤ 5 mm and tip direction within 5°",
    "Obstacle": "final tip error ≤ 5 mm and no collision during the episode",
}


# -- the estimator ------------------------------------------------------------------------------


# -- the runs of a sweep ------------------------------------------------------------------------
@dataclass
class RunResult:
    """One trial of a sweep, as read back from its records and run directory."""

    trial_id: str
    task: str  # env id without the namespace, e.g. "CCKAReach-v0"
    algo: str  # the config's algo (and the sweep variant, if any)
    seed: int
    status: str
    steps: int | None = None
    train_wall_time_s: float | None = None
    stopped_by: str | None = None
    #: condition -> {metric: value}; rates as fractions, errors in mm
    scores: dict[str, dict[str, float]] = field(default_factory=dict)
    #: the first periodic evaluation meeting the target: {"steps", "wall_time_s"}; None if none
    to_target: dict[str, float] | None = None
    #: periodic evaluations: rows of eval_log.csv (steps, wall_time_s, median_error_mm, ...)
    curve: list[dict[str, float]] = field(default_factory=list)
    error: str | None = None
    loadavg: list[float] = field(default_factory=list)  # 1-min load average, start and end
    host: str | None = None  # run.json's host platform
    #: the task kind of eval.json ("Reach", "Track", "Pose", "Obstacle")
    kind: str = "Reach"
    #: condition -> baseline name (e.g. "oracle", "analytic IK") -> {metric: value}, evaluated
    #: on the same episodes as the run (identical for every run of a task)
    baselines: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    part: str = ""  # the sweep part (sweeps run in parts)
    start: str | None = None  # when the trial started and ended (ISO 8601, the record's)
    end: str | None = None
    trial_wall_time_s: float | None = None  # training + evaluation


def task_scores(summary: dict[str, Any]) -> dict[str, float]:
    """The scores of one policy's summary (:func:`training.run.metrics.summarize`, any task):
    medians over the episodes (mm, °) and rates (fractions).

    Every task: ``median_error_mm`` (final tip distance to the goal or target),
    ``success_rate`` and ``within_1mm`` (absent in task files written before it was reported);
    Track: ``tracking_rms_mm``; Pose: ``final_angle_deg``, ``within_1mm_1deg``; Obstacle:
    ``collision_rate``.
    """
    out = {
        "median_error_mm": float(summary["final_distance_mm"]["median"]),
        "success_rate": float(summary["success_rate"]),
    }
    if "within_1mm" in summary:
        out["within_1mm"] = float(summary["within_1mm"])
    if "tracking_rms_mm" in summary:
        out["tracking_rms_mm"] = float(summary["tracking_rms_mm"]["median"])
    if "final_angle_deg" in summary:
        out["final_angle_deg"] = float(summary["final_angle_deg"]["median"])
        out["within_1mm_1deg"] = float(summary["within_1mm_1deg"])
    if "collision_rate" in summary:
        out["collision_rate"] = float(summary["collision_rate"])
    return out


def _label(record: dict[str, Any]) -> str:
    variant = record.get("variant") or {}
    algo = str(record.get("algo", "ppo")).upper()
    if variant:
        algo += " " + ", ".join(f"{k.split('.')[-1]}={v}" for k, v in variant.items())
    return algo


def _meets(row: dict[str, float], target: dict[str, float]) -> bool:

    for key, threshold in target.items():
        value = row.get(key)
        if value is None or not math.isfinite(value):
            return False
        if (value < threshold) if TARGET_KEYS[key] else (value > threshold):
            return False
    return True


def load_runs(sweep_dir: Path) -> tuple[dict[str, Any], list[RunResult]]:
    """``sweep.json`` and one :class:`RunResult` per trial (failed trials included)."""
    summary_path = sweep_dir / "sweep.json"
    if not summary_path.is_file():
        raise ValueError(f"SWEEP_OUT {str(sweep_dir)!r} has no sweep.json (run the sweep first)")
    summary = json.loads(summary_path.read_text())
    target = summary.get("spec", {}).get("target") or {}
    runs = []
    for record in summary["trials"]:
        run = RunResult(
            trial_id=record["trial_id"],
            task=str(record.get("env_id", "?")).split("/")[-1],
            algo=_label(record),
            seed=int(record.get("seed", -1)),
            status=record.get("status", "?"),
            error=record.get("error"),
            loadavg=[x[0] for x in (record.get("loadavg_start"), record.get("loadavg_end")) if x],
            part=str(record.get("part") or ""),
            start=record.get("start"),
            end=record.get("end"),
            trial_wall_time_s=record.get("wall_time_s"),
        )
        run_dir = Path(record.get("run_dir", ""))
        if run.status == "complete" and (run_dir / "run.json").is_file():
            meta = json.loads((run_dir / "run.json").read_text())
            run.steps = meta.get("total_steps")
            run.train_wall_time_s = meta.get("total_wall_time_s")
            run.stopped_by = meta.get("stopped_by")
            host = meta.get("host") or {}
            run.host = f"{host.get('hostname', '?')}: {host.get('platform', '?')}"
            if (run_dir / "eval.json").is_file():
                data = read_eval(run_dir / "eval.json")
                run.kind = str(data.get("task", "Reach"))
                for name, c in data["conditions"].items():
                    run.scores[name] = task_scores(c["policy"])
                    # the baselines on the same episodes: the oracle (open loop; on a physics
                    # backend also closed loop), the reach IK and the random policy (the floor)
                    run.baselines[name] = {
                        BASELINES.get(k, k): task_scores(v)
                        for k, v in c.items()
                        if k != "policy" and isinstance(v, dict)
                    }
            if (run_dir / "eval_log.csv").is_file():
                with open(run_dir / "eval_log.csv", newline="") as f:
                    for row in csv.DictReader(f):
                        values = {k: float(v) for k, v in row.items() if v not in (None, "")}
                        run.curve.append(values)
                        if run.to_target is None and target and _meets(values, target):
                            run.to_target = {
                                "steps": values["timesteps"],
                                "wall_time_s": values["wall_time_s"],
                            }
        runs.append(run)
    return summary, runs


def aggregate(runs: list[RunResult], reps: int = 50_000, seed: int = 0) -> dict[str, Any]:
    """IQM ± 95 % CI per (task, algorithm, condition, metric), and the across-task rates.

    Returns ``{"groups": [...], "aggregate": [...]}``; each entry names its task (or tasks),
    algorithm, condition, runs, and for each metric ``{"iqm", "ci": [low, high]}``.
    """
    ok = [r for r in runs if r.status == "complete" and r.scores]
    by_group: dict[tuple[str, str], list[RunResult]] = defaultdict(list)
    for r in ok:
        by_group[(r.task, r.algo)].append(r)
    groups = []
    for (task, algo), members in sorted(by_group.items()):
        conditions = sorted({c for r in members for c in r.scores}, key=condition_order)
        for cond in conditions:
            have = [r for r in members if cond in r.scores]
            entry: dict[str, Any] = {
                "task": task,
                "algo": algo,
                "condition": cond,
                "runs": len(have),
                "seeds": sorted(r.seed for r in have),
            }
            for metric in METRICS:
                if not all(metric in r.scores[cond] for r in have):
                    continue
                values = [r.scores[cond][metric] for r in have]
                point, low, high = stratified_bootstrap_ci([values], reps=reps, seed=seed)
                entry[metric] = {"iqm": point, "ci": [low, high], "values": values}
            baselines = next((r.baselines[cond] for r in have if cond in r.baselines), {})
            if baselines:
                entry["baselines"] = baselines
            groups.append(entry)
    across = []
    algos = sorted({r.algo for r in ok})
    for algo in algos:
        members = [r for r in ok if r.algo == algo]
        conditions = sorted({c for r in members for c in r.scores}, key=condition_order)
        for cond in conditions:
            per_task: dict[str, list[RunResult]] = defaultdict(list)
            for r in members:
                if cond in r.scores:
                    per_task[r.task].append(r)
            if len(per_task) < 2:
                continue
            entry = {
                "algo": algo,
                "condition": cond,
                "tasks": sorted(per_task),
                "runs": sum(len(v) for v in per_task.values()),
            }
            for metric in RATE_METRICS:
                if not all(metric in r.scores[cond] for v in per_task.values() for r in v):
                    continue  # e.g. within 1 mm: Reach only
                strata = [[r.scores[cond][metric] for r in per_task[t]] for t in sorted(per_task)]
                point, low, high = stratified_bootstrap_ci(strata, reps=reps, seed=seed)
                entry[metric] = {"iqm": point, "ci": [low, high]}
            across.append(entry)
    return {"groups": groups, "aggregate": across}


def condition_order(name: str) -> tuple[int, str]:
    return (0 if name.startswith("straight") else 1, name)


def group_metrics(groups: list[dict[str, Any]]) -> list[str]:
    """The metrics (of :data:`METRICS`) that any of ``groups`` has, in that order."""
    return [m for m in METRICS if any(m in g for g in groups)]
