"""Train a PPO agent on a cdcr_gym env from a YAML config.

Usage::

    python -m training.train CONFIG [--run-dir DIR] [--total-timesteps N] [--seed S] [--resume]

The run directory (default ``runs/<name>_seed<S>_<timestamp>``) holds everything that
reproduces and documents the run:

=============================  =================================================================
``config.yaml``                the resolved config (every key; CLI overrides applied)
``run.json``                   seed, versions (python, numpy, torch, stable-baselines3, gymnasium,
                               cdcr_gym, pybullet), git commit, host, and one entry per training
                               session (command, start/end, steps, wall time, status)
``command.txt``                every command line that trained into this directory
``tb/``                        TensorBoard logs (``rollout/``, ``train/``, ``charts/``, ``eval/``)
``progress.csv``               the same scalars as CSV (continued, not overwritten, on resume)
``eval_log.csv``               the periodic fixed-goal evaluations
``checkpoints/``               ``model_<N>_steps.zip`` + ``vecnormalize_<N>_steps.pkl``
``best_model/``                ``model.zip`` + ``vecnormalize.pkl`` + ``info.json`` (best eval)
``final_model/``               the same at the end of training
``vecnormalize.pkl``           the final VecNormalize statistics
``learning_curve.png``         eval success rate and tip error, and training return, vs steps
=============================  =================================================================

``--resume`` continues an interrupted run from its last checkpoint: the step counter, the
learning-rate schedule, the VecNormalize statistics, the best-model score and the logs all
continue (log rows past the checkpoint, from the interrupted session, are dropped from the CSV
logs). Ctrl-C (or SIGTERM) saves a checkpoint before exiting with status 130.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import json
import os
import platform
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from training.config import (
    ConfigError,
    ExperimentConfig,
    config_to_dict,
    load_config,
    save_config,
)

__all__ = ["main", "train", "build_vec_env", "RunDir"]

EXIT_INTERRUPTED = 130


# -- the run directory --------------------------------------------------------------------------
class RunDir:
    """Paths inside a run directory."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    config = property(lambda self: self.root / "config.yaml")
    run_json = property(lambda self: self.root / "run.json")
    command = property(lambda self: self.root / "command.txt")
    tb = property(lambda self: self.root / "tb")
    progress = property(lambda self: self.root / "progress.csv")
    eval_log = property(lambda self: self.root / "eval_log.csv")
    checkpoints = property(lambda self: self.root / "checkpoints")
    best = property(lambda self: self.root / "best_model")
    final = property(lambda self: self.root / "final_model")
    vecnormalize = property(lambda self: self.root / "vecnormalize.pkl")
    learning_curve = property(lambda self: self.root / "learning_curve.png")

    def checkpoint_paths(self, steps: int) -> tuple[Path, Path]:
        return (
            self.checkpoints / f"model_{steps}_steps.zip",
            self.checkpoints / f"vecnormalize_{steps}_steps.pkl",
        )

    def latest_checkpoint(self) -> int | None:
        """Step count of the newest complete checkpoint (model and statistics), or None."""
        best = None
        for path in self.checkpoints.glob("model_*_steps.zip"):
            m = re.fullmatch(r"model_(\d+)_steps\.zip", path.name)
            if m and self.checkpoint_paths(int(m.group(1)))[1].exists():
                steps = int(m.group(1))
                best = steps if best is None else max(best, steps)
        return best


def _versions() -> dict[str, str]:
    import gymnasium
    import stable_baselines3
    import torch

    import cdcr_gym

    versions = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "torch": torch.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "gymnasium": gymnasium.__version__,
        "cdcr_gym": cdcr_gym.__version__,
    }
    try:
        from importlib.metadata import version

        versions["pybullet"] = version("pybullet")
    except Exception:  # noqa: BLE001 - optional information only
        versions["pybullet"] = "not installed"
    return versions


def _git_info() -> dict[str, Any]:
    repo = Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True, timeout=10
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=repo,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
        return {"commit": commit or None, "dirty": bool(dirty)}
    except (OSError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None}


