"""Train an agent (PPO, SAC, TD3 or TQC, optionally with HER) on a cdcr_gym env from a YAML config.

Usage::

    python -m training.train CONFIG [--run-dir DIR] [--total-timesteps N] [--seed S] [--resume]

The config is validated completely before anything is written: its keys and values, the env
(made once with every ``per_env_kwargs`` entry, then closed), the algorithm's package and the
device. Any error is exit status 2 with a message naming the key, and no run directory.

The run directory (default ``runs/<name>_seed<S>_<timestamp>``) holds everything that
reproduces and documents the run:

=============================  =================================================================
``config.yaml``                the resolved config (every key; CLI overrides applied)
``run.json``                   seed, device, versions (python, numpy, torch, stable-baselines3,
                               gymnasium, cdcr_gym, pybullet), git commit, host, and one entry per
                               training session (command, start/end, steps, wall time, status)
``command.txt``                every command line that trained into this directory
``tb/``                        TensorBoard logs (``rollout/``, ``train/``, ``charts/``, ``eval/``)
``progress.csv``               the same scalars as CSV (continued, not overwritten, on resume)
``eval_log.csv``               the periodic fixed-goal evaluations
``checkpoints/``               per checkpoint at step N: ``model_N_steps.zip``,
                               ``vecnormalize_N_steps.pkl``, ``replay_buffer_N_steps.pkl``
                               (off-policy; the two newest kept) and ``state_N_steps.pkl`` (RNG
                               states, env states, sizes and hashes of the others; written last)
``best_model/``                ``model.zip`` + ``vecnormalize.pkl`` + ``info.json`` (best eval)
``final_model/``               the same at the end of training
``vecnormalize.pkl``           the final VecNormalize statistics
``learning_curve.png``         eval success rate and tip error, and training return, vs steps
=============================  =================================================================

Checkpoints are taken between an update and the next rollout, every file written to a
temporary name and renamed, the state file last. ``--resume`` continues from the newest
checkpoint that is complete and loads (falling back to older ones, or to a fresh start in the
same directory if there is none), restoring the model, optimiser, schedule progress, update
counter, VecNormalize statistics and running returns, the replay buffer, every training env's
state and the python/numpy/torch RNGs: on CPU, a run killed at any moment and resumed ends
with the same final model, bit for bit, as an uninterrupted one (see docs/training.md).

Ctrl-C (SIGINT) or SIGTERM: the run stops at the next rollout boundary after saving a
checkpoint there; a second one stops at once (the previous checkpoint stays). Either way the
exit status is 130, with a one-line message and no traceback.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import json
import os
import pickle
import platform
import random
import re
import shlex
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from training.run.config import (
    OFF_POLICY,
    ConfigError,
    ExperimentConfig,
    OffPolicyConfig,
    SACConfig,
    TD3Config,
    TQCConfig,
    check_writable_directory,
    config_to_dict,
    load_config,
    save_config,
)

__all__ = ["main", "train", "build_vec_env", "check_env_config", "RunDir", "Checkpoint"]

EXIT_INTERRUPTED = 130
#: Files a training session writes into a run directory (removed when a run restarts afresh).
_ARTEFACTS = (
    "tb",
    "progress.csv",
    "eval_log.csv",
    "checkpoints",
    "best_model",
    "final_model",
    "vecnormalize.pkl",
    "learning_curve.png",
)
#: Off-policy checkpoints keep their (large) replay buffer for the newest this many.
_KEEP_REPLAY_BUFFERS = 2


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

    def replay_buffer_path(self, steps: int) -> Path:
        return self.checkpoints / f"replay_buffer_{steps}_steps.pkl"

    def state_path(self, steps: int) -> Path:
        return self.checkpoints / f"state_{steps}_steps.pkl"

    def checkpoint_steps(self) -> list[int]:
        """Step counts that have a checkpoint state file, newest first (not yet validated)."""
        steps = []
        for path in self.checkpoints.glob("state_*_steps.pkl"):
            m = re.fullmatch(r"state_(\d+)_steps\.pkl", path.name)
            if m:
                steps.append(int(m.group(1)))
        return sorted(steps, reverse=True)

    def latest_checkpoint(self) -> int | None:
        """Step count of the newest complete checkpoint (see :meth:`Checkpoint.read`), or None."""
        for steps in self.checkpoint_steps():
            try:
                Checkpoint.read(self, steps)
            except CheckpointError:
                continue
            return steps
        return None


class CheckpointError(Exception):
    """A checkpoint that is incomplete or corrupt (the message names the file)."""


def _sha256(path: Path) -> str:
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _atomic(path: Path, write: Callable[[Path], None]) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``: a kill leaves the old file or none."""
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    write(tmp)
    os.replace(tmp, path)


