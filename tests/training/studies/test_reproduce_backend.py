"""``cdcr-gym reproduce --backend``: the paper's study on MuJoCo (default) or pybullet."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from training.studies import reproduce as R


def test_backend_option_defaults_to_mujoco_and_sets_the_links_per_span():
    args = R.build_parser().parse_args([])
    assert args.backend == "mujoco"
    assert R.config_from_args(args).links_per_span == 1
    args = R.build_parser().parse_args(["--backend", "bullet"])
    assert R.config_from_args(args).links_per_span == 4
    args = R.build_parser().parse_args(["--backend", "bullet", "--links-per-span", "2"])
    assert R.config_from_args(args).links_per_span == 2
    with pytest.raises(SystemExit):
        R.build_parser().parse_args(["--backend", "ccka"])


@pytest.mark.slow  # ~15-30 s: the quick grid on MuJoCo
def test_quick_study_on_mujoco(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    out = tmp_path / "out"
    assert R.main(["--quick", "--out", str(out), "--no-horizontal"]) == 0
    assert json.loads((out / "run.json").read_text())["backend"] == "mujoco_factory"
    with open(out / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ours = [r for r in rows if r["source"] == "this study (MuJoCo)"]
    assert ours, rows
    off = ours[0]
    # Under cable loads alone the MuJoCo backbone is close to an arc: CCKA within 1.5 mm.
    assert float(off["max_mm"]) < 1.5
    report = (out / "report.md").read_text()
    assert "with the MuJoCo backbone" in report
    assert "pybullet" not in report.split("## Method")[1].split("## Results")[0]