def _now() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def _write_json(path: Path, data: Any) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


# -- environments -------------------------------------------------------------------------------
def build_vec_env(config: ExperimentConfig, seed: int, n_envs: int | None = None) -> Any:
    """The training VecEnv (Monitor-wrapped, not yet normalised), seeded with ``seed``."""
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    from training.rollout import make_env

    e = config.env
    n = e.n_envs if n_envs is None else n_envs
    if e.vec_env == "batched":
        try:
            from training.sb3_vec import BatchedCCKAVecEnv
        except ImportError as exc:
            raise ConfigError(
                f"env.vec_env: 'batched' needs training/sb3_vec.py (BatchedCCKAVecEnv), which "
                f"could not be imported ({exc}); use 'dummy' or 'subproc'"
            ) from None
        import gymnasium as gym

        import cdcr_gym  # noqa: F401 - registers the ids

        registered = gym.registry[e.id].kwargs if e.id in gym.registry else {}
        if registered.get("backend") != "CCKA":
            raise ConfigError(f"env.vec_env: 'batched' supports the CCKA env only, not {e.id!r}")
        kwargs = dict(e.kwargs)
        kwargs["task"] = registered["task"]
        if e.max_episode_steps is not None:
            kwargs["max_episode_steps"] = e.max_episode_steps
        if e.per_env_kwargs:
            kwargs["per_env_kwargs"] = [dict(k) for k in e.per_env_kwargs]
        try:
            venv = BatchedCCKAVecEnv(num_envs=n, seed=seed, **kwargs)
        except ValueError as exc:
            raise ConfigError(f"env (vec_env: batched): {exc}") from None
        return VecMonitor(venv)

    def factory(rank: int):
        def _init():
            kwargs = dict(e.kwargs)
            if e.per_env_kwargs:
                kwargs.update(e.per_env_kwargs[rank % len(e.per_env_kwargs)])
            env = make_env(e.id, kwargs, e.max_episode_steps)
            env = Monitor(env)
            env.reset(seed=seed + rank)
            env.action_space.seed(seed + rank)
            return env

        return _init

    fns = [factory(i) for i in range(n)]
    venv = SubprocVecEnv(fns) if e.vec_env == "subproc" else DummyVecEnv(fns)
    venv.seed(seed)
    return venv


def _registered_task(env_id: str) -> str:
    """The task name of a registered id (``"Reach"`` for ids registered elsewhere)."""
    import gymnasium as gym

    import cdcr_gym  # noqa: F401 - registers the ids

    spec = gym.registry.get(env_id)
    return str(spec.kwargs.get("task", "Reach")) if spec is not None else "Reach"


def _check_env_id(config: ExperimentConfig) -> None:
    import gymnasium as gym

    import cdcr_gym  # noqa: F401 - registers the ids

    if config.env.id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("cdcr_gym/"))
        raise ConfigError(f"env.id {config.env.id!r} is not registered; known ids: {known}")


