"""Hostile sweep files: every ``set:`` key reaches the trial's config, out-of-range targets and
resources are usage errors naming the key, and a config error leaves no directory behind."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from training.run import train as train_mod
from training.run.config import ConfigError
from training.sweep import tune
from training.sweep.tune import expand, load_sweep


def _write(path: Path, data: object) -> Path:
    path.write_text(yaml.safe_dump(data))
    return path


def _spec(tmp_path: Path, **data: object) -> Path:
    _write(tmp_path / "a.yaml", {"name": "a", "env": {"id": "cdcr_gym/CCKAReach-v0"}})
    base = {"name": "t", "configs": ["a.yaml"], "seeds": [0], "out_dir": str(tmp_path / "out")}
    base.update(data)
    return _write(tmp_path / "sweep.yaml", base)


def _get(config: dict, key: str) -> object:
    for part in key.split("."):
        config = config[part]
    return config


# -- 2. a sweep's set: always reaches the trial's config ------------------------------------------
@pytest.mark.parametrize(
    "key, value",
    [
        ("evaluate.model", "final"),
        ("evaluate.episodes", 7),
        ("env.id", "cdcr_gym/CCKATrack-v0"),
        ("env.n_envs", 3),
        ("env.kwargs.goal_tolerance", 0.004),
        ("env.max_episode_steps", 77),
        ("ppo.policy.net_arch", [8, 8]),
        ("ppo.learning_rate", 1.0e-4),
        ("runtime.max_wall_time_s", 30.0),
        ("total_timesteps", 1024),
    ],
)
@pytest.mark.parametrize("where", ["set", "overrides", "grid", "part"])
def test_every_set_key_reaches_the_trial_config(
    tmp_path: Path, key: str, value: object, where: str
) -> None:
    extra: dict = {
        "set": {"set": {key: value}},
        "overrides": {"overrides": [{key: value}]},
        "grid": {"grid": {key: [value]}},
        "part": {"configs": None, "parts": {"p": {"configs": ["a.yaml"], "set": {key: value}}}},
    }[where]
    path = _spec(tmp_path, **extra)
    data = yaml.safe_load(path.read_text())
    if data.get("configs") is None:
        data.pop("configs", None)
        _write(path, data)
    (trial,) = expand(load_sweep(path))
    assert _get(trial.config, key) == value
    if key == "evaluate.model":  # and the sweep evaluates that model
        assert trial.commands()[1][-2:] == ["--model", value]


def test_a_set_evaluate_model_that_contradicts_the_sweeps_is_refused(tmp_path: Path) -> None:
    path = _spec(tmp_path, set={"evaluate.model": "final"}, evaluate={"model": "best"})
    with pytest.raises(ConfigError, match=r"evaluate\.model 'best'.*'final'"):
        expand(load_sweep(path))


def test_a_set_seed_is_refused_naming_seeds(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"set: seed 5 .*seeds"):
        load_sweep(_spec(tmp_path, set={"seed": 5}))


# -- 3. validation: key and value, exit 2, nothing left behind -------------------------------------
@pytest.mark.parametrize(
    "data, message",
    [
        ({"target": {"success_rate": math.nan}}, r"target\.success_rate.*nan"),
        ({"target": {"success_rate": math.inf}}, r"target\.success_rate.*inf"),
        ({"target": {"success_rate": 150}}, r"target\.success_rate.*150"),
        ({"target": {"within_1mm": -1}}, r"target\.within_1mm.*-1"),
        ({"target": {"median_error_mm": -1}}, r"target\.median_error_mm.*-1"),
        ({"target": {"mean_error_mm": math.inf}}, r"target\.mean_error_mm.*inf"),
        ({"resources": {"cpus_per_trial": math.inf}}, r"resources\.cpus_per_trial.*inf"),
        ({"resources": {"cpus_per_trial": math.nan}}, r"resources\.cpus_per_trial.*nan"),
    ],
)
def test_dry_run_refuses_bad_targets_and_resources(
    tmp_path: Path, data: dict, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _spec(tmp_path, **data)
    assert tune.main([str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert __import__("re").search(message, err), err
    assert not (tmp_path / "out").exists()


def test_a_bad_oracle_kwargs_leaves_no_run_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(
        tmp_path / "c.yaml",
        {
            "name": "c",
            "total_timesteps": 128,
            "env": {"id": "cdcr_gym/CCKAReach-v0", "n_envs": 1},
            "ppo": {"n_steps": 64, "batch_size": 64},
            "demonstrations": {"episodes": 2, "oracle_kwargs": {"no_such_option": 1}},
        },
    )
    run = tmp_path / "run"
    assert train_mod.main([str(cfg), "--run-dir", str(run)]) == 2
    err = capsys.readouterr().err
    assert "demonstrations.oracle_kwargs" in err and "no_such_option" in err
    assert not run.exists()
