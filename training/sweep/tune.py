"""Sweeps: a grid of experiments (configs × overrides × seeds) run as Ray Tune trials.

Usage::

    python -m training.sweep SWEEP.yaml [--address ADDR] [--executor ray|serial] [--dry-run]
    cdcr-gym sweep SWEEP.yaml ...

A sweep file (strict: an unknown or misspelt key is an error naming it, exit status 2)::

    name: benchmark                  # output directory runs/sweeps/<name> (see out_dir)
    configs:                         # experiment configs (paths, or packaged names)
      - configs/ppo_ccka_reach.yaml
      - ppo_bullet_reach
    seeds: [0, 1, 2]                 # every trial runs once per seed (the config's seed: ignored)
    set:                             # dotted config keys set in every trial
      runtime.max_wall_time_s: 90    #   e.g. an equal wall-clock training budget per run
    overrides:                       # variants: a list of dotted-key mappings ([{}]: none)
      - {}
      - {ppo.n_epochs: 5}
    grid:                            # every combination of these values (× each override)
      ppo.learning_rate: [3.0e-4, 1.0e-3]
    evaluate:                        # after training: python -m training.evaluate RUN_DIR
      enabled: true
      model: best                    # best | final
      episodes: null                 # null: the config's evaluate.episodes
    target:                          # "reached the target": the first periodic evaluation
      success_rate: 0.99             #   (eval_log.csv) meeting every listed threshold;
      within_1mm: 0.95               #   rates are lower bounds, *_error_mm upper bounds
      median_error_mm: 0.5
    resources:
      cpus_per_trial: 1              # Ray resources per trial (one trial per core by default)
      max_concurrent: null           # null: as many as the cluster's CPUs allow
    out_dir: null                    # null: runs/sweeps/<name> (relative to the working dir)

Each trial is an ordinary ``python -m training.train`` run directory, ``OUT/runs/<trial id>``,
trained from its resolved config ``OUT/configs/<trial id>.yaml`` (the same code and files as a
hand-started run), then evaluated. ``OUT/trials/<trial id>.json`` records the outcome (status,
commands, return codes, wall times, the machine's load average before and after) and
``OUT/logs/<trial id>.log`` its output. ``OUT/sweep.json`` lists all trials.

* **Ray Tune**: by default ``ray.init()`` starts Ray on this machine with one trial per core
  (``resources.cpus_per_trial: 1``); ``--address ADDR`` joins an existing cluster unchanged:
  ``auto`` for one started with ``ray start --head`` on this machine, ``ray://head:10001`` for a
  remote one (its nodes need cdcr-gym installed and ``out_dir`` on storage they share; Ray's
  own authentication settings apply).
  ``--executor serial`` runs the trials one after another in this process, without Ray (debugging).
* **Failures** (a non-zero exit of training or evaluation, a crash) are recorded and reported
  with the log's last lines; the other trials go on. Exit status 1 if any trial failed.
* **Re-running** the same sweep skips the trials that completed with the same resolved config
  and evaluation settings; any other run directory (failed, killed, or from another budget) is
  deleted and its trial runs again from scratch. A trial's training process gets SIGTERM if the
  Ray worker running it dies (Linux), so a cancelled sweep leaves no orphaned training.

Aggregation (IQM with stratified bootstrap confidence intervals, performance profiles, the
benchmark page) is ``python -m training.aggregate OUT``.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as _dt
import difflib
import importlib.util
import itertools
import json
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from training.run.config import (
    ConfigError,
    config_from_dict,
    config_to_dict,
    load_config,
    save_config,
)

__all__ = [
    "SweepSpec",
    "Trial",
    "load_sweep",
    "sweep_from_dict",
    "expand",
    "run_trial",
    "is_finished",
    "run_sweep",
    "main",
    "TARGET_KEYS",
]

EXIT_USAGE = 2
#: eval_log.csv columns a target may name -> True if higher is better (a lower bound)
TARGET_KEYS: dict[str, bool] = {
    "success_rate": True,
    "within_1mm": True,
    "mean_error_mm": False,
    "median_error_mm": False,
    "p95_error_mm": False,
}
PYTHON = "{python}"  # replaced by the Python of the process that runs the trial


@dataclasses.dataclass
class EvaluateSpec:
    """What runs after training: ``python -m training.evaluate RUN_DIR --model MODEL``."""

    enabled: bool = True
    model: str = "best"
    episodes: int | None = None


@dataclasses.dataclass
class ResourcesSpec:
    """Ray resources: CPUs per trial, and a cap on concurrent trials (None: no cap)."""

    cpus_per_trial: float = 1.0
    max_concurrent: int | None = None


@dataclasses.dataclass
class SweepSpec:
    """A parsed sweep file (see the module docstring)."""

    name: str
    configs: list[str]
    seeds: list[int]
    set: dict[str, Any] = dataclasses.field(default_factory=dict)
    overrides: list[dict[str, Any]] = dataclasses.field(default_factory=lambda: [{}])
    grid: dict[str, list[Any]] = dataclasses.field(default_factory=dict)
    evaluate: EvaluateSpec = dataclasses.field(default_factory=EvaluateSpec)
    target: dict[str, float] = dataclasses.field(default_factory=dict)
    resources: ResourcesSpec = dataclasses.field(default_factory=ResourcesSpec)
    out_dir: str | None = None
    #: where the sweep file lives (config paths may be relative to it); not a file key
    base_dir: Path = dataclasses.field(default=Path("."), repr=False)

    @property
    def output(self) -> Path:
        """The sweep's output directory (absolute)."""
        return Path(self.out_dir or Path("runs") / "sweeps" / self.name).resolve()