# -- callbacks ----------------------------------------------------------------------------------
def _make_callbacks(config: ExperimentConfig, run: RunDir, state: dict[str, Any]) -> list[Any]:
    from stable_baselines3.common.callbacks import BaseCallback

    from training.rollout import (
        PPOPolicy,
        concat_specs,
        make_env,
        make_specs,
        run_episodes,
        summarize,
    )

    class StatsCallback(BaseCallback):
        """Logs the final tip error of finished training episodes (``charts/``)."""

        def __init__(self) -> None:
            super().__init__()
            self.final_errors: list[float] = []
            self.successes: list[float] = []

        def _on_step(self) -> bool:
            for done, info in zip(self.locals["dones"], self.locals["infos"], strict=False):
                if done and "distance" in info:
                    self.final_errors.append(float(info["distance"]) * 1000.0)
            return True

        def _on_rollout_end(self) -> None:
            if self.final_errors:
                self.logger.record("charts/final_error_mm_mean", float(np.mean(self.final_errors)))
                self.logger.record(
                    "charts/final_error_mm_median", float(np.median(self.final_errors))
                )
                self.final_errors = []
            self.logger.record(
                "charts/learning_rate", self.model.policy.optimizer.param_groups[0]["lr"]
            )

    class CheckpointCallback(BaseCallback):
        """Every ``checkpoint.freq`` env steps: model + VecNormalize + learning curve."""

        def __init__(self) -> None:
            super().__init__()
            self.next_at = (
                state["start_steps"] // config.checkpoint.freq + 1
            ) * config.checkpoint.freq

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at:
                save_checkpoint(self.model, run, state)
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.checkpoint.freq
            return True

    class EvalCallback(BaseCallback):
        """Fixed-goal evaluation every ``eval.freq`` env steps; keeps the best model."""

        def __init__(self) -> None:
            super().__init__()
            ev = config.eval
            self.next_at = (state["start_steps"] // ev.freq + 1) * ev.freq
            params = config.env.kwargs.get("params")
            if isinstance(params, dict):
                from cdcr_gym.params import RobotParams

                params = RobotParams(**params)
            self.specs = concat_specs(
                [make_specs(ev.n_episodes, ev.seed, s, params) for s in ev.initial_states]
            )
            self.horizon = config.env.max_episode_steps or _registered_steps(config.env.id)
            self.task = _registered_task(config.env.id)

        def _task_row(self, policy: Any) -> dict[str, Any]:
            """Success, errors (mm) and return of the task's own metrics (training.task_metrics):
            the error is the tracking RMS for Track, the final distance otherwise."""
            from training.task_metrics import run_task_episodes

            e, ev = config.env, config.eval
            parts = []
            for start in ev.initial_states:
                kwargs = {**e.kwargs, "initial_state": start}
                parts.append(
                    run_task_episodes(
                        lambda k=kwargs: make_env(e.id, k, self.horizon),
                        policy,
                        ev.n_episodes,
                        ev.seed,
                    )
                )
            key = "tracking_rms_mm" if self.task == "Track" else "final_distance_mm"
            errors = np.concatenate([p[key] for p in parts])
            return {
                "timesteps": self.num_timesteps,
                "success_rate": float(np.mean(np.concatenate([p["success"] for p in parts]))),
                "within_1mm": float(np.mean(errors <= 1.0)),
                "mean_error_mm": float(np.mean(errors)),
                "median_error_mm": float(np.median(errors)),
                "p95_error_mm": float(np.percentile(errors, 95)),
                "max_error_mm": float(np.max(errors)),
                "mean_reward": float(np.mean(np.concatenate([p["return"] for p in parts]))),
            }

        def _evaluate(self) -> None:
            vecnorm = self.model.get_vec_normalize_env()
            policy = PPOPolicy.from_model(self.model, vecnorm)
            e = config.env
            t0 = time.perf_counter()
            if self.task != "Reach":
                row = self._task_row(policy)
                row["wall_time_s"] = state["wall_before"] + time.perf_counter() - state["t_start"]
                self._record(row, vecnorm, t0)
                return
            rollouts = run_episodes(
                lambda: make_env(e.id, e.kwargs, self.horizon), policy, self.specs, self.horizon
            )
            threshold = config.env.kwargs.get("distance_threshold", 0.005)
            stats = summarize(rollouts.final_distance, threshold)
            row = {
                "timesteps": self.num_timesteps,
                "success_rate": stats["success_rate"],
                "within_1mm": stats["within_1mm"],
                "mean_error_mm": stats["error_mm"]["mean"],
                "median_error_mm": stats["error_mm"]["median"],
                "p95_error_mm": stats["error_mm"]["p95"],
                "max_error_mm": stats["error_mm"]["max"],
                "mean_reward": float(np.mean(rollouts.returns)),
                "wall_time_s": state["wall_before"] + time.perf_counter() - state["t_start"],
            }
            self._record(row, vecnorm, t0)

        def _record(self, row: dict[str, Any], vecnorm: Any, t0: float) -> None:
            for key in (
                "success_rate",
                "within_1mm",
                "mean_error_mm",
                "median_error_mm",
                "p95_error_mm",
                "mean_reward",
            ):
                self.logger.record(f"eval/{key}", row[key])
            self.logger.record("eval/duration_s", time.perf_counter() - t0)
            _append_csv(run.eval_log, row)
            state["last_eval_step"] = self.num_timesteps
            metric = config.eval.best_metric
            score = {
                "mean_error": -row["mean_error_mm"],
                "median_error": -row["median_error_mm"],
                "success_rate": row["success_rate"] - 1e-6 * row["mean_error_mm"],
                "mean_reward": row["mean_reward"],
            }[metric]
            if state.get("best_score") is None or score > state["best_score"]:
                state["best_score"] = score
                run.best.mkdir(parents=True, exist_ok=True)
                self.model.save(run.best / "model.zip")
                if vecnorm is not None:
                    vecnorm.save(str(run.best / "vecnormalize.pkl"))
                _write_json(run.best / "info.json", {**row, "best_metric": metric})
                self.logger.record("eval/best_step", self.num_timesteps)

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at:
                self._evaluate()
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.eval.freq
            return True

        def _on_training_end(self) -> None:
            # Always evaluate the final weights too (the best model may be the last one).
            if (
                state.get("last_eval_step") != self.num_timesteps
                and self.num_timesteps >= state["total"]
            ):
                self._evaluate()

    return [StatsCallback(), CheckpointCallback(), EvalCallback()]


def _registered_steps(env_id: str) -> int:
    import gymnasium as gym

    return gym.registry[env_id].max_episode_steps or 100


def save_checkpoint(model: Any, run: RunDir, state: dict[str, Any]) -> int:
    """Save model + VecNormalize at the model's step count; return the step count."""
    steps = int(model.num_timesteps)
    run.checkpoints.mkdir(parents=True, exist_ok=True)
    model_path, vn_path = run.checkpoint_paths(steps)
    vecnorm = model.get_vec_normalize_env()
    # Statistics first: a checkpoint counts once its model file exists (see latest_checkpoint).
    if vecnorm is not None:
        vecnorm.save(str(vn_path))
    else:
        vn_path.write_bytes(b"")
    model.save(model_path)
    state["last_checkpoint"] = steps
    _write_json(
        run.checkpoints / "state.json",
        {
            "steps": steps,
            "best_score": state.get("best_score"),
            "wall_time_s": state["wall_before"] + time.perf_counter() - state["t_start"],
        },
    )
    try:
        from training.plots import plot_learning_curve

        plot_learning_curve(run.root)
    except Exception as exc:  # noqa: BLE001 - a plot must never kill a training run
        print(f"warning: learning curve not written: {exc}", file=sys.stderr)
    return steps


# -- CSV logs that survive --resume -------------------------------------------------------------
def _append_csv(path: Path, row: dict[str, Any]) -> None:
    new = not path.exists()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(row))
        if new:
            writer.writeheader()
        writer.writerow(row)