class Checkpoint:
    """The state file of one checkpoint: what :func:`save_checkpoint` stored besides the model.

    Attributes:
        steps: environment steps at the checkpoint.
        data: ``files`` (name -> size, sha256), ``rng`` (python, numpy, torch, action space),
            ``envs`` (pickled training-env states, or None), ``vecnormalize_returns``,
            ``best_score``, ``wall_time_s``, ``last_eval_step``.
    """

    def __init__(self, steps: int, data: dict[str, Any]) -> None:
        self.steps = steps
        self.data = data

    @classmethod
    def read(cls, run: RunDir, steps: int) -> Checkpoint:
        """Load and validate checkpoint ``steps``: every file present with its recorded size and
        hash. Raises :class:`CheckpointError` naming the bad file."""
        path = run.state_path(steps)
        try:
            with open(path, "rb") as f:
                data = pickle.load(f)
            files = data["files"]
        except Exception as exc:  # noqa: BLE001 - truncated/foreign: many exception types
            raise CheckpointError(f"{path}: unreadable ({type(exc).__name__}: {exc})") from None
        for name, (size, digest) in files.items():
            file = run.checkpoints / name
            if not file.is_file():
                raise CheckpointError(f"{file}: missing")
            if file.stat().st_size != size or _sha256(file) != digest:
                raise CheckpointError(f"{file}: truncated or modified (size/hash differ)")
        return cls(steps, data)


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
    repo = Path(__file__).resolve().parents[2]
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
def _snapshot_wrapper() -> type:
    import gymnasium as gym

    class EnvSnapshot(gym.Wrapper):  # type: ignore[type-arg]
        """Outermost wrapper of a training env: its whole state (wrappers, RNG, robot) as bytes.

        ``get_snapshot()`` is None if the env cannot be pickled (then a resume reseeds the envs
        instead of restoring them). Called through ``VecEnv.env_method``, so it works in
        ``SubprocVecEnv`` workers too."""

        def get_snapshot(self) -> bytes | None:
            import cloudpickle

            try:
                return bytes(cloudpickle.dumps(self.env))
            except Exception:  # noqa: BLE001 - e.g. a pybullet client: not restorable
                return None

        def set_snapshot(self, blob: bytes) -> None:
            self.env.close()
            self.env = pickle.loads(blob)

    return EnvSnapshot


