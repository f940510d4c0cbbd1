"""training.evaluate.results --out: collects the evaluations of several runs, any task, into one
JSON (fake runs, no training)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from training.evaluate import results


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
    code = results.main([*map(str, runs), "--out", str(out), "--figures", str(figs)])
    assert code == 0
    data = json.loads(out.read_text())
    assert [r["seed"] for r in data["runs"]] == [0, 2]
    assert (
        data["runs"][0]["conditions"]["straight_100steps"]["policy"]["tracking_rms_mm"]["mean"]
        == 0.5
    )
    assert data["runs"][1]["train_wall_time_s"] == 12.5
    assert data["command"].startswith("cdcr-gym results ")
    # an evaluation written before the renaming (straight_h100) reads as straight_100steps
    assert (figs / "ppo_track_seed0_straight_100steps_paths.png").read_bytes() == b"png"
    assert (figs / "ppo_obstacle_seed2_straight_100steps_paths.png").exists()
    table = capsys.readouterr().out
    assert "Track:" in table and "Obstacle:" in table  # one table per task
    assert "| a straight_100steps | policy | 75.0% | – | 0.500 | 0.500 | 0.500 |" in table  # RMS
    assert "| b straight_100steps | policy | 75.0% | – | 3.000 | 3.000 | 25.0% |" in table
    rows = [line for line in table.splitlines() if line.startswith("| ")]
    assert len(rows) == 2 * 3  # per table the header + one row per policy


def test_a_run_without_an_evaluation_is_an_error(tmp_path, capsys):
    run = _fake_run(tmp_path, "a", "Track", 0, 0.5)
    (run / "eval.json").unlink()
    assert results.main([str(run), "--out", str(tmp_path / "r.json")]) == 2
    assert "eval.json" in capsys.readouterr().err
    assert not (tmp_path / "r.json").exists()
    (run / "run.json").unlink()
    with pytest.raises(results.ResultsError, match="run.json"):
        results.collect([run])


def test_condition_names_read_for_what_they_are_and_old_keys_still_read(tmp_path: Path) -> None:
    """Issue 23.11: ``straight_h100`` read like a GPU; the conditions are now
    ``straight_100steps``, and evaluations of before (docs/figures/**) read under the new names."""
    from training.evaluate.conditions import canonical_condition, condition_name, read_eval

    assert condition_name("straight", 100) == "straight_100steps"
    assert canonical_condition("random_h200") == "random_200steps"
    assert canonical_condition("random_200steps") == "random_200steps"
    old = tmp_path / "eval.json"
    old.write_text(
        json.dumps({"headline_condition": "straight_h100", "conditions": {"straight_h100": {}}})
    )
    data = read_eval(old)
    assert data["headline_condition"] == "straight_100steps"
    assert list(data["conditions"]) == ["straight_100steps"]
    # every condition name in the results committed under docs/figures maps to a current one
    import re

    def names(node: object) -> list[str]:
        if isinstance(node, dict):
            found = list(node["conditions"]) if isinstance(node.get("conditions"), dict) else []
            return found + [n for v in node.values() for n in names(v)]
        if isinstance(node, list):
            return [n for v in node for n in names(v)]
        return []

    docs = Path(__file__).resolve().parents[3] / "docs" / "figures"
    seen = [n for path in docs.rglob("*.json") for n in names(json.loads(path.read_text()))]
    assert seen and all(re.fullmatch(r"[a-z]+_\d+steps", canonical_condition(n)) for n in seen)


def test_tag_collects_the_tagged_evaluation_with_its_env_kwargs(tmp_path, capsys):
    run = _fake_run(tmp_path, "a", "Obstacle", 1, 2.0)
    ev = json.loads((run / "eval.json").read_text())
    condition = ev["conditions"]["straight_h100"]
    for who in ("policy", "oracle"):
        condition[who] = {**condition[who], "collision_rate": 0.0, "filtered_step_fraction": 0.04}
    condition["reach_ik"] = {**condition["policy"], "success_rate": 0.5}
    ev["env_kwargs"] = {"safety_filter": True}
    (run / "eval_safe.json").write_text(json.dumps(ev))
    (run / "eval_safe").mkdir()
    (run / "eval_safe" / "straight_100steps_paths.png").write_bytes(b"safe")
    out, figs = tmp_path / "r.json", tmp_path / "figs"
    argv = [str(run), "--out", str(out), "--tag", "safe", "--figures", str(figs)]
    assert results.main(argv) == 0
    record = json.loads(out.read_text())["runs"][0]
    assert record["eval_tag"] == "safe" and record["env_kwargs"] == {"safety_filter": True}
    policy = record["conditions"]["straight_100steps"]["policy"]
    assert policy["filtered_step_fraction"] == 0.04
    assert (figs / "ppo_obstacle_seed1_straight_100steps_safe_paths.png").read_bytes() == b"safe"
    table = capsys.readouterr().out
    assert "| a straight_100steps | reach_ik | 50.0% |" in table
    assert results.main([str(run), "--tag", "safe", "--wide"]) == 0
    assert "4.0%" in capsys.readouterr().out  # the safety filter's share of the steps
    # an untagged collection of the same run reads eval.json (no filter numbers)
    assert "eval_tag" not in results.collect([run])[0]
    with pytest.raises(results.ResultsError, match="eval_other.json"):
        results.collect([run], "other")
