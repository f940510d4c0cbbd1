"""experiments.bench_single: the speed benchmark's JSON record (a short smoke run)."""

from __future__ import annotations

import json

from experiments import bench_single


def test_output_records_the_result_and_its_command(tmp_path, capsys):
    path = tmp_path / "speed.json"
    argv = ["--rounds", "1", "--steps", "50", "--output", str(path)]
    assert bench_single.main(argv) == 0
    record = json.loads(path.read_text(encoding="utf-8"))
    assert record["command"] == "python -m experiments.bench_single " + " ".join(argv)
    assert record["rounds"] == 1 and record["steps"] == 50
    result = record["result"]
    assert result["single"] > 0 and result["pendulum"] > 0
    assert abs(result["ratio"] - result["single"] / result["pendulum"]) < 1e-9
    assert "ratio" in capsys.readouterr().out