def _ignore_sigint() -> None:
    """In a SubprocVecEnv worker: Ctrl-C is the main process's to handle (no BrokenPipeError)."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def build_vec_env(config: ExperimentConfig, seed: int, n_envs: int | None = None) -> Any:
    """The training VecEnv (Monitor-wrapped, not yet normalised), seeded with ``seed``."""
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    from training.evaluate.rollout import make_env

    e = config.env
    n = e.n_envs if n_envs is None else n_envs
    if e.vec_env == "batched":
        try:
            from training.run.sb3_vec import BatchedCCKAVecEnv
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
        except (ValueError, TypeError) as exc:
            raise ConfigError(f"env (vec_env: batched): {exc}") from None
        return VecMonitor(venv)

    snapshot = _snapshot_wrapper()
    subproc = e.vec_env == "subproc"

    def factory(rank: int) -> Callable[[], Any]:
        def _init() -> Any:
            if subproc:
                _ignore_sigint()
            kwargs = dict(e.kwargs)
            if e.per_env_kwargs:
                kwargs.update(e.per_env_kwargs[rank % len(e.per_env_kwargs)])
            env = make_env(e.id, kwargs, e.max_episode_steps)
            env = Monitor(env)
            env.reset(seed=seed + rank)
            env.action_space.seed(seed + rank)
            return snapshot(env)

        return _init

    fns = [factory(i) for i in range(n)]
    if subproc and threading.current_thread() is threading.main_thread():
        # Workers inherit an ignored SIGINT (a terminal's Ctrl-C reaches the whole group).
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            venv: Any = SubprocVecEnv(fns)
        finally:
            signal.signal(signal.SIGINT, previous)
    elif subproc:
        venv = SubprocVecEnv(fns)
    else:
        venv = DummyVecEnv(fns)
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

    known = sorted(k for k in gym.registry if k.startswith("cdcr_gym/"))
    if config.env.id not in gym.registry:
        raise ConfigError(f"env.id {config.env.id!r} is not registered; known ids: {known}")
    entry = gym.registry[config.env.id].entry_point
    if not (isinstance(entry, str) and entry.startswith("cdcr_gym.")):
        raise ConfigError(
            f"env.id {config.env.id!r} is not a cdcr_gym env (entry point {entry!r}); "
            f"training.train trains the cdcr_gym envs: {known}"
        )


def check_env_config(config: ExperimentConfig) -> None:
    """Make the env once per distinct kwargs (``env.kwargs`` updated by each
    ``env.per_env_kwargs`` entry), reset and close it, and check the algorithm's package and the
    device; raise :class:`ConfigError` naming the key. Called before the run directory exists."""
    from training.evaluate.rollout import algo_class, make_env

    _check_env_id(config)
    e = config.env
    cases = [("env.kwargs", dict(e.kwargs))]
    cases += [
        (f"env.per_env_kwargs[{i}]", {**e.kwargs, **extra})
        for i, extra in enumerate(e.per_env_kwargs)
    ]
    for key, kwargs in cases:
        params = kwargs.get("params")
        if params is not None and not isinstance(params, dict):
            raise ConfigError(
                f"{key}.params must be a mapping of RobotParams fields, got {params!r}"
            )
        if isinstance(params, dict):
            from cdcr_gym.params import RobotParams

            try:
                RobotParams(**params)
            except (TypeError, ValueError) as exc:
                raise ConfigError(f"{key}.params: {exc}") from None
        try:
            env = make_env(e.id, kwargs, e.max_episode_steps)
            try:
                env.reset(seed=config.seed)
            finally:
                env.close()
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{key}: cannot make {e.id!r} with {kwargs}: {exc}") from None
    if e.vec_env == "batched":
        build_vec_env(config, config.seed, n_envs=1).close()
    try:
        algo_class(config.algo)
    except ImportError as exc:
        raise ConfigError(str(exc)) from None
    _resolve_device(config.runtime.device)


def _resolve_device(device: str) -> str:
    """The torch device a run uses: ``auto`` is cuda if available else cpu; cuda (or cuda:N)
    without a usable GPU is a :class:`ConfigError` (rather than silently training on the CPU)."""
    import torch

    if device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if device.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ConfigError(
                f"runtime.device: {device!r}, but torch sees no CUDA GPU "
                f"(torch {torch.__version__}); use cpu or auto"
            )
        index = int(device.split(":")[1]) if ":" in device else 0
        if index >= torch.cuda.device_count():
            raise ConfigError(
                f"runtime.device: {device!r}, but torch sees {torch.cuda.device_count()} GPU(s)"
            )
    return device


# -- callbacks ----------------------------------------------------------------------------------
def _make_callbacks(config: ExperimentConfig, run: RunDir, state: dict[str, Any]) -> list[Any]:
    from stable_baselines3.common.callbacks import BaseCallback

    from training.evaluate.rollout import (
        SB3Policy,
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
            optimizer = getattr(self.model.policy, "optimizer", None)
            if optimizer is None:  # SAC/TD3/TQC: one optimiser per network
                optimizer = self.model.actor.optimizer
            self.logger.record("charts/learning_rate", optimizer.param_groups[0]["lr"])

    class CheckpointCallback(BaseCallback):
        """Every ``checkpoint.freq`` env steps, at the next rollout start (after the update of
        the previous rollout, so nothing is half done): a checkpoint. A stop request (Ctrl-C,
        SIGTERM) also checkpoints there, then ends training at the next step."""

        def __init__(self) -> None:
            super().__init__()
            self.next_at = (
                state["start_steps"] // config.checkpoint.freq + 1
            ) * config.checkpoint.freq

        def _on_rollout_start(self) -> None:
            due = self.num_timesteps >= self.next_at
            if due or (state["stop_requested"] and not state["stopped"]):
                if state.get("last_checkpoint") != self.num_timesteps:
                    save_checkpoint(self.model, run, state)
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.checkpoint.freq
            if state["stop_requested"]:
                state["stopped"] = True

        def _on_step(self) -> bool:
            return not state["stopped"]

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
            from training.evaluate.metrics import run_task_episodes

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
            policy = SB3Policy.from_model(self.model, vecnorm)
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
                _save_model_dir(self.model, run.best)
                _write_json(run.best / "info.json", {**row, "best_metric": metric})
                self.logger.record("eval/best_step", self.num_timesteps)

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at and not state["stop_requested"]:
                self._evaluate()
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.eval.freq
            return True

        def _on_training_end(self) -> None:
            # Always evaluate the final weights too (the best model may be the last one).
            if (
                state.get("last_eval_step") != self.num_timesteps
                and not state["stop_requested"]
                and (self.num_timesteps >= state["total"] or state.get("stopped_by_wall_time"))
            ):
                self._evaluate()

    class WallTimeCallback(BaseCallback):
        """Stops training once ``runtime.max_wall_time_s`` of training wall time has passed."""

        def _on_step(self) -> bool:
            limit = config.runtime.max_wall_time_s
            elapsed = state["wall_before"] + time.perf_counter() - state["t_start"]
            if limit is not None and elapsed >= limit:
                state["stopped_by_wall_time"] = True
                return False
            return True

    # The wall-time check runs last, so the step that hits the limit is still logged/evaluated.
    return [StatsCallback(), CheckpointCallback(), EvalCallback(), WallTimeCallback()]


def _registered_steps(env_id: str) -> int:
    import gymnasium as gym

    return gym.registry[env_id].max_episode_steps or 100


def _save_model_dir(model: Any, directory: Path) -> None:
    """``model.zip`` and ``vecnormalize.pkl`` into ``directory``, each written atomically."""
    directory.mkdir(parents=True, exist_ok=True)
    _atomic(directory / "model.zip", lambda tmp: model.save(tmp))
    vecnorm = model.get_vec_normalize_env()
    if vecnorm is not None:
        _atomic(directory / "vecnormalize.pkl", lambda tmp: vecnorm.save(str(tmp)))


def _env_snapshot(venv_base: Any) -> dict[str, Any] | None:
    """The training envs' state (below VecNormalize), or None if they cannot be pickled."""
    import cloudpickle
    from stable_baselines3.common.vec_env import VecMonitor

    if isinstance(venv_base, VecMonitor):  # the batched env: one in-process object
        batched = venv_base.venv
        try:
            blob = cloudpickle.dumps(
                {
                    "vector": batched.venv,  # the CDCRVectorEnv: robots, goals, RNGs, counters
                    "vec_attrs": {k: getattr(batched, k) for k in _BATCHED_ATTRS},
                    "monitor": {k: getattr(venv_base, k) for k in _MONITOR_ATTRS},
                }
            )
        except Exception:  # noqa: BLE001
            return None
        return {"kind": "vec", "blob": bytes(blob)}
    blobs = venv_base.env_method("get_snapshot")
    if any(b is None for b in blobs):
        return None
    return {"kind": "per_env", "blobs": blobs}


