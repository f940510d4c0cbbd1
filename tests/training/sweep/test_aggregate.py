"""training.sweep.aggregate: the IQM / stratified-bootstrap estimator, profiles, the benchmark page."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from training.sweep.aggregate import (
    aggregate,
    iqm,
    iqm_table,
    load_runs,
    main,
    performance_profile,
    stratified_bootstrap,
    stratified_bootstrap_ci,
)


# -- the estimator ------------------------------------------------------------------------------
def test_iqm_hand_computed() -> None:
    # 8 values: int(0.25 * 8) = 2 cut at each end -> mean(3, 4, 5, 6); the outlier is ignored.
    assert iqm([7, 1, 100, 3, 2, 6, 5, 4]) == pytest.approx(4.5)
    # 3 values: int(0.75) = 0 cut -> the plain mean
    assert iqm([3.0, 1.0, 2.0]) == pytest.approx(2.0)
    # 5 values: 1 cut at each end -> mean(2, 3, 10)
    assert iqm([50.0, 2.0, 3.0, 10.0, -7.0]) == pytest.approx(5.0)
    # along an axis, row by row
    rows = np.array([[7, 1, 100, 3, 2, 6, 5, 4], [1, 1, 1, 1, 9, 9, 9, 9]], dtype=float)
    np.testing.assert_allclose(iqm(rows, axis=-1), [4.5, 5.0])
    np.testing.assert_allclose(iqm(rows.T, axis=0), [4.5, 5.0])


def test_iqm_rejects_empty() -> None:
    with pytest.raises(ValueError, match="at least one value"):
        iqm([])


def test_bootstrap_ci_hand_computed() -> None:
    # Two runs {1, 2}: a resample's IQM (= mean) is 1, 1.5 or 2 with probabilities 1/4, 1/2, 1/4,
    # so the 2.5 % and 97.5 % quantiles are exactly 1 and 2.
    point, low, high = stratified_bootstrap_ci([[1.0, 2.0]], reps=20_000, seed=3)
    assert (point, low, high) == (1.5, 1.0, 2.0)


def test_bootstrap_ci_contains_iqm_and_is_deterministic() -> None:
    scores = [0.31, 0.52, 0.18, 0.77, 0.45, 0.66, 0.29, 0.91, 0.40]
    first = stratified_bootstrap_ci([scores], reps=5_000, seed=7)
    again = stratified_bootstrap_ci([scores], reps=5_000, seed=7)
    other = stratified_bootstrap_ci([scores], reps=5_000, seed=8)
    assert first == again
    assert first != other  # the seed does drive the resampling
    point, low, high = first
    assert point == pytest.approx(iqm(scores))
    assert low < point < high
    assert min(scores) <= low and high <= max(scores)


def test_bootstrap_is_stratified_by_task() -> None:
    """Every resample keeps each task's run count: runs are drawn within their own task."""
    task_a = [0.0, 0.0, 0.0]
    task_b = [1.0, 1.0, 1.0, 1.0, 1.0]
    zeros = stratified_bootstrap(
        [task_a, task_b], lambda x: (x == 0.0).sum(axis=-1), reps=1_000, seed=0
    )
    assert zeros.shape == (1_000,)
    assert np.all(zeros == 3)
    # hence the pooled IQM never moves: sorted (0,0,0,1,1,1,1,1), cut 2 per end -> 0.75
    assert stratified_bootstrap_ci([task_a, task_b], reps=1_000) == (0.75, 0.75, 0.75)
    # ... whereas one unstratified pool of the same eight runs does vary
    _, low, high = stratified_bootstrap_ci([task_a + task_b], reps=1_000)
    assert low < high


def test_bootstrap_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="reps"):
        stratified_bootstrap([[1.0]], np.mean, reps=0)
    with pytest.raises(ValueError, match="non-empty"):
        stratified_bootstrap([[1.0], []], np.mean)
    with pytest.raises(ValueError, match="confidence"):
        stratified_bootstrap_ci([[1.0, 2.0]], confidence=95)


def test_performance_profile_hand_computed() -> None:
    frac, low, high = performance_profile([[1.0, 2.0, 4.0]], np.array([0.5, 1.0, 3.0, 5.0]))
    np.testing.assert_allclose(frac, [0.0, 1 / 3, 2 / 3, 1.0])
    assert np.all(low <= frac + 1e-12) and np.all(frac <= high + 1e-12)
    assert low[0] == high[0] == 0.0 and low[-1] == high[-1] == 1.0


