"""training.sweep: sweep-file validation, grid expansion, skipping finished trials, failures.

The trials' commands are replaced by small scripts here (the plumbing is what is tested); the
real train + evaluate commands through Ray are the slow test at the end and the CI's smoke sweep.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from training.run.config import ConfigError
from training.sweep import tune as sweep
from training.sweep.tune import PYTHON, Trial, expand, is_finished, load_sweep, run_sweep

REPO = Path(__file__).resolve().parents[3]
ENV = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO)}


def _write(path: Path, data: object) -> Path:
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture
def configs(tmp_path: Path) -> tuple[Path, Path]:
    a = _write(tmp_path / "a.yaml", {"name": "a", "env": {"id": "cdcr_gym/CCKAReach-v0"}})
    b = _write(tmp_path / "b.yaml", {"name": "b", "env": {"id": "cdcr_gym/BulletReach-v0"}})
    return a, b


def _spec(tmp_path: Path, **data: object) -> Path:
    base = {"name": "t", "configs": ["a.yaml"], "seeds": [0], "out_dir": str(tmp_path / "out")}
    base.update(data)
    return _write(tmp_path / "sweep.yaml", base)


def test_trial_config_names_the_model_the_sweep_evaluates(tmp_path: Path) -> None:
    """A config whose evaluate.model is final, swept with the sweep's evaluate.model best: the
    trial's config (and so its run directory's config.yaml) says best, as its --model does."""
    _write(
        tmp_path / "a.yaml",
        {"name": "a", "env": {"id": "cdcr_gym/CCKAReach-v0"}, "evaluate": {"model": "final"}},
    )
    (trial,) = expand(load_sweep(_spec(tmp_path, evaluate={"model": "best"})))
    assert trial.config["evaluate"]["model"] == "best"
    assert trial.commands()[1][-2:] == ["--model", "best"]


# -- the grid -----------------------------------------------------------------------------------
def test_grid_is_configs_x_overrides_x_grid_x_seeds(tmp_path: Path, configs) -> None:
    path = _spec(
        tmp_path,
        configs=["a.yaml", "b.yaml"],  # relative to the sweep file
        seeds=[0, 5],
        set={"runtime.max_wall_time_s": 30, "total_timesteps": 4096},
        overrides=[{}, {"ppo.n_epochs": 3}],
        grid={"ppo.learning_rate": [1.0e-3, 3.0e-4]},
    )
    trials = expand(load_sweep(path))
    assert len(trials) == 2 * 2 * 2 * 2
    assert len({t.trial_id for t in trials}) == len(trials)
    assert len({t.run_dir for t in trials}) == len(trials)
    assert {t.env_id for t in trials} == {"cdcr_gym/CCKAReach-v0", "cdcr_gym/BulletReach-v0"}
    for t in trials:
        c = t.config
        assert c["seed"] == t.seed and t.trial_id.endswith(f"_seed{t.seed}")
        assert c["runtime"]["max_wall_time_s"] == 30 and c["total_timesteps"] == 4096
        assert c["ppo"]["n_epochs"] == t.variant.get("ppo.n_epochs", 10)
        assert c["ppo"]["learning_rate"] == t.variant["ppo.learning_rate"]
        assert t.run_dir.parent == tmp_path / "out" / "runs"
    assert sorted({t.seed for t in trials}) == [0, 5]
    # commands: an ordinary training run, then the evaluation of its best model
    train, evaluate = trials[0].commands()
    assert train[1:3] == ["-m", "training.run.train"] and train[-2:] == [
        "--run-dir",
        str(trials[0].run_dir),
    ]
    assert evaluate[1:4] == ["-m", "training.evaluate", str(trials[0].run_dir)]


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"seed": [0]}, "unknown sweep key 'seed'; did you mean 'seeds'?"),
        ({"evaluate": {"episode": 3}}, "unknown sweep key 'evaluate.episode'"),
        ({"resources": {"cpus": 1}}, "unknown sweep key 'resources.cpus'"),
        ({"target": {"success": 0.9}}, "unknown sweep key 'target.success'"),
        ({"overrides": [{"ppo.n_epoch": 3}]}, "unknown config key 'ppo.n_epoch'"),
        ({"set": {"runtime.max_wall_time_s": -1}}, "runtime.max_wall_time_s must be"),
        ({"grid": {"ppo.gamma": []}}, "grid.ppo.gamma must be a non-empty list"),
        ({"seeds": [0, 0]}, "seeds must be a non-empty list of distinct"),
        ({"configs": ["nope.yaml"]}, "'nope.yaml' does not exist"),
        ({"evaluate": {"model": "last"}}, "evaluate.model must be 'best' or 'final'"),
    ],
)
def test_sweep_file_is_strict(tmp_path: Path, configs, data: dict, message: str, capsys) -> None:
    path = _spec(tmp_path, **data)
    with pytest.raises(ConfigError, match=None) as info:
        expand(load_sweep(path))
    assert message in str(info.value)
    # the CLI: exit status 2, the message on stderr, nothing run
    assert sweep.main([str(path)]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_clashing_trial_ids_are_an_error(tmp_path: Path, configs) -> None:
    _write(tmp_path / "a2.yaml", {"name": "a"})
    with pytest.raises(ConfigError, match="share the run directory 'a_seed0'"):
        expand(load_sweep(_spec(tmp_path, configs=["a.yaml", "a2.yaml"])))


# -- running: skip finished, report failures ----------------------------------------------------
FAKE_TRIAL = """
import json, pathlib, sys
run, seed = pathlib.Path(sys.argv[1]), int(sys.argv[2])
calls = run.parent.parent / "calls.txt"
with open(calls, "a") as f:
    f.write(run.name + "\\n")