def _pending_log(logger: Any) -> dict[str, Any]:
    def plain(value: Any) -> Any:
        return value.item() if isinstance(value, np.generic) else value

    return {
        "values": {k: plain(v) for k, v in logger.name_to_value.items() if _picklable(v)},
        "counts": dict(logger.name_to_count),
        "excluded": dict(logger.name_to_excluded),
    }


def _picklable(value: Any) -> bool:
    return isinstance(value, (int, float, str, np.number))


_BATCHED_ATTRS = ("reset_infos", "_seeds", "_options", "_actions")
_MONITOR_ATTRS = ("episode_returns", "episode_lengths", "episode_count")


def _rng_state(model: Any) -> dict[str, Any]:
    import torch

    return {
        "python": random.getstate(),
        "numpy": np.random.get_state(),  # noqa: NPY002 - SB3 draws from the legacy global RNG
        "torch": torch.get_rng_state().numpy().copy(),
        "action_space": model.action_space.np_random.bit_generator.state,
    }


def _set_rng_state(model: Any, rng: dict[str, Any]) -> None:
    import torch

    random.setstate(rng["python"])
    np.random.set_state(rng["numpy"])  # noqa: NPY002
    torch.set_rng_state(torch.from_numpy(rng["torch"]))
    model.action_space.np_random.bit_generator.state = rng["action_space"]


def save_checkpoint(model: Any, run: RunDir, state: dict[str, Any]) -> int:
    """Save a complete checkpoint at the model's step count; return the step count.

    Model, VecNormalize, replay buffer (off-policy) and then the state file (RNG and env states,
    VecNormalize's running returns, sizes and hashes of the other files), each written to a
    temporary name and renamed: killed at any moment, the directory holds the previous
    checkpoints intact and at most an incomplete newest one, which ``--resume`` skips."""
    steps = int(model.num_timesteps)
    run.checkpoints.mkdir(parents=True, exist_ok=True)
    model_path, vn_path = run.checkpoint_paths(steps)
    vecnorm = model.get_vec_normalize_env()
    paths = [model_path]
    _atomic(model_path, lambda tmp: model.save(tmp))
    if vecnorm is not None:
        _atomic(vn_path, lambda tmp: vecnorm.save(str(tmp)))
        paths.append(vn_path)
    if hasattr(model, "replay_buffer") and model.replay_buffer is not None:
        rb_path = run.replay_buffer_path(steps)
        _atomic(rb_path, lambda tmp: model.save_replay_buffer(tmp))
        paths.append(rb_path)
    envs = _env_snapshot(state["venv_base"])
    if envs is None and not state.get("warned_snapshot"):
        state["warned_snapshot"] = True
        print(
            "warning: the training envs cannot be pickled; a resumed run reseeds them "
            "(deterministic, but not bit-identical to an uninterrupted run)",
            file=sys.stderr,
        )
    data = {
        "format": 1,
        "steps": steps,
        "algo": state["algo"],
        "files": {p.name: (p.stat().st_size, _sha256(p)) for p in paths},
        "rng": _rng_state(model),
        "envs": envs,
        "vecnormalize_returns": None if vecnorm is None else vecnorm.returns.copy(),
        "best_score": state.get("best_score"),
        "last_eval_step": state.get("last_eval_step"),
        "wall_time_s": state["wall_before"] + time.perf_counter() - state["t_start"],
        # values recorded (e.g. train/* of the update just done) but not yet written to the logs
        "pending_log": _pending_log(model.logger),
    }
    _atomic(run.state_path(steps), lambda tmp: tmp.write_bytes(pickle.dumps(data)))
    state["last_checkpoint"] = steps
    # Replay buffers are large: only the newest few off-policy checkpoints stay resumable (older
    # ones keep their model and statistics, as a history).
    for old in run.checkpoint_steps()[_KEEP_REPLAY_BUFFERS:]:
        if old < steps and run.replay_buffer_path(old).exists():
            run.state_path(old).unlink(missing_ok=True)
            run.replay_buffer_path(old).unlink()
    try:
        from training.evaluate.plots import plot_learning_curve

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


