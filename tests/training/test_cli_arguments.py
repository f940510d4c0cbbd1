"""Every command line (each ``cdcr-gym`` subcommand, each ``python -m experiments.<name>``) rejects
a bogus flag and bad values (negative counts, zero steps, NaN, unknown choices) with a usage error:
exit status 2, a message naming the flag, no traceback, nothing written."""

from __future__ import annotations

import argparse
import importlib
import math
from pathlib import Path

import pytest

from training.cli import COMMANDS
from training.cli import main as cdcr_gym
from training.run import argtypes

EXPERIMENTS = {
    "bench_compare": "experiments.bench_compare",
    "bench_realism": "experiments.bench_realism",
    "bench_single": "experiments.bench_single",
    "friction_chatter": "experiments.friction_chatter",
    "hysteresis": "experiments.hysteresis",
    "oracle_feedback": "experiments.oracle_feedback",
    "sim2sim": "experiments.sim2sim",
    "step_response": "experiments.step_response",
    "transfer_probe": "experiments.transfer_probe",
    "verification": "experiments.verification",
    "cosserat": "experiments.cosserat.reference",
}

#: positional arguments each command needs before its options are looked at
POSITIONAL = {
    "train": ["ppo_ccka_reach"],
    "evaluate": ["RUN"],
    "sweep": ["sweeps/benchmark"],
    "aggregate": ["OUT"],
    "results": ["RUN"],
    "from-zoo": ["ZOO", "RUN"],
    "oracles": ["--task", "reach"],
    "sim2sim": ["eval.json", "--out", "OUT"],
}

#: (command, arguments, the flag the message must name)
BAD_VALUES = [
    ("train", ["--total-timesteps", "0"], "--total-timesteps"),
    ("train", ["--total-timesteps", "nan"], "--total-timesteps"),
    ("train", ["--seed", "-1"], "--seed"),
    ("evaluate", ["--episodes", "0"], "--episodes"),
    ("evaluate", ["--seed", "-1"], "--seed"),
    ("evaluate", ["--model", "worst"], "--model"),
    ("sweep", ["--executor", "nope"], "--executor"),
    ("aggregate", ["--reps", "0"], "--reps"),
    ("aggregate", ["--seed", "-1"], "--seed"),
    ("reproduce", ["--forces", "1"], "--forces"),
    ("reproduce", ["--max-force", "nan"], "--max-force"),
    ("reproduce", ["--dpi", "0"], "--dpi"),
    ("bench", ["--repeats", "0"], "--repeats"),
    ("demo", ["--episodes", "0"], "--episodes"),
    ("demo", ["--action-mode", "nope"], "--action-mode"),
    ("oracles", ["--backend", "nope"], "--backend"),
    ("oracles", ["--episodes", "-1"], "--episodes"),
    ("oracles", ["--figures", "-1"], "--figures"),
    ("bench-physics", ["--steps", "-1"], "--steps"),
    ("bench-physics", ["--steps", "0"], "--steps"),
    ("bench-physics", ["--repeats", "0"], "--repeats"),
    ("bench-physics", ["--robot", "nope"], "--robot"),
    ("calibrate", ["--stiffness-scale", "-1"], "--stiffness-scale"),
    ("calibrate", ["--ramp-steps", "0"], "--ramp-steps"),
    ("calibrate", ["--max-evals", "0"], "--max-evals"),
    ("bench_compare", ["--rounds", "0"], "--rounds"),
    ("bench_realism", ["--num-envs", "0"], "--num-envs"),
    ("bench_realism", ["--steps", "-1"], "--steps"),
    ("bench_single", ["--steps", "0"], "--steps"),
    ("bench_single", ["--batched", "-2"], "--batched"),
    ("friction_chatter", ["--mu", "-1"], "--mu"),
    ("friction_chatter", ["--mu", "nan"], "--mu"),
    ("friction_chatter", ["--damping-ratio", "0"], "--damping-ratio"),
    ("friction_chatter", ["--damping-ratio", "inf"], "--damping-ratio"),
    ("friction_chatter", ["--hold", "-1"], "--hold"),
    ("friction_chatter", ["--backend", "nope"], "--backend"),
    ("hysteresis", ["--ramp-steps", "-3"], "--ramp-steps"),
    ("hysteresis", ["--settle-steps", "-1"], "--settle-steps"),
    ("oracle_feedback", ["--episodes", "0"], "--episodes"),
    ("oracle_feedback", ["--task", "nope"], "--task"),
    ("oracle_feedback", ["--gain", "nan"], "--gain"),
    ("sim2sim", ["--target-success", "1.5"], "--target-success"),
    ("sim2sim", ["--target-median-mm", "-1"], "--target-median-mm"),
    ("step_response", ["--tension", "-5"], "--tension"),
    ("step_response", ["--tension", "nan"], "--tension"),
    ("step_response", ["--omega", "0"], "--omega"),
    ("step_response", ["--steps", "0"], "--steps"),
    ("transfer_probe", ["--trace", "no/such/run"], "--trace"),
    ("transfer_probe", ["--friction", "-1"], "--friction"),
    ("verification", ["--bench-only", "--robot", "nope"], "--robot"),
    ("verification", ["--steps", "0"], "--steps"),
    ("cosserat", ["--refine", "bogus"], "--refine"),
    ("cosserat", ["--refine", "straight:1:0"], "--refine"),
    ("cosserat", ["--write", "x.json", "--robot", "nope"], "--robot"),
]