def _truncate_csv(path: Path, step_key: str, max_step: int) -> None:
    """Drop rows of ``path`` whose ``step_key`` exceeds ``max_step`` (logs past a checkpoint)."""
    if not path.exists():
        return
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        fields = reader.fieldnames or []
        rows = [r for r in reader if not r.get(step_key) or float(r[step_key]) <= max_step]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


def _resumable_csv_format(path: Path) -> Any:
    """An SB3 logger output that appends to ``path`` (keeping its rows) instead of truncating."""
    from stable_baselines3.common.logger import KVWriter, filter_excluded_keys

    class ResumableCSV(KVWriter):
        def __init__(self) -> None:
            self.rows: list[dict[str, Any]] = []
            self.keys: list[str] = []
            if path.exists():
                with open(path, newline="") as f:
                    reader = csv.DictReader(f)
                    self.keys = list(reader.fieldnames or [])
                    self.rows = list(reader)

        def write(self, key_values: dict[str, Any], key_excluded: Any, step: int = 0) -> None:
            values = filter_excluded_keys(key_values, key_excluded, "csv")
            row = {k: v for k, v in values.items() if isinstance(v, (int, float, str, np.number))}
            self.rows.append(row)
            extra = [k for k in row if k not in self.keys]
            if extra:
                self.keys.extend(sorted(extra))
                with open(path, "w", newline="") as f:
                    writer = csv.DictWriter(f, fieldnames=self.keys)
                    writer.writeheader()
                    writer.writerows(self.rows)
            else:
                with open(path, "a", newline="") as f:
                    csv.DictWriter(f, fieldnames=self.keys).writerow(row)

        def close(self) -> None:
            pass

    return ResumableCSV()


