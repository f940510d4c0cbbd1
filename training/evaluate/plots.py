"""Figures of training and evaluation runs (matplotlib, Agg backend, PNG files)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "plot_learning_curve",
    "plot_error_histogram",
    "plot_workspace_errors",
    "plot_policy_vs_ik",
    "plot_error_vs_step",
]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    if not path.exists():
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return {}
    out = {}
    for key in rows[0]:
        vals = []
        for r in rows:
            try:
                vals.append(float(r.get(key) or "nan"))
            except ValueError:
                vals.append(np.nan)
        out[key] = np.asarray(vals)
    return out


def plot_learning_curve(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """``learning_curve.png``: eval success / tip error and training return vs env steps."""
    run_dir = Path(run_dir)
    out = Path(out) if out is not None else run_dir / "learning_curve.png"
    ev = _read_csv(run_dir / "eval_log.csv")
    pr = _read_csv(run_dir / "progress.csv")
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    ax = axes[0]
    if ev:
        steps = ev["timesteps"]
        ax.plot(steps, 100 * ev["success_rate"], "o-", ms=3, label="success @ threshold")
        ax.plot(steps, 100 * ev["within_1mm"], "s-", ms=3, label="within 1 mm")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("% of eval goals")
    ax.set_ylim(-2, 102)
    ax.set_title("periodic evaluation (fixed goals)")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    ax = axes[1]
    if ev:
        ax.semilogy(steps, ev["mean_error_mm"], "o-", ms=3, label="mean")
        ax.semilogy(steps, ev["median_error_mm"], "s-", ms=3, label="median")
        ax.semilogy(steps, ev["p95_error_mm"], "^-", ms=3, label="p95")
        ax.axhline(1.0, color="grey", ls=":", lw=1)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("final tip error (mm)")
    ax.set_title("periodic evaluation: final error")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper right")
    ax = axes[2]
    if pr and "rollout/ep_rew_mean" in pr:
        x = pr["time/total_timesteps"]
        ax.plot(x, pr["rollout/ep_rew_mean"], label="episode return (training)")
        ax.set_ylabel("return (sum of −distance, m)")
    if pr and "charts/final_error_mm_median" in pr:
        ax2 = ax.twinx()
        ax2.semilogy(
            pr["time/total_timesteps"],
            pr["charts/final_error_mm_median"],
            color="tab:orange",
            lw=1,
            label="median final error (training)",
        )
        ax2.set_ylabel("median final error, training episodes (mm)", color="tab:orange")
    ax.set_xlabel("environment steps")
    ax.set_title("training episodes")
    ax.grid(alpha=0.3)
    fig.suptitle(run_dir.name)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_error_histogram(errors_mm: dict[str, np.ndarray], out: Path, title: str = "") -> Path:
    """Histogram (log-spaced bins) of final tip errors, one series per label."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    floor = 1e-3  # errors below 1 µm (the exact IK on its own model) are drawn at 1 µm
    allv = np.clip(np.concatenate([np.asarray(v) for v in errors_mm.values()]), floor, None)
    lo, hi = np.min(allv), max(np.max(allv), np.min(allv) * 10)
    bins = np.logspace(np.log10(lo) - 0.05, np.log10(hi) + 0.05, 40)
    for label, v in errors_mm.items():
        v = np.asarray(v)
        if np.any(v < floor):
            label += f" ({np.mean(v < floor):.0%} < 1 µm, drawn at 1 µm)"
        ax.hist(np.clip(v, floor, None), bins=bins, alpha=0.55, label=label)
    ax.set_xscale("log")
    for x, txt in ((1.0, "1 mm"), (5.0, "5 mm")):
        ax.axvline(x, color="k", ls=":", lw=1)
        ax.text(x, ax.get_ylim()[1] * 0.95, txt, ha="right", va="top", fontsize=8, rotation=90)
    ax.set_xlabel("final tip error (mm)")
    ax.set_ylabel("episodes")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_workspace_errors(
    goals: np.ndarray, errors_mm: np.ndarray, out: Path, title: str = ""
) -> Path:
    """Goals over the workspace (top view x–y, and side view r–z), coloured by final error."""
    from matplotlib.colors import LogNorm

    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    g = np.asarray(goals) * 1000.0
    e = np.clip(np.asarray(errors_mm), 1e-3, None)
    norm = LogNorm(vmin=max(e.min(), 1e-3), vmax=max(e.max(), e.min() * 10))
    order = np.argsort(e)  # worst on top
    sc = axes[0].scatter(g[order, 0], g[order, 1], c=e[order], norm=norm, cmap="viridis", s=18)
    axes[0].set_aspect("equal")
    axes[0].set_xlabel("x (mm)")
    axes[0].set_ylabel("y (mm)")
    axes[0].set_title("top view")
    radial = np.hypot(g[:, 0], g[:, 1])
    axes[1].scatter(radial[order], g[order, 2], c=e[order], norm=norm, cmap="viridis", s=18)
    axes[1].set_xlabel("radial distance from axis (mm)")
    axes[1].set_ylabel("z (mm)")
    axes[1].set_title("side view")
    fig.colorbar(sc, ax=axes, label="final tip error (mm)")
    fig.suptitle(title)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_policy_vs_ik(policy_mm: np.ndarray, ik_mm: np.ndarray, out: Path, title: str = "") -> Path:
    """Per-goal final error: policy vs analytic IK (log–log), with the diagonal."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5))
    x = np.clip(np.asarray(ik_mm), 1e-3, None)  # below 1 µm drawn at 1 µm
    y = np.clip(np.asarray(policy_mm), 1e-3, None)
    ax.scatter(x, y, s=12, alpha=0.7)
    lo = min(x.min(), y.min()) * 0.8
    hi = max(x.max(), y.max()) * 1.2
    ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="equal error")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_xlabel("analytic IK final error (mm)")
    ax.set_ylabel("learned policy final error (mm)")
    ax.set_title(title)
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def plot_error_vs_step(
    curves: dict[str, np.ndarray], out: Path, train_horizon: int | None = None, title: str = ""
) -> Path:
    """Median and 95th percentile of the tip error vs step, per label ((n, T+1) m arrays)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, d in curves.items():
        mm = np.clip(np.asarray(d) * 1000.0, 1e-3, None)  # below 1 µm drawn at 1 µm
        t = np.arange(mm.shape[1])
        (line,) = ax.semilogy(t, np.median(mm, axis=0), label=f"{label} median")
        ax.semilogy(
            t, np.percentile(mm, 95, axis=0), ls="--", color=line.get_color(), label=f"{label} p95"
        )
    if train_horizon is not None:
        ax.axvline(train_horizon, color="grey", ls=":", lw=1)
        ax.text(train_horizon, ax.get_ylim()[1], " training episode length", va="top", fontsize=8)
    ax.axhline(1.0, color="k", ls=":", lw=0.8)
    ax.set_xlabel("step")
    ax.set_ylabel("tip error (mm)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