@dataclasses.dataclass
class Trial:
    """One run of the grid: a resolved config and where it goes. Plain data (sent to Ray)."""

    trial_id: str
    config_name: str
    algo: str
    env_id: str
    variant: dict[str, Any]
    seed: int
    config: dict[str, Any]  # the resolved experiment config (every key)
    out_dir: str  # the sweep's output directory (absolute)
    evaluate: dict[str, Any]

    @property
    def run_dir(self) -> Path:
        return Path(self.out_dir) / "runs" / self.trial_id

    @property
    def config_path(self) -> Path:
        return Path(self.out_dir) / "configs" / f"{self.trial_id}.yaml"

    @property
    def record_path(self) -> Path:
        return Path(self.out_dir) / "trials" / f"{self.trial_id}.json"

    @property
    def log_path(self) -> Path:
        return Path(self.out_dir) / "logs" / f"{self.trial_id}.log"

    def commands(self) -> list[list[str]]:
        """The commands of this trial, ``{python}`` standing for the interpreter."""
        cmds = [
            [
                PYTHON,
                "-m",
                "training.run.train",
                str(self.config_path),
                "--run-dir",
                str(self.run_dir),
            ]
        ]
        if self.evaluate.get("enabled", True):
            cmd = [PYTHON, "-m", "training.evaluate", str(self.run_dir)]
            cmd += ["--model", str(self.evaluate.get("model", "best"))]
            if self.evaluate.get("episodes") is not None:
                cmd += ["--episodes", str(self.evaluate["episodes"])]
            cmds.append(cmd)
        return cmds


# -- the sweep file -----------------------------------------------------------------------------
_TOP_KEYS = [f.name for f in dataclasses.fields(SweepSpec) if f.name != "base_dir"]


def _check_keys(where: str, data: dict[str, Any], valid: list[str]) -> None:
    for key in data:
        if key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise ConfigError(
                f"unknown sweep key '{where}{key}'{hint} (valid keys here: {', '.join(valid)})"
            )


