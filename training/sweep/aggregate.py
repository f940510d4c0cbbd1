"""Aggregate a sweep: IQM with stratified-bootstrap confidence intervals, performance profiles.

Usage::

    python -m training.aggregate SWEEP_OUT [--doc docs/benchmark.md] [--reps 50000]

``SWEEP_OUT`` is a sweep's output directory (``runs/sweeps/<name>``, holding ``sweep.json``,
see :mod:`training.sweep`). Prints markdown tables and writes ``SWEEP_OUT/aggregate.json``;
``--doc PAGE`` also writes the benchmark page ``PAGE``, its figures in
``<PAGE dir>/figures/<page name>/`` and its data ``<PAGE dir>/figures/<page name>/results.json``.

**Scores.** One scalar per run and evaluation condition (``eval.json``'s ``conditions``, e.g.
``straight_h100``): the median final tip error (mm), the fraction of goals within 5 mm
(``success_rate``) and within 1 mm. Runs are grouped by (task = env id, algorithm = the config's
``algo`` and the sweep variant); the seeds of a group are its runs.

**Estimator.** The interquartile mean (IQM: the mean of the middle 50 % of the runs, the
``trim_mean(·, 0.25)`` of Agarwal et al., NeurIPS 2021, "Deep RL at the edge of the statistical
precipice") and its 95 % percentile confidence interval from a *stratified* bootstrap: each
bootstrap sample redraws, with replacement, the same number of runs *within each task*, pools
them and takes the IQM (50 000 samples by default, as rliable's ``get_interval_estimates``).
Per (task, algorithm) there is one stratum, so it is the ordinary bootstrap over seeds; the
across-task aggregate of the scale-free rates uses one stratum per task. The estimator is
written here (``iqm``, ``stratified_bootstrap_ci``: some twenty lines of numpy) instead of
depending on rliable: rliable is archived, pins old numpy/scipy/arch releases, and the method is
small enough to test against hand-computed values (``tests/test_aggregate.py``); it follows
rliable's definitions (scipy's trimming rule: ``int(0.25 n)`` runs cut at each end, so with
n ≤ 3 runs the IQM is the mean; percentile intervals).

**Performance profiles.** For error levels τ, the fraction of runs whose median final error is
≤ τ, with a stratified-bootstrap 95 % band (rliable's run-score distributions, for an error:
lower is better).

**Target.** The sweep's ``target`` thresholds (e.g. ``success_rate: 0.9``) are looked up in each
run's periodic evaluations (``eval_log.csv``): the env steps and training wall time of the first
evaluation meeting every threshold, or "not reached" within the budget.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shlex
import sys
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "iqm",
    "stratified_bootstrap",
    "stratified_bootstrap_ci",
    "performance_profile",
    "RunResult",
    "load_runs",
    "aggregate",
    "main",
]

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
#: what "success" means per task (the env's ``is_success`` at the last step)
SUCCESS = {
    "Reach": "final tip error ≤ 5 mm",
    "Track": "tip within 5 mm of the moving target at the last step",
    "Pose": "final tip error ≤ 5 mm and tip direction within 5°",
    "Obstacle": "final tip error ≤ 5 mm and no collision during the episode",
}


# -- the estimator ------------------------------------------------------------------------------
def iqm(scores: np.ndarray | Sequence[float], axis: int = -1) -> np.ndarray | float:
    """Interquartile mean along ``axis``: the mean after cutting ``int(0.25 n)`` values per end.

    Identical to ``scipy.stats.trim_mean(scores, 0.25, axis)`` (rliable's IQM). ``scores``: any
    shape with n ≥ 1 values along ``axis``. Returns a float for 1-D input, else an array with
    ``axis`` removed.
    """
    x = np.sort(np.asarray(scores, dtype=float), axis=axis)
    n = x.shape[axis]
    if n == 0:
        raise ValueError("scores must hold at least one value along axis, got an empty array")
    k = int(0.25 * n)
    out = np.take(x, np.arange(k, n - k), axis=axis).mean(axis=axis)
    return float(out) if np.ndim(out) == 0 else out


def stratified_bootstrap(
    groups: Sequence[np.ndarray | Sequence[float]],
    statistic: Callable[[np.ndarray], np.ndarray],
    reps: int = 50_000,
    seed: int = 0,
) -> np.ndarray:
    """``reps`` bootstrap replicates of ``statistic`` over the pooled, stratified resamples.

    ``groups``: one 1-D array of run scores per stratum (task). Each replicate draws, with
    replacement, ``len(g)`` runs from every group ``g`` independently, pools them (shape
    ``(reps, sum len(g))``) and applies ``statistic`` along the last axis. Returns shape
    ``(reps, ...)``. Deterministic for a given ``seed`` (``numpy.random.default_rng``).
    """
    if reps <= 0:
        raise ValueError(f"reps must be a positive integer, got {reps!r}")
    arrays = [np.asarray(g, dtype=float).ravel() for g in groups]
    if not arrays or any(a.size == 0 for a in arrays):
        raise ValueError("groups must be a non-empty list of non-empty score arrays")
    rng = np.random.default_rng(seed)
    pooled = np.concatenate([a[rng.integers(0, a.size, size=(reps, a.size))] for a in arrays], 1)
    return np.asarray(statistic(pooled))


def stratified_bootstrap_ci(
    groups: Sequence[np.ndarray | Sequence[float]],
    statistic: Callable[..., Any] = iqm,
    reps: int = 50_000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """Point estimate and percentile confidence interval of ``statistic`` over pooled groups.

    Returns ``(point, low, high)``: ``statistic`` of all runs pooled, and the ``(1 ± confidence)
    / 2`` quantiles of its stratified-bootstrap distribution (:func:`stratified_bootstrap`).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    point = float(statistic(np.concatenate([np.asarray(g, dtype=float).ravel() for g in groups])))
    boot = stratified_bootstrap(groups, lambda x: statistic(x, axis=-1), reps, seed)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(boot, [alpha, 1.0 - alpha])
    return point, float(low), float(high)


def performance_profile(
    groups: Sequence[np.ndarray | Sequence[float]],
    levels: np.ndarray,
    reps: int = 2_000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fraction of runs with a score ≤ each level, with a stratified-bootstrap band.

    ``groups``: run scores (errors: lower is better) per stratum; ``levels``: shape ``(L,)``.
    Returns ``(fraction, low, high)``, each of shape ``(L,)``.
    """
    levels = np.asarray(levels, dtype=float)

    def frac(x: np.ndarray, axis: int = -1) -> np.ndarray:
        return (np.moveaxis(x, axis, -1)[..., None] <= levels).mean(axis=-2)

    pooled = np.concatenate([np.asarray(g, dtype=float).ravel() for g in groups])
    boot = stratified_bootstrap(groups, frac, reps, seed)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(boot, [alpha, 1.0 - alpha], axis=0)
    return frac(pooled), low, high


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


def task_scores(summary: dict[str, Any]) -> dict[str, float]:
    """The scores of one policy's Track/Pose/Obstacle summary (``summarize_task`` in
    :mod:`training.task_metrics`): medians over the episodes (mm, °) and rates (fractions).

    Every task: ``median_error_mm`` (final tip distance to the goal or target) and
    ``success_rate``; Track: ``tracking_rms_mm``; Pose: ``final_angle_deg``, ``within_1mm_1deg``;
    Obstacle: ``collision_rate``.
    """
    out = {
        "median_error_mm": float(summary["final_distance_mm"]["median"]),
        "success_rate": float(summary["success_rate"]),
    }
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
    from training.sweep.tune import TARGET_KEYS

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
                data = json.loads((run_dir / "eval.json").read_text())
                run.kind = str(data.get("task", "Reach"))
                for name, c in data["conditions"].items():
                    if "policy" in c:  # Track, Pose, Obstacle: the task's own metrics
                        run.scores[name] = task_scores(c["policy"])
                        run.baselines[name] = {
                            k: task_scores(v) for k, v in c.items() if k != "policy"
                        }
                        continue
                    run.scores[name] = {
                        "median_error_mm": float(c["error_mm"]["median"]),
                        "success_rate": float(c["success_rate"]),
                        "within_1mm": float(c["within_1mm"]),
                    }
                    if "ik" in c:
                        run.baselines[name] = {
                            "analytic IK": {
                                "median_error_mm": float(c["ik"]["error_mm"]["median"]),
                                "success_rate": float(c["ik"]["success_rate"]),
                                "within_1mm": float(c["ik"]["within_1mm"]),
                            }
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
        conditions = sorted({c for r in members for c in r.scores}, key=_condition_order)
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
        conditions = sorted({c for r in members for c in r.scores}, key=_condition_order)
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


def _condition_order(name: str) -> tuple[int, str]:
    return (0 if name.startswith("straight") else 1, name)


# -- tables -------------------------------------------------------------------------------------
def _fmt_metric(metric: str, value: float) -> str:
    if METRICS[metric][1] == "%":
        return f"{100 * value:.1f} %"
    return f"{value:.3g}" if value < 100 else f"{value:.0f}"


def _fmt_ci(metric: str, m: dict[str, Any] | None) -> str:
    if m is None:
        return "–"
    low, high = m["ci"]
    unit = {"mm": " mm", "°": "°"}.get(METRICS[metric][1], "")
    if METRICS[metric][1] == "%":
        return f"{100 * m['iqm']:.1f} [{100 * low:.1f}, {100 * high:.1f}] %"
    return f"{_fmt_metric(metric, m['iqm'])} [{_fmt_metric(metric, low)}, {_fmt_metric(metric, high)}]{unit}"


def _fmt_value(metric: str, value: float | None) -> str:
    if value is None:
        return "–"
    unit = {"mm": " mm", "°": "°"}.get(METRICS[metric][1], "")
    return _fmt_metric(metric, value) + ("" if METRICS[metric][1] == "%" else unit)


def _group_metrics(groups: list[dict[str, Any]]) -> list[str]:
    return [m for m in METRICS if any(m in g for g in groups)]


def iqm_table(result: dict[str, Any]) -> list[str]:
    """Markdown: per task, one row per (algorithm, condition) with the IQM [95 % CI] of each of
    the task's metrics, then the task's baselines (oracle, analytic IK: one value, the same
    episodes for every run). One table per task, separated by a blank line and a task heading."""
    lines: list[str] = []
    tasks = sorted({g["task"] for g in result["groups"]})
    for task in tasks:
        groups = [g for g in result["groups"] if g["task"] == task]
        metrics = _group_metrics(groups)
        if len(tasks) > 1:
            lines += [f"**{task}**", ""]
        lines += [
            "| algorithm | condition | runs | "
            + " | ".join(f"{METRICS[m][0]}, IQM [95 % CI]" for m in metrics)
            + " |",
            "|---|---|---|" + "---|" * len(metrics),
        ]
        for g in groups:
            lines.append(
                f"| {g['algo']} | {g['condition']} | {g['runs']} "
                + "".join(f"| {_fmt_ci(m, g.get(m))} " for m in metrics)
                + "|"
            )
        seen = set()
        for g in groups:
            for name, scores in (g.get("baselines") or {}).items():
                if (name, g["condition"]) in seen:
                    continue
                seen.add((name, g["condition"]))
                lines.append(
                    f"| *{name}* | {g['condition']} | – "
                    + "".join(f"| {_fmt_value(m, scores.get(m))} " for m in metrics)
                    + "|"
                )
        lines.append("")
    return lines[:-1] if lines else lines


def aggregate_table(result: dict[str, Any]) -> list[str]:
    """Markdown: the across-task IQM of the rates per algorithm (stratified over tasks)."""
    if not result["aggregate"]:
        return []
    metrics = [m for m in RATE_METRICS if any(m in a for a in result["aggregate"])]
    lines = [
        "| algorithm | condition | tasks | runs | "
        + " | ".join(f"{METRICS[m][0]}, IQM [95 % CI]" for m in metrics)
        + " |",
        "|---|---|---|---|" + "---|" * len(metrics),
    ]
    for a in result["aggregate"]:
        lines.append(
            f"| {a['algo']} | {a['condition']} | {', '.join(a['tasks'])} | {a['runs']} "
            + "".join(f"| {_fmt_ci(m, a.get(m))} " for m in metrics)
            + "|"
        )
    return lines


def runs_table(runs: list[RunResult], target: dict[str, float]) -> list[str]:
    """Markdown: one row per run — budget use, target, final scores (or the failure)."""
    conds = sorted({c for r in runs for c in r.scores}, key=_condition_order)
    lines = [
        "| task | algorithm | seed | status | env steps | train wall time | steps to target "
        "| wall time to target | " + " | ".join(f"median error {c}" for c in conds) + " |",
        "|---|---|---|---|---|---|---|---|" + "---|" * len(conds),
    ]
    for r in sorted(runs, key=lambda r: (r.task, r.algo, r.seed)):
        hit = r.to_target
        tgt_steps = f"{int(hit['steps']):,}" if hit is not None else "not reached"
        tgt_wall = f"{hit['wall_time_s']:.0f} s" if hit is not None else "–"
        if not target:
            tgt_steps = tgt_wall = "(no target)"
        steps = f"{r.steps:,}" if r.steps is not None else "–"
        wall = f"{r.train_wall_time_s:.0f} s" if r.train_wall_time_s is not None else "–"
        errs = " | ".join(
            f"{r.scores[c]['median_error_mm']:.3g} mm" if c in r.scores else "–" for c in conds
        )
        lines.append(
            f"| {r.task} | {r.algo} | {r.seed} | {r.status} | {steps} | {wall} | {tgt_steps} "
            f"| {tgt_wall} | {errs} |"
        )
    return lines


def target_table(runs: list[RunResult], target: dict[str, float]) -> list[str]:
    """Markdown: per (task, algorithm): runs reaching the target, steps/time to it, budget use."""
    by_group: dict[tuple[str, str], list[RunResult]] = defaultdict(list)
    for r in runs:
        if r.status == "complete":
            by_group[(r.task, r.algo)].append(r)
    lines = [
        "| task | algorithm | runs | env steps in the budget (median) | reached the target "
        "| env steps to target (median [min, max]) | wall time to target (median [min, max]) |",
        "|---|---|---|---|---|---|---|",
    ]
    for (task, algo), members in sorted(by_group.items()):
        steps = [r.steps for r in members if r.steps is not None]
        hit = [r.to_target for r in members if r.to_target is not None]
        if hit:
            s = np.array([h["steps"] for h in hit])
            w = np.array([h["wall_time_s"] for h in hit])
            s_txt = f"{np.median(s):,.0f} [{s.min():,.0f}, {s.max():,.0f}]"
            w_txt = f"{np.median(w):.0f} s [{w.min():.0f}, {w.max():.0f}]"
        else:
            s_txt = w_txt = "–"
        lines.append(
            f"| {task} | {algo} | {len(members)} | "
            f"{np.median(steps):,.0f} | {len(hit)}/{len(members)} | {s_txt} | {w_txt} |"
            if steps
            else f"| {task} | {algo} | {len(members)} | – | {len(hit)}/{len(members)} "
            f"| {s_txt} | {w_txt} |"
        )
    return lines


# -- figures ------------------------------------------------------------------------------------
def _tasks_algos(runs: list[RunResult]) -> tuple[list[str], list[str]]:
    ok = [r for r in runs if r.scores]
    return sorted({r.task for r in ok}), sorted({r.algo for r in ok})


def _profile_score(scores: dict[str, float]) -> float:
    """The error of a run in the performance profiles: the median tracking RMS for Track, the
    median final tip error otherwise (mm)."""
    return scores.get("tracking_rms_mm", scores["median_error_mm"])


def plot_performance_profiles(
    runs: list[RunResult], path: Path, reps: int = 2_000, seed: int = 0
) -> Path:
    """Per task and condition: fraction of runs with median final error (Track: median tracking
    RMS) ≤ τ (log τ), with bands."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks, algos = _tasks_algos(runs)
    conds = sorted({c for r in runs for c in r.scores}, key=_condition_order)
    errors = [_profile_score(r.scores[c]) for r in runs for c in r.scores]
    lo = max(min(errors) / 2, 1e-3) if errors else 0.01
    hi = max(errors) * 2 if errors else 100.0
    levels = np.geomspace(lo, hi, 200)
    fig, axes = plt.subplots(
        1, max(len(tasks), 1), figsize=(5.0 * max(len(tasks), 1), 3.8), squeeze=False
    )
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ["-", "--", ":", "-."]
    for ax, task in zip(axes[0], tasks, strict=False):
        for i, algo in enumerate(algos):
            for j, cond in enumerate(conds):
                vals = [
                    _profile_score(r.scores[cond])
                    for r in runs
                    if r.task == task and r.algo == algo and cond in r.scores
                ]
                if not vals:
                    continue
                frac, low, high = performance_profile([vals], levels, reps=reps, seed=seed)
                color = colors[i % len(colors)]
                ax.step(
                    levels,
                    frac,
                    where="post",
                    color=color,
                    linestyle=styles[j % len(styles)],
                    label=f"{algo}, {cond} ({len(vals)} runs)",
                )
                ax.fill_between(levels, low, high, step="post", color=color, alpha=0.12)
        ax.axvline(5.0, color="0.6", lw=0.8)
        ax.axvline(1.0, color="0.6", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("error level τ (mm)")
        ax.set_title(task)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    axes[0][0].set_ylabel("fraction of runs with median final\nerror (Track: tracking RMS) ≤ τ")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_iqm(result: dict[str, Any], path: Path) -> Path:
    """Interval estimates: IQM and 95 % CI per (task, algorithm, condition), one panel per metric
    (a group without the metric, e.g. a tracking RMS outside Track, leaves its row empty)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullFormatter

    groups = result["groups"]
    metrics = _group_metrics(groups)
    labels = [f"{g['task']} · {g['algo']} · {g['condition']}" for g in groups]
    fig, axes = plt.subplots(
        1, len(metrics), figsize=(4.2 * len(metrics), 0.3 * len(groups) + 1.4), squeeze=False
    )
    y = np.arange(len(groups))
    nan = {"iqm": np.nan, "ci": [np.nan, np.nan]}
    for ax, metric in zip(axes[0], metrics, strict=True):
        title, unit, _ = METRICS[metric]
        scale = 100.0 if unit == "%" else 1.0
        mid = np.array([g.get(metric, nan)["iqm"] for g in groups]) * scale
        low = np.array([g.get(metric, nan)["ci"][0] for g in groups]) * scale
        high = np.array([g.get(metric, nan)["ci"][1] for g in groups]) * scale
        ok = np.isfinite(mid)
        ax.hlines(y[ok], low[ok], high[ok], lw=6, color="tab:blue", alpha=0.35)
        ax.plot(mid[ok], y[ok], "|", color="k", ms=14)
        ax.set_yticks(y, labels if ax is axes[0][0] else [""] * len(y), fontsize=8)
        ax.set_xlabel(f"IQM {title} ({unit})")
        low, high = low[ok], high[ok]
        if unit == "%":
            ax.set_xlim(-2, 102)
        elif len(low) and np.all(low > 0) and high.max() > 5 * low.min():
            ax.set_xscale("log")
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(alpha=0.3, axis="x")
        ax.invert_yaxis()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_curves(runs: list[RunResult], path: Path) -> Path:
    """Periodic-evaluation median error vs training wall time, every run (one panel per task)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks, algos = _tasks_algos(runs)
    fig, axes = plt.subplots(
        1, max(len(tasks), 1), figsize=(5.0 * max(len(tasks), 1), 3.6), squeeze=False
    )
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, task in zip(axes[0], tasks, strict=False):
        for i, algo in enumerate(algos):
            first = True
            for r in runs:
                if r.task != task or r.algo != algo or not r.curve:
                    continue
                t = [row["wall_time_s"] for row in r.curve]
                e = [row["median_error_mm"] for row in r.curve]
                ax.plot(
                    t,
                    e,
                    "o-",
                    ms=3,
                    color=colors[i % len(colors)],
                    label=algo if first else None,
                )
                first = False
        ax.set_yscale("log")
        ax.set_xlabel("training wall time (s)")
        ax.set_ylabel("eval median error (mm)" if task == tasks[0] else "")
        ax.set_title(task)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# -- the benchmark page -------------------------------------------------------------------------
def _machine(summary: dict[str, Any], runs: list[RunResult]) -> str:
    loads = [x for r in runs for x in r.loadavg]
    cpus = {t.get("cpu_count") for t in summary["trials"] if t.get("cpu_count")}
    load = (
        f"1-minute load average at the trials' starts and ends: median {np.median(loads):.2f}, "
        f"range {min(loads):.2f}–{max(loads):.2f}"
        if loads
        else "load average not recorded"
    )
    hosts = sorted({r.host for r in runs if r.host})
    return f"{', '.join(hosts) or '?'}, {', '.join(map(str, sorted(cpus)))} CPU cores; {load}"


def _sharing(summary: dict[str, Any], runs: list[RunResult], max_conc: int | None) -> str:
    """Whether the recorded load says other jobs shared the machine with the sweep's trials:
    a median 1-minute load above the trials running at once (``max_conc``, else the cores) + 0.5."""
    loads = [x for r in runs for x in r.loadavg]
    cpus = [t["cpu_count"] for t in summary["trials"] if t.get("cpu_count")]
    own = max_conc or (max(cpus) if cpus else None)
    if not loads or own is None:
        return "Whether other jobs shared the machine is unknown (no load recorded)."
    if float(np.median(loads)) <= own + 0.5:
        return (
            f"That load is the sweep's own {own} concurrent trial{'s' if own > 1 else ''}; "
            "the steps each run reached are in the tables."
        )
    return (
        "The machine was shared with other jobs while the sweep ran, so the wall-clock budget "
        "bought fewer env steps than on an idle machine; the steps each run reached are in the "
        "tables."
    )


def write_doc(
    page: Path,
    sweep_dir: Path,
    summary: dict[str, Any],
    runs: list[RunResult],
    result: dict[str, Any],
    argv: list[str],
    reps: int,
    note: str | None = None,
) -> None:
    """The benchmark page, its figures and its data (see the module docstring); ``note``: a
    paragraph placed under the page's introduction (e.g. why the budget is what it is)."""
    fig_dir = page.parent / "figures" / page.stem
    fig_dir.mkdir(parents=True, exist_ok=True)
    rel = f"figures/{page.stem}"
    plot_performance_profiles(runs, fig_dir / "performance_profiles.png")
    plot_iqm(result, fig_dir / "iqm.png")
    plot_curves(runs, fig_dir / "learning_curves.png")
    spec = summary.get("spec", {})
    target = spec.get("target") or {}
    budget = (spec.get("set") or {}).get("runtime.max_wall_time_s")
    sweep_file = next(
        (a for a in shlex.split(summary.get("command", "")) if a.endswith((".yaml", ".yml"))),
        "?",
    )
    sweep_cmd = "python -m training.sweep " + " ".join(shlex.split(summary.get("command", ""))[3:])
    agg_cmd = "python -m training.aggregate " + " ".join(shlex.quote(a) for a in argv)
    n_ok = sum(r.status == "complete" for r in runs)
    concurrency = summary.get("executor", "ray")
    cpus = spec.get("resources", {}).get("cpus_per_trial", 1)
    max_conc = spec.get("resources", {}).get("max_concurrent")
    kinds = {r.kind for r in runs if r.scores}
    data = {
        "sweep_file": sweep_file,
        "sweep_command": sweep_cmd,
        "aggregate_command": agg_cmd,
        "sweep_time": summary.get("time"),
        "runs": [asdict(r) for r in runs],
        **result,
    }
    for entry in data["runs"]:
        entry["curve"] = entry["curve"][-1:]  # keep the page's data small
    (fig_dir / "results.json").write_text(json.dumps(data, indent=1) + "\n")
    tgt_txt = (
        ", ".join(
            f"{k} {'≥' if k in RATE_METRICS else '≤'} {v:g}" for k, v in sorted(target.items())
        )
        if target
        else "none"
    )
    src = f"sweep `{sweep_file}`, `{sweep_cmd}`, then `{agg_cmd}`"
    lines = [
        "# Benchmark",
        "",
        "<!-- Generated by `python -m training.aggregate` (training/aggregate.py); do not edit: "
        "rerun the sweep and the generator. -->",
        "",
        f"Every number on this page comes from the {src} "
        f"(sweep run finished {summary.get('time', '?')}; {n_ok}/{len(runs)} trials complete). "
        f"The data behind the tables: [`{rel}/results.json`]({rel}/results.json).",
        "",
        *([note, ""] if note else []),
        "## Protocol",
        "",
        f"* **Budget**: every run trains for the same wall-clock budget, "
        f"**{budget:g} s of training wall time** (`runtime.max_wall_time_s`; the periodic "
        f"evaluations during training count against it), whatever the env steps it reaches. "
        f"Training stops at the first env step past the budget, then evaluates the final "
        f"weights once more, so the *train wall time* column exceeds the budget by that last "
        f"evaluation."
        if budget
        else "* **Budget**: the configs' own `total_timesteps` (no wall-clock budget set).",
        f"* **Runs**: each (task, algorithm) with seeds {sorted({r.seed for r in runs})}, as Ray "
        f"Tune trials ({concurrency} executor, {cpus:g} CPU per trial, "
        + (
            f"at most {max_conc} concurrent trial{'s' if max_conc > 1 else ''})"
            if max_conc
            else "so as many concurrent trials as cores)"
        )
        + ", each an ordinary `training.train` run directory.",
        f"* **Machine**: {_machine(summary, runs)}. " + _sharing(summary, runs, max_conc),
        "* **Scores**: after training, `python -m training.evaluate RUN_DIR --model best` on "
        "fixed goals (reset seeds from `evaluate.seed`, the same for every run) from each "
        "starting state (`straight_h100`: straight start, 100 steps; `random_h100`: a random "
        "starting shape). Per run: the median final tip error, and the fractions of goals "
        "within 5 mm and 1 mm"
        + (
            "; for Track, Pose and Obstacle the task's own metrics (`training.task_metrics`): "
            "the median over the episodes of the tracking RMS (Track, after the settling "
            "window), of the final tip direction error (Pose), the fraction of episodes with a "
            "collision (Obstacle), beside the task's oracle on the same episodes (and, for "
            "Obstacle, the plain reach IK that ignores the obstacles). **Success** is the env's "
            "`is_success` at the last step: "
            + "; ".join(f"{k}: {v}" for k, v in SUCCESS.items() if k in kinds)
            + ". The *median final error* is the final tip distance to the goal (Track: to "
            "the moving target)."
            if kinds - {"Reach"}
            else "."
        ),
        f"* **Estimator**: interquartile mean across runs with a 95 % stratified-bootstrap "
        f"percentile interval ({reps:,} resamples; rliable's method, implemented in "
        f"`training/aggregate.py`). With 3 runs per group the IQM cuts no run (`int(0.25·3) = 0`): "
        f"it equals the mean, and the interval comes from resampling only 3 values, so it is "
        f"wide and coarse.",
        f"* **Target** (for the time-to-target columns): the first periodic evaluation during "
        f"training (`eval_log.csv`) with {tgt_txt}.",
        "",
        f"Covered by this sweep: algorithms {', '.join(sorted({r.algo for r in runs}))}; "
        f"tasks {', '.join(sorted({r.task for r in runs}))}.",
        "",
        "## IQM per task and algorithm",
        "",
        *iqm_table(result),
        "",
        f"![IQM and 95 % CIs]({rel}/iqm.png)",
        "",
    ]
    agg = aggregate_table(result)
    if agg:
        lines += [
            "## Across tasks",
            "",
            "IQM of the rates over every task's runs, the bootstrap stratified by task "
            "(success as each task defines it, see Protocol).",
            "",
            *agg,
            "",
        ]
    lines += [
        "## Performance profiles",
        "",
        "Fraction of runs whose median final error (Track: median tracking RMS) is at most "
        "τ, with 95 % bootstrap bands (grey lines: 1 mm and 5 mm).",
        "",
        f"![performance profiles]({rel}/performance_profiles.png)",
        "",
        "## Env steps and wall time to the target",
        "",
        *target_table(runs, target),
        "",
        f"![learning curves]({rel}/learning_curves.png)",
        "",
        "## Every run",
        "",
        *runs_table(runs, target),
        "",
    ]
    failed = [r for r in runs if r.status != "complete"]
    if failed:
        lines += ["## Failed trials", ""]
        for r in failed:
            tail = (r.error or "").strip().splitlines()[-3:]
            lines.append(f"* `{r.trial_id}`: {r.status}; " + " / ".join(f"`{t}`" for t in tail))
        lines.append("")
    lines += [
        "## Reproduce",
        "",
        "```bash",
        f"nice -n 5 {sweep_cmd}",
        f"{agg_cmd}",
        "```",
        "",
        "A re-run of the sweep skips the finished trials; add the configs of new algorithms or "
        "tasks to the sweep file and rerun both commands to extend the tables.",
        "",
    ]
    page.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="python -m training.aggregate",
        description="IQM with stratified-bootstrap CIs and performance profiles of a sweep.",
    )
    parser.add_argument("sweep_dir", type=Path, metavar="SWEEP_OUT", help="a sweep's out_dir")
    parser.add_argument(
        "--doc", type=Path, default=None, help="write the benchmark page (e.g. docs/benchmark.md)"
    )
    parser.add_argument("--reps", type=int, default=50_000, help="bootstrap resamples (50 000)")
    parser.add_argument("--seed", type=int, default=0, help="bootstrap RNG seed")
    parser.add_argument(
        "--note", default=None, help="a paragraph for the page, under its introduction"
    )
    args = parser.parse_args(argv)
    if args.reps <= 0:
        print(f"error: --reps must be a positive integer, got {args.reps}", file=sys.stderr)
        return 2
    try:
        summary, runs = load_runs(args.sweep_dir)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    result = aggregate(runs, reps=args.reps, seed=args.seed)
    target = summary.get("spec", {}).get("target") or {}
    print("\n".join([*iqm_table(result), "", *target_table(runs, target)]))
    (args.sweep_dir / "aggregate.json").write_text(json.dumps(result, indent=1) + "\n")
    if args.doc is not None:
        write_doc(args.doc, args.sweep_dir, summary, runs, result, argv, args.reps, args.note)
        print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
