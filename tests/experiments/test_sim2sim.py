"""experiments.sim2sim: the summary of evaluate JSONs, its target check, table and CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from experiments import sim2sim


def _eval_json(path: Path, run: str, median: float, success: float) -> Path:
    def cond(m: float, s: float) -> dict:
        return {
            "success_rate": s,
            "within_1mm": s / 4,
            "error_mm": {"mean": m, "median": m, "p95": 2 * m, "max": 3 * m},
            "ik": {"success_rate": 0.01, "error_mm": {"median": 40.0, "p95": 80.0}},
        }

    data = {
        "run_dir": f"runs/{run}",
        "env_id": "cdcr_gym/BulletReach-v0",
        "env_kwargs": {"gravity": True},
        "episodes": 10,
        "model_step": 100,
        "command": "python -m training.evaluate ...",
        "headline_condition": "straight_h100",
        "conditions": {
            "straight_h100": cond(median, success),
            "random_h100": cond(2 * median, success / 2),
        },
    }
    path.write_text(json.dumps(data))
    return path


def test_target_is_checked_on_the_headline_condition_of_every_run(tmp_path):
    good = _eval_json(tmp_path / "a.json", "a", median=2.9, success=0.95)
    slow = _eval_json(tmp_path / "b.json", "b", median=3.1, success=0.95)
    few = _eval_json(tmp_path / "c.json", "c", median=1.0, success=0.85)
    summary = sim2sim.summarize_evals([good])
    assert summary["all_meet_target"] and summary["runs"][0]["meets_target"]
    assert summary["runs"][0]["conditions"]["random_100steps"]["median_mm"] == pytest.approx(5.8)
    summary = sim2sim.summarize_evals([good, slow, few])
    assert [r["meets_target"] for r in summary["runs"]] == [True, False, False]
    assert not summary["all_meet_target"]
    # a looser target changes the verdict
    loose = sim2sim.summarize_evals([slow, few], target_median_mm=3.2, target_success=0.8)
    assert loose["all_meet_target"]
    rows = sim2sim.table_rows(summary)
    assert len(rows) == 6
    assert rows[0].startswith("| a | straight_100steps * | 95.0 % |") and "| 2.90 |" in rows[0]
    assert rows[1].startswith("| a | random_100steps | 47.5 % |")


def test_cli_writes_json_and_figure_and_rejects_bad_input(tmp_path, capsys):
    good = _eval_json(tmp_path / "a.json", "a", median=2.0, success=1.0)
    out = tmp_path / "fig" / "s2s"
    assert sim2sim.main([str(good), "--out", str(out), "--title", "t"]) == 0
    data = json.loads(out.with_suffix(".json").read_text())
    assert data["runs"][0]["run_dir"] == "runs/a" and data["all_meet_target"]
    assert out.with_suffix(".png").stat().st_size > 1000
    assert "| a | straight_100steps * |" in capsys.readouterr().out
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"run_dir": "x"}))
    assert sim2sim.main([str(bad), "--out", str(out)]) == 2
    assert "has no 'env_id'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="target_median_mm"):
        sim2sim.summarize_evals([good], target_median_mm=0.0)
    with pytest.raises(ValueError, match="target_success"):
        sim2sim.summarize_evals([good], target_success=1.5)
    with pytest.raises(ValueError, match="paths"):
        sim2sim.summarize_evals([])


def test_transfer_probe_cotension_and_step_response():
    """CCKA ignores equal tension on all cables; bullet with gravity bends more with it."""
    from experiments import transfer_probe

    rows = transfer_probe.cotension_table(base_tensions=(0.0, 40.0), deltas=(10,))
    (_, _, ccka0, bullet0), (_, _, ccka40, bullet40) = rows
    assert ccka0 == pytest.approx(ccka40, rel=1e-9)
    assert bullet40 > bullet0 > ccka0
    remaining, model, final_mm = transfer_probe.step_response(steps=30)
    assert final_mm > 1.0
    assert remaining[0] > 0.8 and abs(remaining[-1]) < 0.05  # starts slow, settles
    assert model[0] == pytest.approx(1.44 * np.exp(-0.44))