if seed == 1:
    print("training blew up: ValueError: tension_step must be > 0", file=sys.stderr)
    sys.exit(3)
run.mkdir(parents=True)
(run / "run.json").write_text(json.dumps({"status": "complete"}))
(run / "eval.json").write_text("{}")
"""


@pytest.fixture
def fake_commands(monkeypatch) -> None:
    def commands(self: Trial) -> list[list[str]]:
        return [[PYTHON, "-c", FAKE_TRIAL, str(self.run_dir), str(self.seed)]]

    monkeypatch.setattr(Trial, "commands", commands)


def test_failures_are_reported_and_finished_trials_skipped(
    tmp_path: Path, configs, fake_commands, capsys
) -> None:
    spec = load_sweep(_spec(tmp_path, seeds=[0, 1, 2]))
    calls = tmp_path / "out" / "calls.txt"

    summary = run_sweep(spec, executor="serial")
    status = {r["trial_id"]: r["status"] for r in summary["trials"]}
    assert status == {"a_seed0": "complete", "a_seed1": "failed", "a_seed2": "complete"}
    failed = next(r for r in summary["trials"] if r["status"] == "failed")
    assert failed["returncode"] == 3 and "tension_step must be > 0" in failed["error"]
    assert sweep._report(summary) == 1  # exit status 1: a trial failed
    err = capsys.readouterr().err
    assert "FAILED a_seed1" in err and "tension_step must be > 0" in err
    assert calls.read_text().split() == ["a_seed0", "a_seed1", "a_seed2"]
    saved = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert [r["status"] for r in saved["trials"]] == ["complete", "failed", "complete"]

    # a re-run skips the finished trials and retries the failed one
    trials = expand(spec)
    assert [is_finished(t) for t in trials] == [True, False, True]
    summary = run_sweep(spec, executor="serial")
    assert calls.read_text().split() == ["a_seed0", "a_seed1", "a_seed2", "a_seed1"]
    assert [r["skipped"] for r in summary["trials"]] == [True, False, True]

    # an interrupted trial (record says running, partial run directory) runs again from scratch
    record = json.loads(trials[2].record_path.read_text())
    trials[2].record_path.write_text(json.dumps({**record, "status": "running"}))
    (trials[2].run_dir / "partial.txt").write_text("x")
    assert not is_finished(trials[2])
    run_sweep(spec, executor="serial")
    assert calls.read_text().split()[-2:] == ["a_seed1", "a_seed2"]
    assert not (trials[2].run_dir / "partial.txt").exists()

    # the same trial ids with another budget are other trials: they run again
    spec.set = {"runtime.max_wall_time_s": 7.0}
    assert not any(is_finished(t) for t in expand(spec))
    run_sweep(spec, executor="serial")
    assert calls.read_text().split()[-3:] == ["a_seed0", "a_seed1", "a_seed2"]
    assert [is_finished(t) for t in expand(spec)] == [True, False, True]


def test_a_config_key_added_since_at_its_default_keeps_a_trial_finished(
    tmp_path: Path, configs, fake_commands
) -> None:
    """A trial recorded before a config section existed (here ``demonstrations``) is the same
    experiment when the new section is at its default; with another value it runs again."""
    spec = load_sweep(_spec(tmp_path, seeds=[0]))
    run_sweep(spec, executor="serial")
    trial = expand(spec)[0]
    assert trial.config["demonstrations"]["episodes"] == 0
    record = json.loads(trial.record_path.read_text())
    del record["resolved_config"]["demonstrations"]  # as written before the section existed
    trial.record_path.write_text(json.dumps(record))
    assert is_finished(trial)
    record["resolved_config"]["demonstrations"] = {"episodes": 5}
    trial.record_path.write_text(json.dumps(record))
    assert not is_finished(trial)
    record["resolved_config"]["no_such_section"] = {}
    trial.record_path.write_text(json.dumps(record))
    assert not is_finished(trial)  # no longer loadable: rerun, no crash


@pytest.mark.slow  # ~12 s: a real training stopped by its wall-time budget
def test_wall_time_budget_stops_training(tmp_path: Path) -> None:
    """runtime.max_wall_time_s ends a run early, as complete, with a final evaluation."""
    cfg = _write(
        tmp_path / "tiny.yaml",
        {
            "name": "tiny",
            "total_timesteps": 10_000_000,
            "env": {"n_envs": 2},
            "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 1, "policy": {"net_arch": [8]}},
            "eval": {"freq": 1_000_000, "n_episodes": 2},
            "checkpoint": {"freq": 1_000_000},
            "runtime": {"max_wall_time_s": 2.0},
        },
    )
    run = tmp_path / "run"
    result = subprocess.run(
        [sys.executable, "-m", "training.run.train", str(cfg), "--run-dir", str(run)],
        cwd=REPO,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    meta = json.loads((run / "run.json").read_text())
    assert meta["status"] == "complete" and meta["stopped_by"] == "runtime.max_wall_time_s"
    assert 0 < meta["total_steps"] < 10_000_000
    assert meta["total_wall_time_s"] >= 2.0
    assert (run / "final_model" / "model.zip").is_file()
    last_eval = (run / "eval_log.csv").read_text().strip().splitlines()[-1]
    assert int(float(last_eval.split(",")[0])) == meta["total_steps"]  # evaluated at the stop


@pytest.mark.slow
def test_ray_sweep_runs_trials_and_survives_a_failing_one(tmp_path: Path) -> None:
    """Through Ray Tune: a good tiny trial completes although the other one fails."""
    smoke = yaml.safe_load((REPO / "configs" / "sweeps" / "smoke.yaml").read_text())
    smoke.update(
        seeds=[0],
        out_dir=str(tmp_path / "out"),
        overrides=[{}, {"env.kwargs.tension_step": -1.0}],  # valid config, fails in the env
    )
    path = _write(tmp_path / "smoke.yaml", smoke)
    result = subprocess.run(
        [sys.executable, "-m", "training.sweep", str(path)],
        cwd=tmp_path,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 1, result.stdout[-2000:] + result.stderr[-2000:]
    saved = json.loads((tmp_path / "out" / "sweep.json").read_text())
    status = {r["trial_id"]: r["status"] for r in saved["trials"]}
    assert status == {
        "ppo_ccka_reach_seed0": "complete",
        "ppo_ccka_reach_tension_step=-1.0_seed0": "failed",
    }
    assert "tension_step" in result.stderr
    assert (tmp_path / "out" / "runs" / "ppo_ccka_reach_seed0" / "eval.json").is_file()
    assert saved["executor"] == "ray"


def test_cdcr_gym_sweep_finds_the_packaged_sweep_file(tmp_path: Path, capsys) -> None:
    from training import cli

    assert cli.main(["sweep", "sweeps/smoke", "--dry-run", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split("\t")[:2] for line in out] == [
        ["ppo_ccka_reach_seed0", "to run"],
        ["ppo_ccka_reach_seed1", "to run"],
    ]


def test_ray_executor_without_ray_names_the_extra(tmp_path: Path, monkeypatch, capsys) -> None:
    real = sweep.importlib.util.find_spec
    monkeypatch.setattr(
        sweep.importlib.util, "find_spec", lambda name: None if name == "ray" else real(name)
    )
    path = str(REPO / "configs" / "sweeps" / "smoke.yaml")
    assert sweep.main([path, "--out-dir", str(tmp_path / "out")]) == 2
    assert "cdcr-gym[sweep]" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_benchmark_sweep_covers_every_algorithm_and_task() -> None:
    """configs/sweeps/benchmark.yaml (v2): 4 algorithms x 4 tasks x {CCKA, MuJoCo} x 5 seeds,
    one part per (backend, task) with one wall-time budget for every algorithm of the part."""
    spec = load_sweep(REPO / "configs" / "sweeps" / "benchmark.yaml")
    trials = expand(spec)
    pairs = {(t.algo, t.env_id.split("/")[-1]) for t in trials}
    algos = {"ppo", "sac", "td3", "tqc"}
    tasks = ("Reach", "Track", "Pose", "Obstacle")
    envs = {f"{backend}{task}-v0" for backend in ("CCKA", "MuJoCo") for task in tasks}
    assert pairs == {(a, e) for a in algos for e in envs}
    assert len(spec.seeds) >= 5
    assert len(trials) == len(pairs) * len(spec.seeds)
    for part in spec.parts:
        members = [t for t in trials if t.part == part]
        assert {t.algo for t in members} == algos and len({t.env_id for t in members}) == 1
        budgets = {t.config["runtime"]["max_wall_time_s"] for t in members}
        assert len(budgets) == 1 and budgets.pop() > 0
        # the same evaluation episodes for every algorithm of a task
        assert len({json.dumps(t.config["evaluate"], sort_keys=True) for t in members}) == 1
        assert len({json.dumps(t.config["env"]["kwargs"], sort_keys=True) for t in members}) == 1
    # One trial per core of the 2-core machine the published numbers came from.
    assert spec.resources.max_concurrent * spec.resources.cpus_per_trial <= 2


# -- parts: a sweep run over several sittings -----------------------------------------------------
def test_parts_have_their_own_budget_and_run_one_at_a_time(
    tmp_path: Path, configs, fake_commands, capsys
) -> None:
    path = _spec(
        tmp_path,
        configs=None,
        seeds=[0, 2],
        set={"total_timesteps": 4096, "runtime.max_wall_time_s": 10},
        parts={
            "fast": {"configs": ["a.yaml"], "set": {"runtime.max_wall_time_s": 30}},
            "slow": {"configs": ["b.yaml"]},
        },
    )
    data = yaml.safe_load(path.read_text())
    del data["configs"]
    path.write_text(yaml.safe_dump(data))
    spec = load_sweep(path)
    trials = expand(spec)
    assert [(t.part, t.trial_id) for t in trials] == [
        ("fast", "a_seed0"),
        ("fast", "a_seed2"),
        ("slow", "b_seed0"),
        ("slow", "b_seed2"),
    ]
    budget = {t.trial_id: t.config["runtime"]["max_wall_time_s"] for t in trials}
    assert budget == {"a_seed0": 30, "a_seed2": 30, "b_seed0": 10, "b_seed2": 10}
    assert all(t.config["total_timesteps"] == 4096 for t in trials)

    # one part: only its trials run; sweep.json lists every trial, the others "not run"
    summary = run_sweep(spec, executor="serial", parts=["fast"])
    calls = tmp_path / "out" / "calls.txt"
    assert calls.read_text().split() == ["a_seed0", "a_seed2"]
    status = {r["trial_id"]: (r["part"], r["status"]) for r in summary["trials"]}
    assert status == {
        "a_seed0": ("fast", "complete"),
        "a_seed2": ("fast", "complete"),
        "b_seed0": ("slow", "not run"),
        "b_seed2": ("slow", "not run"),
    }
    capsys.readouterr()
    assert sweep._report(summary) == 0  # parts not run yet are no failure
    out = capsys.readouterr().out
    assert "2/4 trials complete (2 not run yet: their parts)" in out
    assert "part slow not run yet" in out and "skipped" not in out
    # the other part later (another sitting): the first part's trials stay, none reruns
    summary = run_sweep(spec, executor="serial", parts=["slow"])
    assert calls.read_text().split() == ["a_seed0", "a_seed2", "b_seed0", "b_seed2"]
    assert [r["status"] for r in summary["trials"]] == ["complete"] * 4
    assert [r["skipped"] for r in summary["trials"]] == [True, True, False, False]
    # the CLI: a dry run of one part; an unknown part names the parts
    capsys.readouterr()
    assert sweep.main([str(path), "--part", "slow", "--dry-run"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split("\t")[0::3] for line in out] == [["b_seed0", "slow"], ["b_seed2", "slow"]]
    assert sweep.main([str(path), "--part", "fats"]) == 2
    assert (
        "'fats' is not a part of the sweep 't' (its parts: fast, slow)" in capsys.readouterr().err
    )


@pytest.mark.parametrize(
    ("parts", "message"),
    [
        ({"p": {"config": ["a.yaml"]}}, "unknown sweep key 'parts.p.config'"),
        ({"p": {"configs": []}}, "parts.p.configs must be a non-empty list"),
        ({"p q": {"configs": ["a.yaml"]}}, "a part's name must be a word"),
        ({"p": {"configs": ["a.yaml"], "set": [1]}}, "parts.p.set must be a mapping"),
    ],
)
def test_parts_are_strict(tmp_path: Path, configs, parts: dict, message: str) -> None:
    path = _spec(tmp_path, parts=parts)
    data = yaml.safe_load(path.read_text())
    del data["configs"]
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as info:
        expand(load_sweep(path))
    assert message in str(info.value)
    # configs and parts together: ambiguous
    with pytest.raises(ConfigError, match="either configs or parts"):
        load_sweep(_spec(tmp_path, parts={"p": {"configs": ["a.yaml"]}}))
    # --part on a sweep without parts
    with pytest.raises(ConfigError, match="has no parts"):
        sweep.check_parts(load_sweep(_spec(tmp_path)), ["p"])
