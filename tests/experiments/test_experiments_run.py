"""The experiments run from a checkout as ``python -m experiments.<name>``, are not ``cdcr-gym``
commands, and nothing in the product imports them."""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import experiments
import training
from training.cli import COMMANDS, main

ROOT = Path(experiments.__file__).resolve().parent
EXPERIMENTS = sorted(
    m.name for m in pkgutil.iter_modules([str(ROOT)]) if not m.name.startswith("_")
)  # _x: shared helpers


def test_the_experiments_are_the_one_off_studies():
    assert {
        "friction_chatter",
        "transfer_probe",
        "bench_compare",
        "bench_realism",
        "hysteresis",
        "step_response",
        "sim2sim",
        "verification",
        "oracle_feedback",
        "cosserat",
    } <= set(EXPERIMENTS)


def test_no_experiment_is_a_command_and_the_help_does_not_list_them(capsys):
    assert not any(module.startswith("experiments") for module, _, _ in COMMANDS.values())
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for name in ("friction-chatter", "transfer-probe", "verification", "cosserat-reference"):
        assert name not in out
    assert all(c in out for c in ("train", "evaluate", "sweep", "calibrate", "reproduce", "bench"))


def test_nothing_in_training_imports_the_experiments():
    offenders = []
    for path in Path(training.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            offenders += [f"{path}: {n}" for n in names if n.split(".")[0] == "experiments"]
    assert not offenders, offenders


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n != "step_response" else n for n in EXPERIMENTS],
)
def test_every_experiment_runs_from_the_checkout(name):
    result = subprocess.run(
        [sys.executable, "-m", f"experiments.{name}", "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT.parent,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "usage:" in result.stdout and f"experiments.{name}" in result.stdout