def _mapping(key: str, value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise ConfigError(f"{key} must be a mapping of dotted config keys to values, got {value!r}")
    return dict(value)


def sweep_from_dict(data: Any, name: str = "sweep", base_dir: Path | None = None) -> SweepSpec:
    """A :class:`SweepSpec` from a parsed sweep file; raises ConfigError naming the bad key."""
    if not isinstance(data, dict):
        raise ConfigError(f"a sweep file must be a mapping of keys to values, got {data!r}")
    _check_keys("", data, _TOP_KEYS)
    sweep_name = data.get("name", name)
    if not isinstance(sweep_name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", sweep_name):
        raise ConfigError(f"name must be a word of [A-Za-z0-9_.-], got {sweep_name!r}")
    configs = data.get("configs")
    if not isinstance(configs, list) or not configs or not all(isinstance(c, str) for c in configs):
        raise ConfigError(f"configs must be a non-empty list of config files, got {configs!r}")
    seeds = data.get("seeds")
    if (
        not isinstance(seeds, list)
        or not seeds
        or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
        or len(set(seeds)) != len(seeds)
    ):
        raise ConfigError(
            f"seeds must be a non-empty list of distinct integers >= 0, got {seeds!r}"
        )
    common = _mapping("set", data.get("set"))
    overrides = data.get("overrides", [{}])
    if overrides is None:
        overrides = [{}]
    if not isinstance(overrides, list) or not overrides:
        raise ConfigError(f"overrides must be a non-empty list of mappings, got {overrides!r}")
    overrides = [_mapping(f"overrides[{i}]", o) for i, o in enumerate(overrides)]
    grid = _mapping("grid", data.get("grid"))
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(f"grid.{key} must be a non-empty list of values, got {values!r}")
    ev = data.get("evaluate") or {}
    if not isinstance(ev, dict):
        raise ConfigError(f"evaluate must be a mapping, got {ev!r}")
    _check_keys("evaluate.", ev, [f.name for f in dataclasses.fields(EvaluateSpec)])
    evaluate = EvaluateSpec(**ev)
    if not isinstance(evaluate.enabled, bool):
        raise ConfigError(f"evaluate.enabled must be true or false, got {evaluate.enabled!r}")
    if evaluate.model not in ("best", "final"):
        raise ConfigError(f"evaluate.model must be 'best' or 'final', got {evaluate.model!r}")
    if evaluate.episodes is not None and (
        not isinstance(evaluate.episodes, int)
        or isinstance(evaluate.episodes, bool)
        or evaluate.episodes <= 0
    ):
        raise ConfigError(
            f"evaluate.episodes must be a positive integer or null, got {evaluate.episodes!r}"
        )
    target = _mapping("target", data.get("target"))
    _check_keys("target.", target, list(TARGET_KEYS))
    for key, value in target.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"target.{key} must be a number, got {value!r}")
    res = data.get("resources") or {}
    if not isinstance(res, dict):
        raise ConfigError(f"resources must be a mapping, got {res!r}")
    _check_keys("resources.", res, [f.name for f in dataclasses.fields(ResourcesSpec)])
    resources = ResourcesSpec(**res)
    cpus = resources.cpus_per_trial
    if isinstance(cpus, bool) or not isinstance(cpus, (int, float)) or not cpus > 0:
        raise ConfigError(f"resources.cpus_per_trial must be a number > 0, got {cpus!r}")
    mc = resources.max_concurrent
    if mc is not None and (not isinstance(mc, int) or isinstance(mc, bool) or mc <= 0):
        raise ConfigError(
            f"resources.max_concurrent must be a positive integer or null, got {mc!r}"
        )
    out_dir = data.get("out_dir")
    if out_dir is not None and not isinstance(out_dir, str):
        raise ConfigError(f"out_dir must be a path or null, got {out_dir!r}")
    return SweepSpec(
        name=sweep_name,
        configs=list(configs),
        seeds=list(seeds),
        set=common,
        overrides=overrides,
        grid=grid,
        evaluate=evaluate,
        target={k: float(v) for k, v in target.items()},
        resources=resources,
        out_dir=out_dir,
        base_dir=base_dir or Path("."),
    )


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep file; raises ConfigError naming the file and the bad key."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"sweep file {str(path)!r} does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"sweep file {str(path)!r} is not valid YAML: {exc}") from None
    try:
        return sweep_from_dict(data, name=path.stem, base_dir=path.resolve().parent)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


# -- the grid -----------------------------------------------------------------------------------
def _find_config(name: str, base_dir: Path) -> Path:
    from training.cli import resolve_config

    for candidate in (Path(name), base_dir / name):
        if candidate.is_file():
            return candidate
    found = Path(resolve_config(name))
    if found.is_file():
        return found
    raise ConfigError(f"configs: config file {name!r} does not exist (nor a packaged config)")


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """``data[a][b][c] = value`` for ``key = "a.b.c"`` (missing levels are created as mappings)."""
    parts = key.split(".")
    node = data
    for i, part in enumerate(parts[:-1]):
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, dict):
            raise ConfigError(f"{key}: '{'.'.join(parts[: i + 1])}' is not a section of the config")
        node = child
    node[parts[-1]] = value


def _label(variant: dict[str, Any]) -> str:
    if not variant:
        return ""
    text = "_".join(f"{k.split('.')[-1]}={v}" for k, v in variant.items())
    return re.sub(r"[^A-Za-z0-9_.=-]+", "-", text)[:80]