def _make_logger(run: RunDir) -> Any:
    from stable_baselines3.common.logger import HumanOutputFormat, Logger, TensorBoardOutputFormat

    run.tb.mkdir(parents=True, exist_ok=True)
    formats = [
        HumanOutputFormat(sys.stdout),
        _resumable_csv_format(run.progress),
        TensorBoardOutputFormat(str(run.tb)),
    ]
    return Logger(folder=str(run.root), output_formats=formats)


# -- PPO ----------------------------------------------------------------------------------------
def _ppo_kwargs(config: ExperimentConfig) -> dict[str, Any]:
    import torch
    from stable_baselines3.common.utils import LinearSchedule

    p = config.ppo
    lr: Any = p.learning_rate
    if p.lr_schedule == "linear":
        lr = LinearSchedule(p.learning_rate, 0.0, 1.0)
    activation = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU, "elu": torch.nn.ELU}
    return {
        "learning_rate": lr,
        "n_steps": p.n_steps,
        "batch_size": p.batch_size,
        "n_epochs": p.n_epochs,
        "gamma": p.gamma,
        "gae_lambda": p.gae_lambda,
        "clip_range": p.clip_range,
        "ent_coef": p.ent_coef,
        "vf_coef": p.vf_coef,
        "max_grad_norm": p.max_grad_norm,
        "target_kl": p.target_kl,
        "policy_kwargs": {
            "net_arch": {"pi": list(p.policy.net_arch), "vf": list(p.policy.net_arch)},
            "activation_fn": activation[p.policy.activation],
            "log_std_init": p.policy.log_std_init,
            "ortho_init": p.policy.ortho_init,
        },
    }


def _wrap_normalize(config: ExperimentConfig, venv: Any, stats_path: Path | None) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    n = config.normalize
    if not n.enabled:
        return venv
    if stats_path is not None and stats_path.stat().st_size > 0:
        venv = VecNormalize.load(str(stats_path), venv)
        venv.training = True
        return venv
    return VecNormalize(
        venv,
        norm_obs=n.norm_obs,
        norm_reward=n.norm_reward,
        clip_obs=n.clip_obs,
        clip_reward=n.clip_reward,
        gamma=config.ppo.gamma,
    )