# -- algorithms ---------------------------------------------------------------------------------
_ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU"}


def _ppo_kwargs(config: ExperimentConfig) -> dict[str, Any]:
    import torch
    from stable_baselines3.common.utils import LinearSchedule

    p = config.ppo
    lr: Any = p.learning_rate
    if p.lr_schedule == "linear":
        lr = LinearSchedule(p.learning_rate, 0.0, 1.0)
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
            "activation_fn": getattr(torch.nn, _ACTIVATIONS[p.policy.activation]),
            "log_std_init": p.policy.log_std_init,
            "ortho_init": p.policy.ortho_init,
        },
    }


def _off_policy_kwargs(config: ExperimentConfig, action_dim: int) -> dict[str, Any]:
    """SAC/TD3/TQC constructor arguments from the config's section of ``config.algo``."""
    import torch
    from stable_baselines3 import HerReplayBuffer
    from stable_baselines3.common.noise import NormalActionNoise
    from stable_baselines3.common.utils import LinearSchedule

    c = config.algo_config
    if not isinstance(c, OffPolicyConfig):  # pragma: no cover - validate() guarantees it
        raise ConfigError(f"algo: {config.algo} is not an off-policy algorithm")
    lr: Any = c.learning_rate
    if c.lr_schedule == "linear":
        lr = LinearSchedule(c.learning_rate, 0.0, 1.0)
    policy_kwargs: dict[str, Any] = {
        "net_arch": list(c.policy.net_arch),
        "activation_fn": getattr(torch.nn, _ACTIVATIONS[c.policy.activation]),
    }
    kwargs: dict[str, Any] = {
        "learning_rate": lr,
        "buffer_size": c.buffer_size,
        "learning_starts": c.learning_starts,
        "batch_size": c.batch_size,
        "tau": c.tau,
        "gamma": c.gamma,
        "train_freq": c.train_freq,
        "gradient_steps": c.gradient_steps,
        "policy_kwargs": policy_kwargs,
    }
    if c.her.enabled:
        kwargs["replay_buffer_class"] = HerReplayBuffer
        kwargs["replay_buffer_kwargs"] = {
            "n_sampled_goal": c.her.n_sampled_goal,
            "goal_selection_strategy": c.her.goal_selection_strategy,
        }
    if isinstance(c, (SACConfig, TQCConfig)):
        kwargs["ent_coef"] = "auto" if c.ent_coef is None else c.ent_coef
    if isinstance(c, TD3Config):
        kwargs["action_noise"] = NormalActionNoise(
            np.zeros(action_dim), np.full(action_dim, c.action_noise_std)
        )
        kwargs["policy_delay"] = c.policy_delay
        kwargs["target_policy_noise"] = c.target_policy_noise
        kwargs["target_noise_clip"] = c.target_noise_clip
    if isinstance(c, TQCConfig):
        kwargs["top_quantiles_to_drop_per_net"] = c.top_quantiles_to_drop_per_net
        policy_kwargs["n_quantiles"] = c.n_quantiles
        policy_kwargs["n_critics"] = c.n_critics
    return kwargs


def _make_model(config: ExperimentConfig, venv: Any, device: str) -> Any:
    """A new model of ``config.algo`` on ``venv`` (seeded with ``config.seed``)."""
    from training.evaluate.rollout import algo_class

    cls = algo_class(config.algo)
    goal_conditioned = bool(config.env.kwargs.get("goal_conditioned"))
    policy = "MultiInputPolicy" if goal_conditioned else "MlpPolicy"
    if config.algo == "ppo":
        kwargs = _ppo_kwargs(config)
    else:
        kwargs = _off_policy_kwargs(config, int(np.prod(venv.action_space.shape)))
    return cls(policy, venv, seed=config.seed, device=device, verbose=0, **kwargs)


def _gamma(config: ExperimentConfig) -> float:
    return float(config.algo_config.gamma)


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
        gamma=_gamma(config),
    )