def expand(spec: SweepSpec) -> list[Trial]:
    """The trials of a sweep: configs × (overrides × grid) × seeds, every config validated.

    Raises ConfigError naming the config, the variant and the bad key if any resolved config is
    invalid (nothing runs then).
    """
    import gymnasium as gym

    import cdcr_gym  # noqa: F401 - registers the ids

    grid_variants = [
        dict(zip(spec.grid, values, strict=True))
        for values in itertools.product(*spec.grid.values())
    ]
    variants = [{**o, **g} for o in spec.overrides for g in grid_variants]
    trials: list[Trial] = []
    seen: dict[str, str] = {}
    for name in spec.configs:
        path = _find_config(name, spec.base_dir)
        base = yaml.safe_load(path.read_text()) or {}
        if not isinstance(base, dict):
            raise ConfigError(f"configs: {path} is not a mapping")
        for variant in variants:
            for seed in spec.seeds:
                data = json.loads(json.dumps(base))
                for key, value in {**spec.set, **variant}.items():
                    set_dotted(data, key, value)
                data["seed"] = seed
                where = f"config {str(path)!r}" + (f", variant {variant}" if variant else "")
                try:
                    config = config_from_dict(data)
                except ConfigError as exc:
                    raise ConfigError(f"{where}: {exc}") from None
                if config.env.id not in gym.registry:
                    raise ConfigError(f"{where}: env.id {config.env.id!r} is not registered")
                label = _label(variant)
                trial_id = f"{config.name}{'_' + label if label else ''}_seed{seed}"
                if trial_id in seen:
                    raise ConfigError(
                        f"configs: two trials would share the run directory {trial_id!r} "
                        f"({seen[trial_id]} and {path}); give the configs different names"
                    )
                seen[trial_id] = str(path)
                trials.append(
                    Trial(
                        trial_id=trial_id,
                        config_name=config.name,
                        algo=str(data.get("algo", "ppo")).lower(),
                        env_id=config.env.id,
                        variant=variant,
                        seed=seed,
                        config=config_to_dict(config),
                        out_dir=str(spec.output),
                        evaluate=dataclasses.asdict(spec.evaluate),
                    )
                )
    return trials


# -- one trial ----------------------------------------------------------------------------------
def _write_json(path: Path, data: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


def _load_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _normalized(data: Any) -> Any:
    return json.loads(json.dumps(data))


def is_finished(trial: Trial) -> bool:
    """True if this exact trial ran to completion earlier and its run directory still holds it.

    "This exact trial": the resolved config and the evaluation settings recorded then equal the
    trial's now (a sweep file whose ``set`` changed, e.g. another budget, reruns its trials).
    """
    record = _load_json(trial.record_path)
    if not isinstance(record, dict) or record.get("status") != "complete":
        return False
    meta = _load_json(trial.run_dir / "run.json")
    if not isinstance(meta, dict) or meta.get("status") != "complete":
        return False
    saved = record.get("resolved_config")
    if saved is None and (trial.run_dir / "config.yaml").is_file():
        saved = config_to_dict(load_config(trial.run_dir / "config.yaml"))
    if saved is not None and _normalized(saved) != _normalized(trial.config):
        return False
    if record.get("evaluate", trial.evaluate) != trial.evaluate:
        return False
    return not trial.evaluate.get("enabled", True) or (trial.run_dir / "eval.json").is_file()


def _tail(path: Path, lines: int = 15) -> str:
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return ""
    # progress bars redraw with carriage returns: keep the last state of each line
    return "\n".join(line.split("\r")[-1] for line in text.splitlines()[-lines:])


def _loadavg() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _terminate_with_parent() -> None:
    """In the child, before exec (Linux): SIGTERM when the process that started it dies.

    Ray kills a cancelled trial's worker outright; without this its training subprocess would
    live on as an orphan. ``training.train`` takes SIGTERM as Ctrl-C (checkpoint, exit 130).
    """
    import ctypes

    pr_set_pdeathsig = 1
    ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM)


