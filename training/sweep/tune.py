"""Sweeps: a grid of experiments (configs × overrides × seeds) run as Ray Tune trials.

Usage::

    python -m training.sweep SWEEP.yaml [--address ADDR] [--executor ray|serial]
                                         [--part NAME ...] [--dry-run]
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
      model: best                    # best | final (default: each config's evaluate.model)
      episodes: null                 # null: the config's evaluate.episodes
    target:                          # "reached the target": the first periodic evaluation
      success_rate: 0.99             #   (eval_log.csv) meeting every listed threshold;
      within_1mm: 0.95               #   rates are lower bounds, *_error_mm upper bounds
      median_error_mm: 0.5
    resources:
      cpus_per_trial: 1              # Ray resources per trial (one trial per core by default)
      max_concurrent: null           # null: as many as the cluster's CPUs allow
    out_dir: null                    # null: runs/sweeps/<name> (relative to the working dir)

A sweep too long for one sitting is split into **parts** (instead of ``configs``)::

    parts:                           # name -> its configs and its own settings
      ccka_reach:
        configs: [ppo_ccka_fast, sac_ccka_reach]
        set: {runtime.max_wall_time_s: 90}   # on top of the sweep's set (the part's budget)
      mujoco_obstacle:
        configs: [ppo_mujoco_obstacle]
        set: {runtime.max_wall_time_s: 500}

``--part NAME`` (repeatable) runs only those parts' unfinished trials; every run writes
``sweep.json`` with all trials (those of parts not run yet: ``not run``), so the parts can run
on different days or machines into the same output directory and be aggregated together.

Each trial is an ordinary ``python -m training.run.train`` run directory, ``OUT/runs/<trial id>``,
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
benchmark page) is ``python -m training.sweep.aggregate OUT``.
"""

from __future__ import annotations

import argparse
import ctypes
import dataclasses
import datetime as _dt
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

import gymnasium as gym
import yaml