def _restore(
    config: ExperimentConfig, run: RunDir, ckpt: Checkpoint, device: str
) -> tuple[Any, Any, Any]:
    """(model, VecNormalize-wrapped venv, base venv) exactly as at checkpoint ``ckpt``.

    Raises on any failure (the caller falls back to an older checkpoint)."""
    from training.evaluate.rollout import algo_class

    steps = ckpt.steps
    envs = ckpt.data["envs"]
    # Envs that could not be pickled are reseeded from (seed, steps): a deterministic
    # continuation, on seeds that are not the evaluation's (those are seed + i, i small).
    seed = config.seed if envs is not None else fallback_env_seed(config.seed, steps)
    base = build_vec_env(config, seed)
    try:
        if envs is not None and envs["kind"] == "per_env":
            for i, blob in enumerate(envs["blobs"]):
                base.env_method("set_snapshot", blob, indices=[i])
        elif envs is not None and envs["kind"] == "vec":
            saved = pickle.loads(envs["blob"])
            base.venv.venv.close()
            base.venv.venv = saved["vector"]
            for key, value in saved["vec_attrs"].items():
                setattr(base.venv, key, value)
            for key, value in saved["monitor"].items():
                setattr(base, key, value)
        model_path, vn_path = run.checkpoint_paths(steps)
        venv = _wrap_normalize(config, base, vn_path if vn_path.exists() else None)
        if ckpt.data["vecnormalize_returns"] is not None:
            venv.returns = ckpt.data["vecnormalize_returns"].copy()
        model = algo_class(config.algo).load(
            str(model_path), env=venv, device=device, force_reset=envs is None
        )
        if config.algo in OFF_POLICY:
            # HER: the unfinished episodes continue (not truncated as for a new session).
            model.load_replay_buffer(run.replay_buffer_path(steps), truncate_last_traj=False)
    except BaseException:
        base.close()
        raise
    return model, venv, base


def fallback_env_seed(seed: int, steps: int) -> int:
    """Seed of training envs that a resume at ``steps`` cannot restore (not picklable).

    Hashed from (seed, steps) into [2**31, 2**32 - n_envs): unlike the former ``seed + steps``
    it never lands on evaluation goals (``eval.seed + i``, ``evaluate.seed + i``, below 2**31
    for any sensible config) nor on the first session's ``seed + rank``."""
    h = int(np.random.SeedSequence([seed, steps]).generate_state(1, dtype=np.uint32)[0])
    return 2**31 + h % (2**31 - 2**16)


def _load_newest(
    config: ExperimentConfig, run: RunDir, device: str
) -> tuple[Checkpoint, Any, Any, Any] | None:
    """(checkpoint, model, venv, base venv) of the newest checkpoint that is complete and loads;
    older ones are tried when a newer one is truncated or corrupt (a warning each). None if the
    run has no checkpoint at all; :class:`ConfigError` if it has some but none loads (nothing
    is deleted)."""
    tried = run.checkpoint_steps() if run.checkpoints.is_dir() else []
    for steps in tried:
        try:
            ckpt = Checkpoint.read(run, steps)
            model, venv, base = _restore(config, run, ckpt, device)
        except Exception as exc:  # noqa: BLE001 - a corrupt file fails in many ways
            print(f"warning: skipping checkpoint {steps}: {exc}", file=sys.stderr)
            continue
        return ckpt, model, venv, base
    if tried:
        raise ConfigError(
            f"--resume: none of the checkpoints {tried} in {run.checkpoints} loads "
            f"(warnings above); nothing was changed"
        )
    return None


def _clear_artefacts(run: RunDir) -> None:
    """Remove what a previous session wrote (a restart afresh of a run without a checkpoint)."""
    import shutil

    for name in _ARTEFACTS:
        path = run.root / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def train(
    config: ExperimentConfig,
    run_dir: Path,
    resume: bool,
    argv: list[str],
    *,
    exiting: bool = False,
) -> int:
    """Train into ``run_dir`` (new, or resumed from its last checkpoint). Returns the exit code.

    ``config`` must have passed :func:`check_env_config`. ``exiting`` (the command line): the
    process ends after this call, so once a stop was signalled further SIGINT/SIGTERM are ignored
    instead of the previous handlers being restored — a second Ctrl-C while the interpreter
    shuts down would otherwise kill it by the signal instead of exiting 130."""
    import torch

    run = RunDir(run_dir)
    torch.set_num_threads(config.runtime.torch_threads)
    device = _resolve_device(config.runtime.device)
    command = " ".join(shlex.quote(a) for a in ["python", "-m", "training.train", *argv])
    state: dict[str, Any] = {
        "algo": config.algo,
        "total": config.total_timesteps,
        "stop_requested": False,
        "stopped": False,
    }

    # Ctrl-C / SIGTERM: the first asks for a stop at the next rollout boundary (after a
    # checkpoint), the second stops at once; either way exit 130 without a traceback.
    def on_signal(signum: int, frame: Any) -> None:
        if state["stopped"]:  # already past the last checkpoint and winding down: nothing to gain
            return
        if state["stop_requested"]:
            raise KeyboardInterrupt
        state["stop_requested"] = True
        print(
            f"\n{signal.Signals(signum).name}: stopping after a checkpoint at the next rollout "
            f"boundary (again to stop now)",
            file=sys.stderr,
            flush=True,
        )

    # Signal handlers can only be installed from the main thread (a sweep may train in another).
    in_main = threading.current_thread() is threading.main_thread()
    sigs = (signal.SIGINT, signal.SIGTERM) if in_main else ()
    previous = {sig: signal.signal(sig, on_signal) for sig in sigs}
    try:
        return _train(config, run, resume, argv, command, device, state)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_IGN if exiting and state["stop_requested"] else handler)


