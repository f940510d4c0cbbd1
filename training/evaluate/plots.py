"""Figures of training and evaluation runs (matplotlib, Agg backend, PNG files)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from training.run.logs import pyplot

__all__ = [
    "plot_error_histogram",
    "plot_workspace_errors",
    "plot_policy_vs_oracle",
    "plot_error_vs_step",
]


def plot_error_histogram(errors_mm: dict[str, np.ndarray], out: Path, title: str = "") -> Path:
    """Histogram (log-spaced bins) of final tip errors, one series per label."""
    plt = pyplot()
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

    plt = pyplot()
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


def plot_policy_vs_oracle(
    policy_mm: np.ndarray, oracle_mm: np.ndarray, out: Path, title: str = ""
) -> Path:
    """Per-episode final distance (n,) mm: policy vs the task's oracle on the same episodes
    (log–log), with the diagonal."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5))
    x = np.clip(np.asarray(oracle_mm), 1e-3, None)  # below 1 µm drawn at 1 µm
    y = np.clip(np.asarray(policy_mm), 1e-3, None)
    ax.scatter(x, y, s=12, alpha=0.7)
    lo = min(x.min(), y.min()) * 0.8
    hi = max(x.max(), y.max()) * 1.2
    ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="equal error")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_xlabel("oracle final distance (mm)")
    ax.set_ylabel("learned policy final distance (mm)")
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
    plt = pyplot()
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