import cdcr_gym  # noqa: F401
from training.run.config import (
    ConfigError,
    config_from_dict,
    config_to_dict,
    load_config,
    save_config,
)
from training.run.packaged import resolve_config
from training.sweep.spec import (
    TARGET_KEYS,
    PartSpec,
    SweepSpec,
    check_parts,
    load_sweep,
    sweep_from_dict,
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
PYTHON = "{python}"  # replaced by the Python of the process that runs the trial


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
    part: str = ""  # the sweep part it belongs to ("": a sweep without parts)

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


# -- the grid -----------------------------------------------------------------------------------
def _find_config(name: str, base_dir: Path) -> Path:
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

    grid_variants = [
        dict(zip(spec.grid, values, strict=True))
        for values in itertools.product(*spec.grid.values())
    ]
    variants = [{**o, **g} for o in spec.overrides for g in grid_variants]
    trials: list[Trial] = []
    seen: dict[str, str] = {}
    parts = spec.parts or {"": PartSpec(spec.configs)}
    for part_name, name, part_set in (
        (p, c, part.set) for p, part in parts.items() for c in part.configs
    ):
        path = _find_config(name, spec.base_dir)
        base = yaml.safe_load(path.read_text()) or {}
        if not isinstance(base, dict):
            raise ConfigError(f"configs: {path} is not a mapping")
        for variant in variants:
            for seed in spec.seeds:
                data = json.loads(json.dumps(base))
                data["seed"] = seed
                # The sweep's evaluate.model goes in first, so that every set key reaches the
                # trial's config as written (a conflict with evaluate.model is refused below).
                if spec.evaluate.enabled and spec.evaluate.model is not None:
                    set_dotted(data, "evaluate.model", spec.evaluate.model)
                for key, value in {**spec.set, **part_set, **variant}.items():
                    set_dotted(data, key, value)
                where = f"config {str(path)!r}" + (f", variant {variant}" if variant else "")
                try:
                    config = config_from_dict(data)
                except ConfigError as exc:
                    raise ConfigError(f"{where}: {exc}") from None
                model = config.evaluate.model  # the model the sweep evaluates: the run's choice
                if spec.evaluate.model is not None and spec.evaluate.enabled:
                    if model != spec.evaluate.model:
                        raise ConfigError(
                            f"{where}: evaluate.model {spec.evaluate.model!r} of the sweep "
                            f"contradicts evaluate.model {model!r} set for the trial; "
                            f"give it in one place"
                        )
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
                        evaluate={**dataclasses.asdict(spec.evaluate), "model": model},
                        part=part_name,
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
    if saved is not None:
        try:  # a config key added since, at its default, is the same experiment
            saved = config_to_dict(config_from_dict(saved))
        except ValueError:  # not loadable any more (a key removed or renamed): rerun
            return False
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
    live on as an orphan. ``training.run.train`` takes SIGTERM as Ctrl-C (checkpoint, exit 130).
    """

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
        "part": trial.part,
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


def _not_run(trial: Trial) -> dict[str, Any]:
    """The record of a trial that has not run (yet): what it is, no outcome."""
    return {
        "trial_id": trial.trial_id,
        "config_name": trial.config_name,
        "algo": trial.algo,
        "env_id": trial.env_id,
        "seed": trial.seed,
        "part": trial.part,
        "status": "not run",
        "log": str(trial.log_path),
    }


def run_sweep(
    spec: SweepSpec,
    executor: str = "ray",
    address: str | None = None,
    argv: list[str] | None = None,
    parts: list[str] | None = None,
) -> dict[str, Any]:
    """Run the unfinished trials of ``spec`` (of its ``parts`` only, if given); write
    ``OUT/sweep.json`` (every trial of the sweep); return its content."""
    trials = expand(spec)
    check_parts(spec, parts)
    chosen = [t for t in trials if parts is None or t.part in parts]
    todo = [t for t in chosen if not is_finished(t)]
    out = spec.output
    out.mkdir(parents=True, exist_ok=True)
    which = f" (parts {', '.join(parts)}: {len(chosen)} trials)" if parts is not None else ""
    print(
        f"sweep {spec.name}: {len(trials)} trials{which}, {len(chosen) - len(todo)} finished "
        f"earlier (skipped), {len(todo)} to run; output {out}",
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
            record = _not_run(trial)
        elif record.get("status") == "running" and trial in todo:
            record = {**record, "status": "failed", "error": _tail(trial.log_path)}
        elif record.get("status") == "complete" and not is_finished(trial):
            # a record of another budget or config (the sweep file changed since): not this trial
            record = _not_run(trial)
        record.setdefault("part", trial.part)
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
    failed = [r for r in summary["trials"] if r.get("status") not in ("complete", "not run")]
    width = max(len(r["trial_id"]) for r in summary["trials"])
    for r in summary["trials"]:
        done = r.get("status") == "complete"
        note = "skipped (finished earlier)" if r.get("skipped") and done else ""
        if r.get("status") == "not run":
            note = f"part {r['part']} not run yet" if r.get("part") else ""
        wall = f"{r['wall_time_s']:.0f} s" if "wall_time_s" in r else ""
        print(f"  {r['trial_id']:<{width}}  {r.get('status', '?'):<9} {wall:>7}  {note}")
    for r in failed:
        print(
            f"\nFAILED {r['trial_id']} ({r.get('stage', '?')}, exit {r.get('returncode', '?')}); "
            f"log {r.get('log')}\n{r.get('error', '')}",
            file=sys.stderr,
        )
    n = len(summary["trials"])
    complete = sum(r.get("status") == "complete" for r in summary["trials"])
    waiting = sum(r.get("status") == "not run" for r in summary["trials"])
    later = f" ({waiting} not run yet: their parts)" if waiting else ""
    print(f"\n{complete}/{n} trials complete{later}", flush=True)
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
        "--part",
        action="append",
        default=None,
        metavar="NAME",
        help="run only this part of the sweep (repeatable); default: every part",
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
        check_parts(spec, args.part)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if args.dry_run:
        for t in trials:
            if args.part is None or t.part in args.part:
                state = "finished" if is_finished(t) else "to run"
                print(f"{t.trial_id}\t{state}\t{t.run_dir}" + (f"\t{t.part}" if t.part else ""))
        return 0
    if args.executor == "ray" and importlib.util.find_spec("ray") is None:
        print(
            "error: the Ray executor needs ray: pip install 'cdcr-gym[sweep]' "
            "(or run the trials one by one with --executor serial)",
            file=sys.stderr,
        )
        return EXIT_USAGE
    summary = run_sweep(spec, args.executor, args.address, argv, parts=args.part)
    return _report(summary)


if __name__ == "__main__":
    sys.exit(main())