# -- a sweep's results --------------------------------------------------------------------------
def _fake_run(root: Path, trial_id: str, env: str, seed: int, errors: list[float]) -> dict:
    """A run directory as train + evaluate leave it, and its trial record."""
    run = root / "runs" / trial_id
    run.mkdir(parents=True)
    (run / "run.json").write_text(
        json.dumps({"status": "complete", "total_steps": 40_000, "total_wall_time_s": 60.0})
    )
    conditions = {
        name: {
            "success_rate": float(err <= 5.0),
            "within_1mm": float(err <= 1.0),
            "error_mm": {"median": err},
        }
        for name, err in zip(("straight_h100", "random_h100"), (errors[-1], 2 * errors[-1]))
    }
    (run / "eval.json").write_text(json.dumps({"conditions": conditions}))
    with open(run / "eval_log.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, ["timesteps", "success_rate", "median_error_mm", "wall_time_s"])
        writer.writeheader()
        for i, err in enumerate(errors):
            writer.writerow(
                {
                    "timesteps": 10_000 * (i + 1),
                    "success_rate": 1.0 if err < 3 else 0.0,
                    "median_error_mm": err,
                    "wall_time_s": 15.0 * (i + 1),
                }
            )
    return {
        "trial_id": trial_id,
        "env_id": f"cdcr_gym/{env}",
        "algo": "ppo",
        "variant": {},
        "seed": seed,
        "status": "complete",
        "run_dir": str(run),
        "cpu_count": 2,
        "loadavg_start": [1.5, 1.0, 1.0],
        "loadavg_end": [2.5, 2.0, 1.0],
    }


@pytest.fixture
def sweep_dir(tmp_path: Path) -> Path:
    root = tmp_path / "sweep"
    records = [
        _fake_run(root, "a_seed0", "CCKAReach-v0", 0, [9.0, 2.0, 0.5]),
        _fake_run(root, "a_seed1", "CCKAReach-v0", 1, [8.0, 6.0, 4.0]),
        _fake_run(root, "a_seed2", "CCKAReach-v0", 2, [7.0, 7.0, 7.0]),
        _fake_run(root, "b_seed0", "BulletReach-v0", 0, [9.0, 1.0]),
        {"trial_id": "b_seed1", "env_id": "cdcr_gym/BulletReach-v0", "seed": 1,
         "status": "failed", "error": "Traceback ...\nValueError: tension_step must be > 0"},
    ]  # fmt: skip
    summary = {
        "name": "t",
        "command": "python -m training.sweep configs/sweeps/t.yaml",
        "time": "2026-01-01T00:00:00",
        "spec": {"target": {"success_rate": 0.9}, "set": {"runtime.max_wall_time_s": 60}},
        "trials": records,
    }
    (root / "sweep.json").write_text(json.dumps(summary))
    return root


def test_load_runs_finds_the_target_and_the_failure(sweep_dir: Path) -> None:
    _, runs = load_runs(sweep_dir)
    by_id = {r.trial_id: r for r in runs}
    assert by_id["a_seed0"].to_target == {"steps": 20_000, "wall_time_s": 30.0}
    assert by_id["a_seed1"].to_target is None  # 4 mm is never < 3 mm in the fake log
    assert by_id["b_seed0"].to_target == {"steps": 20_000, "wall_time_s": 30.0}
    assert by_id["b_seed1"].status == "failed" and "tension_step" in by_id["b_seed1"].error
    # eval.json of before the renaming (random_h100): read under the current name
    assert by_id["a_seed2"].scores["random_100steps"]["median_error_mm"] == 14.0


def test_aggregate_groups_by_task_and_algorithm(sweep_dir: Path) -> None:
    _, runs = load_runs(sweep_dir)
    result = aggregate(runs, reps=2_000)
    group = next(
        g
        for g in result["groups"]
        if g["task"] == "CCKAReach-v0" and g["condition"] == "straight_100steps"
    )
    assert group["runs"] == 3 and group["algo"] == "PPO"
    # three runs: the IQM is the mean of the final medians 0.5, 4 and 7
    assert group["median_error_mm"]["iqm"] == pytest.approx((0.5 + 4.0 + 7.0) / 3)
    assert group["success_rate"]["iqm"] == pytest.approx(2 / 3)
    bullet = [g for g in result["groups"] if g["task"] == "BulletReach-v0"]
    assert {g["runs"] for g in bullet} == {1}  # the failed seed is not a score
    (across,) = [a for a in result["aggregate"] if a["condition"] == "straight_100steps"]
    assert across["tasks"] == ["BulletReach-v0", "CCKAReach-v0"] and across["runs"] == 4


def test_aggregate_cli_writes_the_page(sweep_dir: Path, tmp_path: Path, capsys) -> None:
    page = tmp_path / "docs" / "bench.md"
    assert main([str(sweep_dir), "--doc", str(page), "--reps", "500"]) == 0
    text = page.read_text()
    assert "60 s of training wall time" in text
    assert "configs/sweeps/t.yaml" in text
    assert "b_seed1" in text and "tension_step" in text  # the failure is reported
    assert "1/3" in text  # CCKA runs reaching the target
    for name in ("performance_profiles.png", "iqm.png", "learning_curves.png", "results.json"):
        assert (page.parent / "figures" / "bench" / name).stat().st_size > 0
    assert (sweep_dir / "aggregate.json").is_file()
    assert "CCKAReach-v0" in capsys.readouterr().out


def test_aggregate_cli_errors(tmp_path: Path, capsys) -> None:
    assert main([str(tmp_path)]) == 2
    assert "sweep.json" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # an argparse usage error (shared argument types)
        main([str(tmp_path), "--reps", "0"])
    assert exc.value.code == 2
    assert "--reps" in capsys.readouterr().err


def _fake_task_run(root: Path, trial_id: str, env: str, task: str, seed: int, rms: float) -> dict:
    """A Track/Pose/Obstacle run directory: eval.json holds the task summaries per policy."""
    run = root / "runs" / trial_id
    run.mkdir(parents=True)
    (run / "run.json").write_text(
        json.dumps({"status": "complete", "total_steps": 30_000, "total_wall_time_s": 40.0})
    )

    def summary(scale: float) -> dict:
        out = {
            "task": task,
            "success_rate": 0.5 * scale,
            "final_distance_mm": {"median": 3.0 * scale},
        }
        if task == "Track":
            out["tracking_rms_mm"] = {"median": rms * scale}
        if task == "Obstacle":
            out["collision_rate"] = 0.25 * scale
        return out

    conditions = {"straight_h100": {"policy": summary(1.0), "oracle": summary(0.1)}}
    (run / "eval.json").write_text(json.dumps({"task": task, "conditions": conditions}))
    return {
        "trial_id": trial_id,
        "env_id": f"cdcr_gym/{env}",
        "algo": "sac",
        "variant": {},
        "seed": seed,
        "status": "complete",
        "run_dir": str(run),
    }


def test_task_metrics_are_aggregated_per_task(tmp_path: Path) -> None:
    root = tmp_path / "sweep"
    records = [
        _fake_task_run(root, f"t_seed{i}", "CCKATrack-v0", "Track", i, rms)
        for i, rms in enumerate([2.0, 4.0, 9.0, 1.0])
    ] + [_fake_task_run(root, "o_seed0", "CCKAObstacle-v0", "Obstacle", 0, 0.0)]
    summary = {"name": "t", "command": "python -m training.sweep s.yaml", "trials": records,
               "spec": {"target": {}, "set": {}}}  # fmt: skip
    (root / "sweep.json").write_text(json.dumps(summary))
    _, runs = load_runs(root)
    track = [r for r in runs if r.task == "CCKATrack-v0"]
    assert {r.kind for r in track} == {"Track"}
    assert track[0].scores["straight_100steps"] == {
        "median_error_mm": 3.0,
        "success_rate": 0.5,
        "tracking_rms_mm": 2.0,
    }
    assert track[0].baselines["straight_100steps"]["oracle"]["tracking_rms_mm"] == pytest.approx(
        0.2
    )
    result = aggregate(runs, reps=500)
    (g,) = [g for g in result["groups"] if g["task"] == "CCKATrack-v0"]
    # four runs: the IQM cuts int(0.25 * 4) = 1 per end of [1, 2, 4, 9]: mean of 2 and 4
    assert g["tracking_rms_mm"]["iqm"] == pytest.approx(3.0)
    assert "within_1mm" not in g and "collision_rate" not in g
    (o,) = [g for g in result["groups"] if g["task"] == "CCKAObstacle-v0"]
    assert o["collision_rate"]["iqm"] == pytest.approx(0.25)
    (across,) = result["aggregate"]
    assert across["runs"] == 5 and "within_1mm" not in across
    assert across["success_rate"]["iqm"] == pytest.approx(0.5)
    table = "\n".join(iqm_table(result))
    assert "median tracking RMS" in table and "collision rate" in table
    assert "*oracle*" in table and "0.2 mm" in table  # the Track oracle's RMS: 0.1 x 2 mm
    page = tmp_path / "bench.md"
    assert main([str(root), "--doc", str(page), "--reps", "200", "--note", "Budget: why."]) == 0
    text = page.read_text()
    assert "no collision during the episode" in text
    assert text.index("Budget: why.") < text.index("## Protocol")


def test_the_page_says_the_machine_was_shared_only_when_the_load_exceeds_the_trials() -> None:
    """The protocol's machine sentence follows the recorded load: at most the concurrent trials
    (+ 0.5) is the sweep's own load; above it, other jobs shared the machine."""
    from training.sweep.aggregate import RunResult, machine_sharing

    def runs(*loads: float) -> list[RunResult]:
        return [RunResult("t", "CCKAReach-v0", "ppo", 0, "complete", loadavg=list(loads))]

    summary = {"trials": [{"cpu_count": 2}]}
    assert "own 2 concurrent trials" in machine_sharing(summary, runs(1.9, 2.3), 2)
    assert "shared with other jobs" in machine_sharing(summary, runs(3.7, 3.9), 2)
    assert "own 1 concurrent trial;" in machine_sharing(summary, runs(1.2, 1.4), 1)
    assert "shared with other jobs" in machine_sharing(summary, runs(2.0, 2.1), 1)
    # no max_concurrent: as many trials as cores
    assert "own 2 concurrent trials" in machine_sharing(summary, runs(2.2, 2.4), None)
    assert "unknown" in machine_sharing(summary, runs(), 2)  # load not recorded


PINNED_GROUPS = [
    ("BulletReach-v0", "random", "median_error_mm", 2.0, 2.0, 2.0),
    ("BulletReach-v0", "random", "success_rate", 1.0, 1.0, 1.0),
    ("BulletReach-v0", "straight", "median_error_mm", 1.0, 1.0, 1.0),
    ("BulletReach-v0", "straight", "success_rate", 1.0, 1.0, 1.0),
    ("CCKAReach-v0", "random", "median_error_mm", 7.666666667, 2.108333333, 14.0),
    ("CCKAReach-v0", "random", "success_rate", 0.333333333, 0.0, 0.841666667),
    ("CCKAReach-v0", "straight", "median_error_mm", 3.833333333, 1.054166667, 7.0),
    ("CCKAReach-v0", "straight", "success_rate", 0.666666667, 0.0, 1.0),
]


def test_pinned_aggregate_numbers(sweep_dir: Path) -> None:
    """IQMs and bootstrap CIs of the fake sweep on a fixed seed, pinned (any restructuring of the
    aggregation must leave them unchanged)."""
    _, runs = load_runs(sweep_dir)
    result = aggregate(runs, reps=500, seed=0)
    rows = sorted(
        (
            g["task"],
            g["condition"][: g["condition"].index("_")],
            m,
            *map(lambda v: round(v, 9), (g[m]["iqm"], *g[m]["ci"])),
        )
        for g in result["groups"]
        for m in ("median_error_mm", "success_rate")
        if g.get(m)
    )
    assert rows == PINNED_GROUPS


def test_a_sweep_in_parts_gets_a_parts_table_and_its_baseline_rows(tmp_path: Path) -> None:
    """Parts: budgets per part, trials not run yet are neither scores nor failures; Reach's
    baselines (the oracle, the analytic IK, open and closed loop, and the random policy; in an
    eval.json of before the one report shape) become reference rows."""
    root = tmp_path / "sweep"
    records = []
    for seed, err in enumerate([0.5, 0.7, 0.9, 1.1, 30.0]):
        record = _fake_run(root, f"a_seed{seed}", "MuJoCoReach-v0", seed, [9.0, err])
        record.update(part="mujoco_reach", start=f"2026-11-26T11:0{seed}:00+00:00",
                      end=f"2026-11-26T11:1{seed}:00+00:00", wall_time_s=600.0)  # fmt: skip
        eval_path = Path(record["run_dir"]) / "eval.json"
        data = json.loads(eval_path.read_text())
        for cond in data["conditions"].values():
            for key, median in (("ik", 40.0), ("ik_closed_loop", 0.2), ("random", 150.0)):
                cond[key] = {"success_rate": float(median < 5), "within_1mm": float(median < 1),
                             "error_mm": {"median": median}}  # fmt: skip
        eval_path.write_text(json.dumps(data))
        records.append(record)
    records.append({"trial_id": "p_seed0", "env_id": "cdcr_gym/CCKAPose-v0", "algo": "ppo",
                    "seed": 0, "part": "ccka_pose", "status": "not run"})  # fmt: skip
    summary = {
        "name": "bench",
        "command": "cdcr-gym sweep configs/sweeps/bench.yaml --part mujoco_reach",
        "time": "2026-11-26T12:00:00",
        "spec": {
            "target": {"success_rate": 0.9},
            "set": {"eval.freq": 25000},
            "parts": {
                "mujoco_reach": {"configs": ["x"], "set": {"runtime.max_wall_time_s": 120}},
                "ccka_pose": {"configs": ["y"], "set": {"runtime.max_wall_time_s": 180}},
            },
        },
        "trials": records,
    }
    (root / "sweep.json").write_text(json.dumps(summary))
    page = tmp_path / "docs" / "bench.md"
    assert main([str(root), "--doc", str(page), "--reps", "500"]) == 0
    text = page.read_text()
    lines = text.splitlines()
    reach = next(line for line in lines if line.startswith("| mujoco_reach |"))
    assert "| MuJoCoReach-v0 | 120 s | 5/5 | 2026-11-26 11:00 – 2026-11-26 11:14 |" in reach
    assert "| 0.83 h |" in reach  # 5 trials x 600 s
    pose = next(line for line in lines if line.startswith("| ccka_pose |"))
    assert "| 180 s | 0/1 | not run yet |" in pose
    assert "## Failed trials" not in text and "p_seed0" not in text.split("## Parts")[0]
    # five runs: the IQM cuts one at each end (30 mm is the worst, 0.5 the best)
    assert "With 5 runs per group the IQM drops the best and the worst runs" in text
    assert "0.9 [" in text  # IQM of 0.7, 0.9, 1.1
    for label, value in (
        ("*oracle*", "40 mm"),  # Reach's oracle, the analytic IK, named like every task's
        ("*oracle, closed loop*", "0.2 mm"),
        ("*random policy*", "150 mm"),
    ):
        row = next(line for line in lines if line.startswith(f"| {label} | straight"))
        assert value in row


def test_reference_rows_mark_the_performance_profiles(tmp_path: Path) -> None:
    from training.sweep.figures import reference_errors

    root = tmp_path / "sweep"
    record = _fake_run(root, "a_seed0", "MuJoCoReach-v0", 0, [9.0, 1.0])
    eval_path = Path(record["run_dir"]) / "eval.json"
    data = json.loads(eval_path.read_text())
    for cond, scale in zip(data["conditions"].values(), (1.0, 2.0), strict=True):
        cond["ik_closed_loop"] = {"success_rate": 1.0, "within_1mm": 1.0,
                                  "error_mm": {"median": 0.2 * scale}}  # fmt: skip
        cond["random"] = {"success_rate": 0.0, "within_1mm": 0.0,
                          "error_mm": {"median": 150.0 * scale}}  # fmt: skip
    eval_path.write_text(json.dumps(data))
    summary = {"name": "t", "command": "", "spec": {}, "trials": [record]}
    (root / "sweep.json").write_text(json.dumps(summary))
    _, runs = load_runs(root)
    # the straight start's (the first condition's) values, one line per reference row
    assert reference_errors(runs) == {
        "MuJoCoReach-v0": {"oracle, closed loop": 0.2, "random policy": 150.0}
    }


def test_a_page_below_the_docs_links_the_docs_figures_relative_to_its_folder(
    sweep_dir: Path, tmp_path: Path
) -> None:
    """``--doc docs/experiments/benchmark.md`` writes its figures into ``docs/figures/benchmark/``
    (the docs' figures folder) and links them as ``../figures/benchmark/...``; a page whose
    folder has a figures folder uses it (``figures/top``)."""
    from training.sweep.aggregate import figures_dir

    docs = tmp_path / "docs"
    (docs / "figures").mkdir(parents=True)
    page = docs / "experiments" / "benchmark.md"
    page.parent.mkdir()
    assert figures_dir(page) == (docs.resolve() / "figures" / "benchmark", "../figures/benchmark")
    assert figures_dir(docs / "top.md")[1] == "figures/top"
    assert main([str(sweep_dir), "--doc", str(page), "--reps", "200"]) == 0
    text = page.read_text()
    links = re.findall(r"\]\(([^)\s]+)\)", text)
    assert "../figures/benchmark/iqm.png" in links
    for link in links:
        if not re.match(r"[a-z]+:", link) and not link.startswith("#"):
            assert (page.parent / link).resolve().is_file(), link
    assert not (page.parent / "figures").exists()