def train(config: ExperimentConfig, run_dir: Path, resume: bool, argv: list[str]) -> int:
    """Train into ``run_dir`` (new, or resumed from its last checkpoint). Returns the exit code."""
    import torch
    from stable_baselines3 import PPO

    run = RunDir(run_dir)
    torch.set_num_threads(config.runtime.torch_threads)
    command = " ".join(shlex.quote(a) for a in [sys.executable, "-m", "training.train", *argv])

    if resume:
        meta = json.loads(run.run_json.read_text())
        start_steps = run.latest_checkpoint()
        if start_steps is None:
            raise ConfigError(f"--resume: {run.checkpoints} holds no checkpoint to resume from")
        ckpt_state_path = run.checkpoints / "state.json"
        ckpt_state = json.loads(ckpt_state_path.read_text()) if ckpt_state_path.exists() else {}
        if ckpt_state.get("steps") != start_steps:
            ckpt_state = {}
        state: dict[str, Any] = {
            "start_steps": start_steps,
            "best_score": ckpt_state.get("best_score", _best_score_from_log(run, config)),
            "wall_before": ckpt_state.get("wall_time_s", 0.0),
        }
        _truncate_csv(run.progress, "time/total_timesteps", start_steps)
        _truncate_csv(run.eval_log, "timesteps", start_steps)
    else:
        run.root.mkdir(parents=True, exist_ok=True)
        save_config(config, run.config)
        meta = {
            "name": config.name,
            "seed": config.seed,
            "config": config_to_dict(config),
            "versions": _versions(),
            "git": _git_info(),
            "host": {
                "hostname": socket.gethostname(),
                "platform": platform.platform(),
                "cpu_count": os.cpu_count(),
            },
            "torch_threads": config.runtime.torch_threads,
            "sessions": [],
        }
        state = {"start_steps": 0, "best_score": None, "wall_before": 0.0}
    state["total"] = config.total_timesteps
    with open(run.command, "a") as f:
        f.write(command + "\n")

    if state["start_steps"] >= config.total_timesteps:
        print(
            f"{run.root}: already trained for {state['start_steps']} >= "
            f"{config.total_timesteps} steps; nothing to do"
        )
        return 0

    # Seeds: a resumed session reseeds its envs differently (seed + steps), so it is not a
    # bit-identical continuation, but it is deterministic given the checkpoint.
    session_seed = config.seed + state["start_steps"]
    venv = build_vec_env(config, session_seed)
    if resume:
        model_path, vn_path = run.checkpoint_paths(state["start_steps"])
        venv = _wrap_normalize(config, venv, vn_path)
        model = PPO.load(str(model_path), env=venv, device=config.runtime.device)
        print(f"resuming {run.root} from step {model.num_timesteps}")
    else:
        venv = _wrap_normalize(config, venv, None)
        model = PPO(
            "MlpPolicy",
            venv,
            seed=config.seed,
            device=config.runtime.device,
            verbose=0,
            **_ppo_kwargs(config),
        )
    model.set_random_seed(session_seed)
    model.set_logger(_make_logger(run))

    session = {
        "command": command,
        "argv": argv,
        "cwd": os.getcwd(),
        "start": _now(),
        "start_steps": state["start_steps"],
        "status": "running",
        "pid": os.getpid(),
    }
    meta["sessions"].append(session)
    _write_json(run.run_json, meta)

    callbacks = _make_callbacks(config, run, state)
    state["t_start"] = time.perf_counter()

    def on_sigterm(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    status, code = "complete", 0
    try:
        model.learn(
            total_timesteps=config.total_timesteps - state["start_steps"],
            callback=callbacks,
            reset_num_timesteps=not resume,
            progress_bar=True,
        )
    except KeyboardInterrupt:
        status, code = "interrupted", EXIT_INTERRUPTED
        steps = save_checkpoint(model, run, state)
        print(
            f"\ninterrupted: checkpoint saved at step {steps}; continue with\n  "
            f"python -m training.train {shlex.quote(str(run.config))} --run-dir "
            f"{shlex.quote(str(run.root))} --resume",
            file=sys.stderr,
        )
    finally:
        signal.signal(signal.SIGTERM, previous)
        wall = time.perf_counter() - state["t_start"]
        session.update(
            {
                "end": _now(),
                "end_steps": int(model.num_timesteps),
                "wall_time_s": round(wall, 2),
                "steps_per_s": round(
                    (model.num_timesteps - state["start_steps"]) / max(wall, 1e-9), 1
                ),
            }
        )
        if status != "interrupted" and sys.exc_info()[0] is not None:
            status, code = "failed", 1
        session["status"] = status
        meta["total_steps"] = int(model.num_timesteps)
        meta["total_wall_time_s"] = round(state["wall_before"] + wall, 2)
        meta["status"] = status
        _write_json(run.run_json, meta)
        model.logger.close()

    if status == "complete":
        run.final.mkdir(parents=True, exist_ok=True)
        model.save(run.final / "model.zip")
        vecnorm = model.get_vec_normalize_env()
        if vecnorm is not None:
            vecnorm.save(str(run.final / "vecnormalize.pkl"))
            vecnorm.save(str(run.vecnormalize))
        save_checkpoint(model, run, state)
        print(
            f"done: {model.num_timesteps} steps in {meta['total_wall_time_s']:.0f} s; "
            f"run directory {run.root}"
        )
    venv.close()
    return code


def _best_score_from_log(run: RunDir, config: ExperimentConfig) -> float | None:
    info = run.best / "info.json"
    if not info.exists():
        return None
    row = json.loads(info.read_text())
    return {
        "mean_error": lambda: -row["mean_error_mm"],
        "median_error": lambda: -row["median_error_mm"],
        "success_rate": lambda: row["success_rate"] - 1e-6 * row["mean_error_mm"],
        "mean_reward": lambda: row["mean_reward"],
    }[config.eval.best_metric]()


# -- CLI ----------------------------------------------------------------------------------------
def _parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m training.train",
        description="Train a PPO agent on a cdcr_gym env from a YAML config.",
    )
    parser.add_argument("config", help="experiment YAML, e.g. configs/ppo_ccka_reach.yaml")
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        help="run directory (default: runs/<name>_seed<S>_<timestamp>)",
    )
    parser.add_argument(
        "--total-timesteps",
        type=int,
        default=None,
        help="override total_timesteps (env steps, summed over envs)",
    )
    parser.add_argument("--seed", type=int, default=None, help="override the config's seed")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --run-dir from its last checkpoint",
    )
    return parser.parse_args(argv)


