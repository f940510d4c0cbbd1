"""The evaluation tables fit 100 characters by default, ``--wide`` shows every column, and a
legend explains each shown column (read from the committed result JSONs)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from training.evaluate import agent, results, tables
from training.evaluate.conditions import canonical_eval as read_eval_data
from training.evaluate.conditions import read_eval

REPO = Path(__file__).resolve().parents[3]
REACH_EVAL = REPO / "docs/figures/training/ppo_mujoco_reach_seed0_eval.json"
TASK_RESULTS = REPO / "docs/figures/tasks/ppo_results.json"


def _widest(text: str) -> int:
    return max(len(line) for line in text.splitlines())


def _headers_explained(text: str, columns: list[tables.Column], wide: bool) -> None:
    text = " ".join(text.split())  # the legend is wrapped: a header may span two lines
    legend = text[text.index(tables.shown(columns, wide)[0].header + ":") :]
    for column in tables.shown(columns, wide):
        assert f"{column.header}: " in legend, column.header


def test_the_evaluate_table_fits_100_characters_and_wide_shows_every_column(capsys):
    result = read_eval(REACH_EVAL)  # written before the one report shape: read into it
    result["_json_path"] = "runs/ppo_mujoco_reach_seed0/eval.json"
    agent.print_table(result)
    narrow = capsys.readouterr().out
    agent.print_table(result, wide=True)
    wide = capsys.readouterr().out
    assert _widest(narrow) <= tables.WIDTH < _widest(wide)
    columns = tables.task_columns(result["task"])
    assert "ΔT oracle" in wide and "ΔT oracle" not in narrow.splitlines()[2]
    assert "--wide shows" in narrow and "--wide shows" not in wide
    assert "oracle_closed_loop" in narrow  # MuJoCo: the IK also closed loop
    _headers_explained(narrow, columns, False)
    _headers_explained(wide, columns, True)


def test_the_task_table_fits_100_characters(capsys):
    for run in json.loads(TASK_RESULTS.read_text())["runs"]:
        result = read_eval_data({**run, "model_step": run["model_step"], "run_dir": run["run"]})
        agent.print_table(result)
        out = capsys.readouterr().out
        assert _widest(out) <= tables.WIDTH, out
        assert run["task"] in out and "success" in out


def test_results_reads_a_committed_evaluation_and_fits_100_characters(tmp_path, capsys):
    run = tmp_path / "ppo_mujoco_reach_seed0"
    run.mkdir()
    shutil.copy(REACH_EVAL, run / "eval.json")
    (run / "run.json").write_text(json.dumps({"total_wall_time_s": 600.0, "total_steps": 819200}))
    assert results.main([str(run)]) == 0
    narrow = capsys.readouterr().out
    assert results.main([str(run), "--wide"]) == 0
    wide = capsys.readouterr().out
    assert _widest(narrow) <= tables.WIDTH < _widest(wide)
    # one row per condition and policy (policy, oracle, oracle_closed_loop)
    assert narrow.count("| ppo_mujoco_reach_seed0 ") == 4 * 3
    assert "10.0 min" in wide and "819,200" in wide and "10.0 min" not in narrow
    _headers_explained(narrow, results.columns("Reach"), False)
    # the numbers are the file's: the headline policy's median final error
    median = json.loads(REACH_EVAL.read_text())["error_mm"]["median"]
    assert f"{median:.3f}" in narrow


def test_a_legend_is_wrapped_and_names_the_hidden_columns():
    cols = [
        tables.Column("a", " ".join(["first"] * 30), str),
        tables.Column("b", "second", str, narrow=False),
    ]
    text = tables.legend(cols)
    assert _widest(text) <= tables.WIDTH and "--wide shows 1 more column." in " ".join(text.split())
    assert "b: second" in tables.legend(cols, wide=True)


def test_results_reads_task_evaluations_too(tmp_path, capsys):
    run = json.loads(TASK_RESULTS.read_text())["runs"][0]
    run_dir = tmp_path / "ppo_task"
    run_dir.mkdir()
    evaluation = {"task": run["task"], "env_id": run["env_id"], "conditions": run["conditions"]}
    (run_dir / "eval.json").write_text(json.dumps(evaluation))
    (run_dir / "run.json").write_text("{}")
    assert results.main([str(run_dir)]) == 0
    out = capsys.readouterr().out
    assert _widest(out) <= tables.WIDTH, out
    n_rows = sum(len(block) for block in run["conditions"].values())
    assert out.count("| ppo_task ") == n_rows and "| oracle |" in out
    assert out.startswith(f"{run['task']}:")
