"""The figures of a sweep's benchmark page: performance profiles, IQMs, learning curves
(matplotlib, Agg backend, PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from training.sweep.scores import METRICS, RunResult, condition_order, group_metrics
from training.sweep.statistics import performance_profile


# -- figures ------------------------------------------------------------------------------------
def tasks_algos(runs: list[RunResult]) -> tuple[list[str], list[str]]:
    ok = [r for r in runs if r.scores]
    return sorted({r.task for r in ok}), sorted({r.algo for r in ok})


def profile_score(scores: dict[str, float]) -> float:
    """The error of a run in the performance profiles: the median tracking RMS for Track, the
    median final tip error otherwise (mm)."""
    return scores.get("tracking_rms_mm", scores["median_error_mm"])


def reference_errors(runs: list[RunResult]) -> dict[str, dict[str, float]]:
    """Per task: each reference row's (oracles, random policy) error in the profiles' score
    (:func:`profile_score`) on the task's first condition (the straight start)."""
    out: dict[str, dict[str, float]] = {}
    for r in runs:
        if r.task in out or not r.baselines:
            continue
        cond = sorted(r.baselines, key=condition_order)[0]
        out[r.task] = {
            name: profile_score(scores)
            for name, scores in r.baselines[cond].items()
            if "median_error_mm" in scores
        }
    return out


def plot_performance_profiles(
    runs: list[RunResult], path: Path, reps: int = 2_000, seed: int = 0
) -> Path:
    """Per task and condition: fraction of runs with median final error (Track: median tracking
    RMS) ≤ τ (log τ), with bands; the task's reference rows (oracles, random policy) as vertical
    lines at their own error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks, algos = tasks_algos(runs)
    conds = sorted({c for r in runs for c in r.scores}, key=condition_order)
    errors = [profile_score(r.scores[c]) for r in runs for c in r.scores]
    references = reference_errors(runs)
    lo = max(min(errors) / 2, 1e-3) if errors else 0.01
    hi = max([*errors, *[v for refs in references.values() for v in refs.values()]]) * 2
    hi = hi if errors else 100.0
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
                    profile_score(r.scores[cond])
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
        for k, (name, value) in enumerate(sorted(references.get(task, {}).items())):
            # the reference rows' errors (same episodes, first condition): vertical lines; an
            # oracle more precise than the axis' left end sits on it, its value in the label
            ax.axvline(
                max(value, lo),
                color="k",
                lw=1.0,
                ls=(0, (1 + k, 2)),
                alpha=0.7,
                label=f"{name}: {value:.3g} mm" + (" (off the axis)" if value < lo else ""),
            )
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
    metrics = group_metrics(groups)
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

    tasks, algos = tasks_algos(runs)
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
