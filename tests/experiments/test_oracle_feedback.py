"""The open- vs closed-loop oracle study (``python -m experiments.oracle_feedback``) runs end to end."""

from __future__ import annotations

import json

from experiments import oracle_feedback


def test_study_writes_json_and_table(tmp_path):
    argv = ["--backend", "Bullet", "--task", "reach", "--episodes", "1", "--out", str(tmp_path)]
    assert oracle_feedback.main(argv) == 0
    payload = json.loads((tmp_path / "oracle_feedback_Bullet.json").read_text())
    rows = payload["results"]
    assert [r["mode"] for r in rows] == ["open_loop", "closed_loop"]
    assert all(r["env_kwargs"] == {"gravity": True} for r in rows)
    open_loop, closed_loop = rows
    assert closed_loop["within_5mm"] == 1.0
    assert closed_loop["final_distance_mm"]["max"] < open_loop["final_distance_mm"]["max"]
    table = (tmp_path / "oracle_feedback_Bullet_table.txt").read_text()
    assert payload["command"] in table and "| closed loop |" in table


def test_study_rejects_an_unknown_backend(tmp_path, capsys):
    argv = ["--backend", "Nope", "--task", "reach", "--episodes", "1", "--out", str(tmp_path)]
    assert oracle_feedback.main(argv) == 2
    assert "NopeReach" in capsys.readouterr().err