def _train(
    config: ExperimentConfig,
    run: RunDir,
    resume: bool,
    argv: list[str],
    command: str,
    device: str,
    state: dict[str, Any],
) -> int:
    restored = _load_newest(config, run, device) if resume else None
    ckpt = restored[0] if restored is not None else None
    meta: dict[str, Any] | None = None
    if run.run_json.is_file():
        try:
            meta = json.loads(run.run_json.read_text())
        except ValueError:
            meta = None
    if ckpt is None:
        if run.root.exists():  # a restart, or a resume with no checkpoint yet: afresh
            if resume or run.config.exists():
                print(f"{run.root}: no checkpoint; training it afresh from step 0")
            _clear_artefacts(run)
        run.root.mkdir(parents=True, exist_ok=True)
        save_config(config, run.config)
        sessions = (meta or {}).get("sessions", [])
        meta = {
            "name": config.name,
            "algo": config.algo,
            "seed": config.seed,
            "device": device,
            "config": config_to_dict(config),
            "versions": _versions(),
            "git": _git_info(),
            "host": {
                "hostname": socket.gethostname(),
                "platform": platform.platform(),
                "cpu_count": os.cpu_count(),
            },
            "torch_threads": config.runtime.torch_threads,
            "sessions": [{**s, "discarded": True} for s in sessions],
        }
        state.update({"start_steps": 0, "best_score": None, "wall_before": 0.0})
    else:
        if meta is None:
            meta = {"name": config.name, "algo": config.algo, "seed": config.seed, "sessions": []}
        meta["device"] = device
        state.update(
            {
                "start_steps": ckpt.steps,
                "best_score": ckpt.data.get("best_score"),
                "last_eval_step": ckpt.data.get("last_eval_step"),
                "last_checkpoint": ckpt.steps,
                "wall_before": ckpt.data.get("wall_time_s", 0.0),
            }
        )
        _truncate_csv(run.progress, "time/total_timesteps", ckpt.steps)
        _truncate_csv(run.eval_log, "timesteps", ckpt.steps)
    with open(run.command, "a") as f:
        f.write(command + "\n")

    if state["start_steps"] >= config.total_timesteps:
        print(
            f"{run.root}: already trained for {state['start_steps']} >= "
            f"{config.total_timesteps} steps; nothing to do"
        )
        if restored is not None:
            _close_quietly(restored[2])
        return 0

    if restored is None:
        base = build_vec_env(config, config.seed)
        venv = _wrap_normalize(config, base, None)
        model = _make_model(config, venv, device)
        model.set_random_seed(config.seed)
    else:
        _, model, venv, base = restored
        print(f"resuming {run.root} from step {model.num_timesteps}")
    state["venv_base"] = base
    model.set_logger(_make_logger(run))

    session: dict[str, Any] = {
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

    from stable_baselines3.common.callbacks import ProgressBarCallback

    progress = ProgressBarCallback()  # ours, to close it on an interrupt (no shutdown noise)
    callbacks = [*_make_callbacks(config, run, state), progress]
    if ckpt is not None:
        pending = ckpt.data.get("pending_log") or {}
        model.logger.name_to_value.update(pending.get("values", {}))
        model.logger.name_to_count.update(pending.get("counts", {}))
        model.logger.name_to_excluded.update(pending.get("excluded", {}))
        # last: nothing between here and learn() may draw random numbers
        _set_rng_state(model, ckpt.data["rng"])
    state["t_start"] = time.perf_counter()
    status, code = "complete", 0
    try:
        model.learn(
            total_timesteps=config.total_timesteps - state["start_steps"],
            callback=callbacks,
            reset_num_timesteps=ckpt is None,
        )
        if state["stopped"]:
            status, code = "interrupted", EXIT_INTERRUPTED
    except KeyboardInterrupt:  # a second Ctrl-C: stop now, the last checkpoint stays
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
        status, code = "interrupted", EXIT_INTERRUPTED
    finally:
        if getattr(progress, "pbar", None) is not None:
            progress.pbar.close()
        wall = time.perf_counter() - state["t_start"]
        if status != "interrupted" and sys.exc_info()[0] is not None:
            status, code = "failed", 1
        steps_now = int(state.get("last_checkpoint", 0) if status == "interrupted" else 0)
        session.update(
            {
                "end": _now(),
                "end_steps": int(model.num_timesteps),
                "wall_time_s": round(wall, 2),
                "steps_per_s": round(
                    (model.num_timesteps - state["start_steps"]) / max(wall, 1e-9), 1
                ),
                "status": status,
            }
        )
        if status == "interrupted":
            session["resumable_from_step"] = steps_now
        meta["total_steps"] = int(model.num_timesteps)
        meta["total_wall_time_s"] = round(state["wall_before"] + wall, 2)
        meta["status"] = status
        if state.get("stopped_by_wall_time"):
            meta["stopped_by"] = "runtime.max_wall_time_s"
        _write_json(run.run_json, meta)
        model.logger.close()
        if status != "complete":
            _close_quietly(venv)

    if status == "interrupted":
        where = (
            f"from the checkpoint at step {steps_now}"
            if "last_checkpoint" in state
            else "from step 0 (no checkpoint yet)"
        )
        print(
            f"interrupted at step {model.num_timesteps}; continue {where} with: "
            f"python -m training.train {shlex.quote(str(run.config))} --run-dir "
            f"{shlex.quote(str(run.root))} --resume",
            file=sys.stderr,
        )
        return code

    _save_model_dir(model, run.final)
    vecnorm = model.get_vec_normalize_env()
    if vecnorm is not None:
        _atomic(run.vecnormalize, lambda tmp: vecnorm.save(str(tmp)))
    if state.get("last_checkpoint") != model.num_timesteps:
        save_checkpoint(model, run, state)
    print(
        f"done: {model.num_timesteps} steps in {meta['total_wall_time_s']:.0f} s; "
        f"run directory {run.root}"
    )
    _close_quietly(venv)
    if state["stop_requested"]:  # the signal came during the last rollout: complete, but 130
        print(f"interrupted after training completed; {run.root} is complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    return code


def _close_quietly(venv: Any) -> None:
    """Close the training envs; after an interrupt a subprocess may already be gone."""
    from stable_baselines3.common.vec_env import SubprocVecEnv

    try:
        venv.close()
    except Exception:  # noqa: BLE001
        base = venv.unwrapped if hasattr(venv, "unwrapped") else venv
        if isinstance(base, SubprocVecEnv):
            for process in base.processes:
                process.terminate()


# -- CLI ----------------------------------------------------------------------------------------
def _parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m training.train",
        description="Train an agent (PPO, SAC, TD3, TQC) on a cdcr_gym env from a YAML config.",
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
    """The config with CLI overrides, and the run directory; raise ConfigError naming the input.

    Everything is checked here, before the run directory is created: the config, the env (made
    once), the algorithm's package and the device."""
    from training.run.config import MAX_SEED

    if args.total_timesteps is not None and args.total_timesteps <= 0:
        raise ConfigError(
            f"--total-timesteps must be a positive integer, got {args.total_timesteps}"
        )
    if args.seed is not None and not 0 <= args.seed <= MAX_SEED:
        raise ConfigError(f"--seed must be an integer in [0, 2**32 - 1], got {args.seed}")
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        raise ConfigError(f"CONFIG: {exc}") from None
    if args.seed is not None:
        config.seed = args.seed
    if args.total_timesteps is not None:
        config.total_timesteps = args.total_timesteps
    config.validate()
    check_env_config(config)

    if args.resume:
        if args.run_dir is None:
            raise ConfigError("--resume needs --run-dir (the run to continue)")
        run = RunDir(args.run_dir)
        if not run.config.is_file():
            raise ConfigError(
                f"--run-dir {str(args.run_dir)!r} is not a training run directory (no config.yaml)"
            )
        _refuse_legacy(run)
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
        flat_mine, flat_theirs = _flatten(mine), _flatten(theirs)
        diff = sorted(
            k
            for k in flat_mine.keys() | flat_theirs.keys()
            if flat_mine.get(k) != flat_theirs.get(k)
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
    check_writable_directory(run_dir, "--run-dir")
    if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
        run = RunDir(run_dir)
        restartable = run_dir.is_dir() and run.config.is_file() and run.latest_checkpoint() is None
        if restartable:
            _refuse_legacy(run)
        else:
            raise ConfigError(
                f"--run-dir {str(run_dir)!r} already exists and is not empty; "
                f"pass --resume to continue it, or choose another directory"
            )
    return config, run_dir


def _refuse_legacy(run: RunDir) -> None:
    """A run directory of the previous checkpoint format (``checkpoints/state.json``, no state
    files) is neither resumed nor restarted over: its checkpoints would be discarded."""
    if (run.checkpoints / "state.json").is_file() and not run.checkpoint_steps():
        raise ConfigError(
            f"--run-dir {str(run.root)!r} holds checkpoints of an older format (no "
            f"state_N_steps.pkl), which cannot be resumed exactly and would be discarded; "
            f"train into another --run-dir"
        )


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
        return train(config, run_dir, args.resume, argv, exiting=True)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # before training started, or a second Ctrl-C while finishing
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