def run_trial(trial: Trial | dict[str, Any]) -> dict[str, Any]:
    """Train (and evaluate) one trial as subprocesses; write and return its record.

    Never raises for a failing run: the record's ``status`` is ``complete`` or ``failed`` (with
    ``stage``, ``returncode`` and the log's last lines in ``error``).
    """
    if isinstance(trial, dict):
        trial = Trial(**trial)
    env = dict(os.environ)
    repo = Path(__file__).resolve().parents[2]
    if (repo / "pyproject.toml").is_file():  # a checkout: its training/, not an installed one
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(repo), env.get("PYTHONPATH")) if p)
    env.setdefault("MPLBACKEND", "Agg")
    if trial.run_dir.exists():
        shutil.rmtree(trial.run_dir)  # an incomplete earlier attempt: start again
    trial.config_path.parent.mkdir(parents=True, exist_ok=True)
    trial.log_path.parent.mkdir(parents=True, exist_ok=True)
    trial.run_dir.parent.mkdir(parents=True, exist_ok=True)
    save_config(config_from_dict(trial.config), trial.config_path)
    record: dict[str, Any] = {
        "trial_id": trial.trial_id,
        "config_name": trial.config_name,
        "algo": trial.algo,
        "env_id": trial.env_id,
        "variant": trial.variant,
        "seed": trial.seed,
        "run_dir": str(trial.run_dir),
        "config": str(trial.config_path),
        "log": str(trial.log_path),
        "resolved_config": trial.config,
        "evaluate": trial.evaluate,
        "host": socket.gethostname(),
        "cpu_count": os.cpu_count(),
        "start": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "loadavg_start": _loadavg(),
        "status": "running",
        "commands": [],
    }
    _write_json(trial.record_path, record)
    t0 = time.perf_counter()
    with open(trial.log_path, "w") as log:
        for cmd in trial.commands():
            cmd = [sys.executable if a == PYTHON else a for a in cmd]
            stage = cmd[2].split(".")[-1] if len(cmd) > 2 else cmd[0]
            log.write(f"$ {shlex.join(cmd)}\n")
            log.flush()
            t_cmd = time.perf_counter()
            try:
                rc = subprocess.run(
                    cmd,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=env,
                    cwd=trial.out_dir,
                    preexec_fn=_terminate_with_parent if sys.platform == "linux" else None,
                ).returncode
            except OSError as exc:
                log.write(f"{exc}\n")
                rc = -1
            record["commands"].append(
                {
                    "stage": stage,
                    "command": shlex.join(cmd),
                    "returncode": rc,
                    "wall_time_s": round(time.perf_counter() - t_cmd, 2),
                }
            )
            if rc != 0:
                record.update(status="failed", stage=stage, returncode=rc)
                break
        else:
            record["status"] = "complete"
    record["wall_time_s"] = round(time.perf_counter() - t0, 2)
    record["end"] = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
    record["loadavg_end"] = _loadavg()
    if record["status"] == "failed":
        record["error"] = _tail(trial.log_path)
    _write_json(trial.record_path, record)
    return record


# -- executors ----------------------------------------------------------------------------------
def _run_serial(trials: list[Trial]) -> None:
    for i, trial in enumerate(trials):
        print(f"[{i + 1}/{len(trials)}] {trial.trial_id}", flush=True)
        record = run_trial(trial)
        print(f"    {record['status']} in {record['wall_time_s']:.0f} s", flush=True)


def _ray_trainable(config: dict[str, Any], trials: dict[str, dict[str, Any]]) -> None:
    """A Ray Tune function trainable: the :class:`Trial` ``trials[config["trial_id"]]``."""
    from ray import tune

    record = run_trial(trials[config["trial_id"]])
    if record["status"] != "complete":
        raise RuntimeError(
            f"trial {record['trial_id']} failed in {record.get('stage')} "
            f"(exit {record.get('returncode')}); log {record['log']}"
        )
    tune.report({"wall_time_s": record["wall_time_s"], "done": True})


def _ray_trial_name(trial: Any) -> str:
    """Ray's name (and directory name) of a trial: the sweep's trial id."""
    return str(trial.config["trial_id"])


def _run_ray(trials: list[Trial], spec: SweepSpec, address: str | None) -> None:
    import ray
    from ray import tune

    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    if address:
        ray.init(address=address, log_to_driver=False)
    else:
        ray.init(include_dashboard=False, log_to_driver=False)
    try:
        # The trials travel through Ray's object store; the search space is just their ids.
        by_id = {t.trial_id: dataclasses.asdict(t) for t in trials}
        trainable = tune.with_resources(
            tune.with_parameters(_ray_trainable, trials=by_id),
            {"cpu": float(spec.resources.cpus_per_trial)},
        )
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        tuner = tune.Tuner(
            trainable,
            param_space={"trial_id": tune.grid_search(list(by_id))},
            tune_config=tune.TuneConfig(
                num_samples=1,
                max_concurrent_trials=spec.resources.max_concurrent,
                trial_name_creator=_ray_trial_name,
                trial_dirname_creator=_ray_trial_name,
            ),
            run_config=tune.RunConfig(
                name=f"{spec.name}_{stamp}",
                storage_path=str(spec.output / "ray"),
                failure_config=tune.FailureConfig(max_failures=0, fail_fast=False),
                verbose=1,
            ),
        )
        tuner.fit()
    finally:
        ray.shutdown()


