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


def test_study_on_a_fitted_robot_in_displacement_mode(tmp_path):
    """The FTDCR v4 twin (--params), displacement_delta, both starts: one row per start and
    oracle, the drive settings recorded, files named by --tag."""
    argv = [
        "--backend", "CCKA", "--task", "reach", "--episodes", "1",
        "--params", "docs/figures/calibration/ftdcr_v4_ccka/params.yaml",
        "--action-mode", "displacement_delta", "--initial-state", "straight", "random",
        "--displacement-step", "0.001", "--tag", "twin", "--out", str(tmp_path),
    ]  # fmt: skip
    assert oracle_feedback.main(argv) == 0
    rows = json.loads((tmp_path / "oracle_feedback_CCKA_twin.json").read_text())["results"]
    assert [(r["initial_state"], r["mode"]) for r in rows] == [
        ("straight", "open_loop"),
        ("straight", "closed_loop"),
        ("random", "open_loop"),
        ("random", "closed_loop"),
    ]
    assert all(r["action_mode"] == "displacement_delta" for r in rows)
    assert all(r["env_kwargs"]["displacement_step"] == 0.001 for r in rows)
    assert all(r["robot"] == "ftdcr_v4_ccka" for r in rows)
    # model = plant: both oracles end on the goal
    assert all(r["final_distance_mm"]["max"] < 0.1 for r in rows)
    assert (
        "displacement_delta, random"
        in (tmp_path / "oracle_feedback_CCKA_twin_table.txt").read_text()
    )
