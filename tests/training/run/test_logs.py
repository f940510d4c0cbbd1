"""The run directory's learning-curve figure (training.run.logs.plot_learning_curve)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from training.run.logs import plot_learning_curve

EVAL_HEADER = "timesteps,success_rate,within_1mm,mean_error_mm,median_error_mm,p95_error_mm\n"


@pytest.mark.parametrize("evaluated", [False, True])
def test_the_learning_curve_is_drawn_without_warnings_before_and_after_the_first_evaluation(
    tmp_path: Path, evaluated: bool
) -> None:
    """Interrupted before its first periodic evaluation, a run once printed matplotlib's "No
    artists with labels found to put in legend" twice into the user's terminal."""
    (tmp_path / "progress.csv").write_text(
        "time/total_timesteps,rollout/ep_rew_mean\n128,-1.5\n256,-1.2\n"
    )
    if evaluated:
        (tmp_path / "eval_log.csv").write_text(
            EVAL_HEADER + "256,0.5,0.25,3.0,2.0,8.0\n512,0.75,0.5,1.5,1.0,4.0\n"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = plot_learning_curve(tmp_path)
    assert out == tmp_path / "learning_curve.png" and out.stat().st_size > 10_000
