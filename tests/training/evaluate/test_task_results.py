"""training.task_results: collects task evaluations of several runs (fake runs, no training)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from training.evaluate import task_results


def _stats(value: float) -> dict[str, float]:
    return {"mean": value, "median": value, "p95": value, "max": 2 * value}


def _fake_run(root: Path, name: str, task: str, seed: int, rms: float) -> Path:
    run = root / name
    (run / "eval").mkdir(parents=True)
    summary = {"task": task, "episodes": 4, "success_rate": 0.75, "mean_return": -1.0}
    summary["final_distance_mm"] = _stats(rms)
    if task == "Track":
        summary["tracking_rms_mm"] = _stats(rms)
    if task == "Obstacle":
        summary.update(collision_rate=0.25, collisions_in_successful_episodes=0)
    condition = {"policy": summary, "oracle": {**summary, "success_rate": 1.0}}
    ev = {
        "task": task,
        "env_id": f"cdcr_gym/CCKA{task}-v0",
        "episodes": 4,
        "seed": 1000000,
        "model_step": 4096,
        "command": "python -m training.evaluate RUN",
        "conditions": {"straight_h100": condition},
    }
    (run / "eval.json").write_text(json.dumps(ev))
    meta = {"name": f"ppo_ccka_{task.lower()}", "seed": seed, "total_steps": 4096}
    meta["total_wall_time_s"] = 12.5
    (run / "run.json").write_text(json.dumps(meta))
    (run / "eval" / "straight_h100_paths.png").write_bytes(b"png")
    return run


def test_collects_runs_writes_json_copies_figures_and_prints_the_table(tmp_path, capsys):
    runs = [
        _fake_run(tmp_path, "a", "Track", 0, 0.5),
        _fake_run(tmp_path, "b", "Obstacle", 2, 3.0),
    ]
    out, figs = tmp_path / "out" / "results.json", tmp_path / "figs"
    code = task_results.main([*map(str, runs), "--out", str(out), "--figures", str(figs)])
    assert code == 0
    data = json.loads(out.read_text())
    assert [r["seed"] for r in data["runs"]] == [0, 2]
    assert (
        data["runs"][0]["conditions"]["straight_h100"]["policy"]["tracking_rms_mm"]["mean"] == 0.5
    )
    assert data["runs"][1]["train_wall_time_s"] == 12.5
    assert data["command"].startswith("cdcr-gym task-results ")
    assert (figs / "ppo_track_seed0_straight_h100_paths.png").read_bytes() == b"png"
    assert (figs / "ppo_obstacle_seed2_straight_h100_paths.png").exists()
    table = capsys.readouterr().out
    assert "tracking RMS mean 0.50 mm (max 1.00)" in table
    assert "collisions 25 % of episodes (0 in successful ones)" in table
    rows = [line for line in table.splitlines() if line.startswith("| ")]
    assert len(rows) == 3  # the header + one row per run and condition


def test_a_run_without_a_task_evaluation_is_an_error(tmp_path, capsys):
    run = _fake_run(tmp_path, "a", "Track", 0, 0.5)
    (run / "eval.json").unlink()
    assert task_results.main([str(run), "--out", str(tmp_path / "r.json")]) == 2
    assert "eval.json" in capsys.readouterr().err
    (run / "eval.json").write_text(json.dumps({"conditions": {}}))
    with pytest.raises(task_results.ResultsError, match="not a task evaluation"):
        task_results.collect([run])