def _call(command: str, args: list[str]) -> int:
    """Run ``command`` in this process; its exit status (argparse's SystemExit included)."""
    try:
        if command in EXPERIMENTS:
            status = importlib.import_module(EXPERIMENTS[command]).main(args)
        else:
            status = cdcr_gym([command, *args])
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 1
    return int(status or 0)


def _args(command: str, extra: list[str], tmp_path: Path) -> list[str]:
    pos = [
        str(tmp_path / a) if a.isupper() or a.endswith(".json") else a
        for a in POSITIONAL.get(command, [])
    ]
    if command == "sim2sim":
        return [pos[0], *extra, pos[1], pos[2]]
    return [*pos, *extra]


ALL = [*COMMANDS, "configs", *EXPERIMENTS]


@pytest.mark.parametrize("command", ALL)
def test_a_bogus_flag_is_a_usage_error(
    command: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    status = _call(command, _args(command, ["--no-such-flag"], tmp_path))
    err = capsys.readouterr().err
    assert status == 2, err
    assert "--no-such-flag" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize(
    "command, args, flag", BAD_VALUES, ids=[f"{c}{' '.join(a)}" for c, a, _ in BAD_VALUES]
)
def test_a_bad_value_is_a_usage_error_naming_the_flag(
    command: str,
    args: list[str],
    flag: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    status = _call(command, _args(command, args, tmp_path))
    err = capsys.readouterr().err
    assert status == 2, err
    assert flag in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_every_command_is_covered_by_a_bad_value() -> None:
    """Each command with a numeric or choice option has at least one bad-value case above."""
    covered = {c for c, _, _ in BAD_VALUES}
    exempt = {"results", "from-zoo", "configs"}  # no numeric or choice options
    assert set(ALL) - exempt <= covered


def test_cosserat_without_arguments_says_what_to_do(capsys: pytest.CaptureFixture[str]) -> None:
    assert _call("cosserat", []) == 0
    out = capsys.readouterr().out
    assert "usage:" in out and "--write" in out and "--study" in out


@pytest.mark.parametrize(
    "helper, good, bad",
    [
        (argtypes.positive_int, {"1": 1, "40": 40}, ["0", "-1", "1.5", "x", ""]),
        (argtypes.non_negative_int, {"0": 0, "3": 3}, ["-1", "nan"]),
        (argtypes.positive_float, {"0.5": 0.5, "1e3": 1000.0}, ["0", "-1", "nan", "inf", "x"]),
        (argtypes.non_negative_float, {"0": 0.0, "2": 2.0}, ["-0.1", "nan", "-inf"]),
        (argtypes.finite_float, {"-3": -3.0}, ["nan", "inf", "x"]),
        (argtypes.fraction, {"0": 0.0, "1": 1.0}, ["1.5", "-0.1", "nan"]),
        (argtypes.float_in(0.0, 2.0), {"2": 2.0}, ["2.1", "nan"]),
        (argtypes.int_at_least(30), {"30": 30}, ["29"]),
    ],
)
def test_the_argument_types(helper, good: dict, bad: list[str]) -> None:
    for text, value in good.items():
        assert helper(text) == value
    for text in bad:
        with pytest.raises(argparse.ArgumentTypeError, match=repr(text).replace("(", r"\(")):
            helper(text)
    assert not math.isnan(helper(next(iter(good))))