def _resolve(args: argparse.Namespace) -> tuple[ExperimentConfig, Path]:
    """The config with CLI overrides, and the run directory; raise ConfigError naming the input."""
    if args.total_timesteps is not None and args.total_timesteps <= 0:
        raise ConfigError(
            f"--total-timesteps must be a positive integer, got {args.total_timesteps}"
        )
    if args.seed is not None and args.seed < 0:
        raise ConfigError(f"--seed must be an integer >= 0, got {args.seed}")
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        raise ConfigError(f"CONFIG: {exc}") from None
    if args.seed is not None:
        config.seed = args.seed
    if args.total_timesteps is not None:
        config.total_timesteps = args.total_timesteps
    config.validate()
    _check_env_id(config)

    if args.resume:
        if args.run_dir is None:
            raise ConfigError("--resume needs --run-dir (the run to continue)")
        run = RunDir(args.run_dir)
        if not run.config.is_file() or not run.run_json.is_file():
            raise ConfigError(
                f"--run-dir {str(args.run_dir)!r} is not a training run directory "
                f"(no config.yaml / run.json)"
            )
        saved = load_config(run.config)
        if args.total_timesteps is not None:
            saved.total_timesteps = args.total_timesteps
        if args.seed is not None and args.seed != saved.seed:
            raise ConfigError(
                f"--seed {args.seed} differs from the run's seed {saved.seed}; "
                f"a resumed run keeps its seed"
            )
        # The CONFIG file must still describe this run (total_timesteps may be extended).
        mine, theirs = config_to_dict(config), config_to_dict(saved)
        mine["seed"], mine["total_timesteps"] = theirs["seed"], theirs["total_timesteps"]
        diff = sorted(
            k
            for k in _flatten(mine).keys() | _flatten(theirs).keys()
            if _flatten(mine).get(k) != _flatten(theirs).get(k)
        )
        if diff:
            raise ConfigError(
                f"CONFIG {args.config!r} differs from {run.config} in {diff}; "
                f"resume with the run's own config.yaml"
            )
        return saved.validate(), run.root
    if args.run_dir is None:
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        run_dir = Path("runs") / f"{config.name}_seed{config.seed}_{stamp}"
    else:
        run_dir = args.run_dir
    if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
        raise ConfigError(
            f"--run-dir {str(run_dir)!r} already exists and is not empty; "
            f"pass --resume to continue it, or choose another directory"
        )
    return config, run_dir


def _flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v and k != "kwargs":
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = _parse_args(argv)
    try:
        config, run_dir = _resolve(args)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        return train(config, run_dir, args.resume, argv)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