def run_sweep(
    spec: SweepSpec,
    executor: str = "ray",
    address: str | None = None,
    argv: list[str] | None = None,
) -> dict[str, Any]:
    """Run the unfinished trials of ``spec``; write ``OUT/sweep.json``; return its content."""
    trials = expand(spec)
    todo = [t for t in trials if not is_finished(t)]
    out = spec.output
    out.mkdir(parents=True, exist_ok=True)
    print(
        f"sweep {spec.name}: {len(trials)} trials, {len(trials) - len(todo)} finished earlier "
        f"(skipped), {len(todo)} to run; output {out}",
        flush=True,
    )
    if todo:
        if executor == "serial":
            _run_serial(todo)
        else:
            _run_ray(todo, spec, address)
    records = []
    for trial in trials:
        record = _load_json(trial.record_path)
        if not isinstance(record, dict):
            record = {"trial_id": trial.trial_id, "status": "not run", "log": str(trial.log_path)}
        elif record.get("status") == "running":
            record = {**record, "status": "failed", "error": _tail(trial.log_path)}
        record["skipped"] = trial not in todo
        records.append(record)
    summary = {
        "name": spec.name,
        "command": shlex.join(["cdcr-gym", "sweep", *(argv or [])]),
        "executor": executor,
        "address": address,
        "time": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "spec": {
            k: v for k, v in dataclasses.asdict(spec).items() if k not in ("base_dir", "out_dir")
        },
        "trials": records,
    }
    _write_json(out / "sweep.json", summary)
    return summary


def _report(summary: dict[str, Any]) -> int:
    failed = [r for r in summary["trials"] if r.get("status") != "complete"]
    width = max(len(r["trial_id"]) for r in summary["trials"])
    for r in summary["trials"]:
        note = "skipped (finished earlier)" if r.get("skipped") else ""
        wall = f"{r['wall_time_s']:.0f} s" if "wall_time_s" in r else ""
        print(f"  {r['trial_id']:<{width}}  {r.get('status', '?'):<9} {wall:>7}  {note}")
    for r in failed:
        print(
            f"\nFAILED {r['trial_id']} ({r.get('stage', '?')}, exit {r.get('returncode', '?')}); "
            f"log {r.get('log')}\n{r.get('error', '')}",
            file=sys.stderr,
        )
    n = len(summary["trials"])
    print(f"\n{n - len(failed)}/{n} trials complete", flush=True)
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="cdcr-gym sweep",
        description="Run a grid of experiments (configs × overrides × seeds) as Ray Tune trials.",
    )
    parser.add_argument("sweep", help="sweep file, e.g. configs/sweeps/benchmark.yaml")
    parser.add_argument(
        "--address",
        default=None,
        help="join an existing Ray cluster (e.g. 'auto'); default: start Ray on this machine",
    )
    parser.add_argument(
        "--executor",
        choices=("ray", "serial"),
        default="ray",
        help="ray (default): Ray Tune trials; serial: one after another here, without Ray",
    )
    parser.add_argument(
        "--out-dir", default=None, help="override the sweep file's out_dir (output directory)"
    )
    parser.add_argument(
        "--dry-run", action="store_true", help="list the trials and whether they are finished"
    )
    args = parser.parse_args(argv)
    if args.address and args.executor != "ray":
        print("error: --address needs --executor ray", file=sys.stderr)
        return EXIT_USAGE
    try:
        spec = load_sweep(args.sweep)
        if args.out_dir is not None:
            spec.out_dir = args.out_dir
        trials = expand(spec)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if args.dry_run:
        for t in trials:
            print(f"{t.trial_id}\t{'finished' if is_finished(t) else 'to run'}\t{t.run_dir}")
        return 0
    if args.executor == "ray" and importlib.util.find_spec("ray") is None:
        print(
            "error: the Ray executor needs ray: pip install 'cdcr-gym[sweep]' "
            "(or run the trials one by one with --executor serial)",
            file=sys.stderr,
        )
        return EXIT_USAGE
    summary = run_sweep(spec, args.executor, args.address, argv)
    return _report(summary)


if __name__ == "__main__":
    sys.exit(main())
