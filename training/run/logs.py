"""The run's logs: SB3's logger (stdout, CSV continued on resume, TensorBoard) and CSV rows."""

from __future__ import annotations

import csv
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from training.run.rundir import RunDir


# -- CSV logs that survive --resume -------------------------------------------------------------
def append_csv(path: Path, row: dict[str, Any]) -> None:
    new = not path.exists()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(row))
        if new:
            writer.writeheader()
        writer.writerow(row)


def truncate_csv(path: Path, step_key: str, max_step: int) -> None:
    """Drop rows of ``path`` whose ``step_key`` exceeds ``max_step`` (logs past a checkpoint)."""
    if not path.exists():
        return
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        fields = reader.fieldnames or []
        rows = [r for r in reader if not r.get(step_key) or float(r[step_key]) <= max_step]
    # to a temporary file, then renamed: a full disk leaves the old log whole
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        with open(tmp, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=fields)
            writer.writeheader()
            writer.writerows(rows)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _resumable_csv_format(path: Path) -> Any:
    """An SB3 logger output that appends to ``path`` (keeping its rows) instead of truncating."""
    from stable_baselines3.common.logger import KVWriter, filter_excluded_keys

    class ResumableCSV(KVWriter):
        def __init__(self) -> None:
            self.rows: list[dict[str, Any]] = []
            self.keys: list[str] = []
            if path.exists():
                with open(path, newline="") as f:
                    reader = csv.DictReader(f)
                    self.keys = list(reader.fieldnames or [])
                    self.rows = list(reader)

        def write(self, key_values: dict[str, Any], key_excluded: Any, step: int = 0) -> None:
            values = filter_excluded_keys(key_values, key_excluded, "csv")
            row = {k: v for k, v in values.items() if isinstance(v, (int, float, str, np.number))}
            self.rows.append(row)
            extra = [k for k in row if k not in self.keys]
            if extra:
                self.keys.extend(sorted(extra))
                with open(path, "w", newline="") as f:
                    writer = csv.DictWriter(f, fieldnames=self.keys)
                    writer.writeheader()
                    writer.writerows(self.rows)
            else:
                with open(path, "a", newline="") as f:
                    csv.DictWriter(f, fieldnames=self.keys).writerow(row)

        def close(self) -> None:
            pass

    return ResumableCSV()


def make_logger(run: RunDir, verbose: bool = False) -> Any:
    """SB3's logger of a run: ``progress.csv`` (continued on resume) and TensorBoard; with
    ``verbose`` also SB3's tables on stdout (one per rollout: thousands of lines in a minute)."""
    from stable_baselines3.common.logger import HumanOutputFormat, Logger, TensorBoardOutputFormat

    run.tb.mkdir(parents=True, exist_ok=True)
    formats = [_resumable_csv_format(run.progress), TensorBoardOutputFormat(str(run.tb))]
    if verbose:
        formats.insert(0, HumanOutputFormat(sys.stdout))
    return Logger(folder=str(run.root), output_formats=formats)


# -- the learning curve ------------------------------------------------------------------------
def pyplot() -> Any:
    """matplotlib.pyplot on the Agg backend (imported when a figure is drawn)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV log as float arrays (empty cells and text: NaN); {} if none."""
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
    ev = read_csv(run_dir / "eval_log.csv")
    pr = read_csv(run_dir / "progress.csv")
    plt = pyplot()
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
    _legend_or_note(ax, "lower right")
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
    _legend_or_note(ax, "upper right")
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


def _legend_or_note(ax: Any, loc: str) -> None:
    """A legend for the curves drawn; before the first periodic evaluation (nothing drawn) a
    note instead of matplotlib's warning that no artist has a label."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc=loc)
    else:
        ax.text(0.5, 0.5, "no evaluation yet", ha="center", va="center", transform=ax.transAxes)
