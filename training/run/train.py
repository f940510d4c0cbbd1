"""Train an agent (PPO, SAC, TD3 or TQC, optionally with HER) on a cdcr_gym env from a YAML config.

Usage::

    python -m training.run.train CONFIG [--run-dir DIR] [--total-timesteps N] [--seed S] [--resume]

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
import platform
import shlex
import signal
import socket
import sys
import threading
import time
from pathlib import Path
from typing import Any

from training.run.algorithms import make_model, wrap_normalize
from training.run.argtypes import non_negative_int, positive_int
from training.run.callbacks import make_callbacks
from training.run.checkpoints import (
    fallback_env_seed,
    load_newest_checkpoint,
    save_checkpoint,
    save_model_dir,
    set_rng_state,
)
from training.run.config import (
    MAX_SEED,
    ConfigError,
    ExperimentConfig,
    check_writable_directory,
    config_to_dict,
    load_config,
    save_config,
)
from training.run.demonstrations import check_demonstrations, pretrain
from training.run.envs import build_vec_env, check_env_config, resolve_device
from training.run.logs import make_logger, truncate_csv
from training.run.provenance import git_info, now_iso, versions, write_json
from training.run.rundir import (
    LOCK_NAME,
    Checkpoint,
    CheckpointError,
    RunDir,
    RunLock,
    atomic_write,
    clear_artefacts,
    refuse_legacy,
)
from training.run.stop_signal import stop_signal_handler

# (RunDir, Checkpoint, build_vec_env, check_env_config, fallback_env_seed: re-exported from the
# modules they moved to, for code that imports them from here)
__all__ = [
    "main",
    "train",
    "build_vec_env",
    "check_env_config",
    "RunDir",
    "Checkpoint",
    "CheckpointError",
    "fallback_env_seed",
    "save_checkpoint",
]

EXIT_INTERRUPTED = 130


def train(
    config: ExperimentConfig,
    run_dir: Path,
    resume: bool,
    argv: list[str],
    *,
    exiting: bool = False,
    verbose: bool = False,
) -> int:
    """Train into ``run_dir`` (new, or resumed from its last checkpoint). Returns the exit code.

    ``config`` must have passed :func:`check_env_config`. ``exiting`` (the command line): the
    process ends after this call, so once a stop was signalled further SIGINT/SIGTERM are ignored
    instead of the previous handlers being restored — a second Ctrl-C while the interpreter
    shuts down would otherwise kill it by the signal instead of exiting 130. ``verbose``: SB3's
    tables on stdout (default: the progress bar and a compact summary at the end)."""
    import torch

    run = RunDir(run_dir)
    torch.set_num_threads(config.runtime.torch_threads)
    device = resolve_device(config.runtime.device)
    command = " ".join(shlex.quote(a) for a in ["cdcr-gym", "train", *argv])
    state: dict[str, Any] = {
        "algo": config.algo,
        "total": config.total_timesteps,
        "stop_requested": False,
        "stopped": False,
    }

    # Ctrl-C / SIGTERM: the first asks for a stop at the next rollout boundary (after a
    # checkpoint), the second stops at once; either way exit 130 without a traceback.
    on_signal = stop_signal_handler(state)

    # Signal handlers can only be installed from the main thread (a sweep may train in another).
    in_main = threading.current_thread() is threading.main_thread()
    sigs = (signal.SIGINT, signal.SIGTERM) if in_main else ()
    previous = {sig: signal.signal(sig, on_signal) for sig in sigs}
    try:
        # Before anything is read, written or cleared: a second training into the same
        # directory stops here (RunDirBusy, exit 2) instead of deleting the running one's files.
        with RunLock(run.root):
            return _train(config, run, resume, argv, command, device, state, verbose)
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
    verbose: bool = False,
) -> int:
    restored = load_newest_checkpoint(config, run, device) if resume else None
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
            clear_artefacts(run)
        run.root.mkdir(parents=True, exist_ok=True)
        save_config(config, run.config)
        sessions = (meta or {}).get("sessions", [])
        meta = {
            "name": config.name,
            "algo": config.algo,
            "seed": config.seed,
            "device": device,
            "config": config_to_dict(config),
            "versions": versions(),
            "git": git_info(),
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
        if load_config(run.config).total_timesteps != config.total_timesteps:
            # a resume to a new budget: config.yaml says what this directory trains to
            atomic_write(run.config, lambda tmp: save_config(config, tmp))
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
        truncate_csv(run.progress, "time/total_timesteps", ckpt.steps)
        truncate_csv(run.eval_log, "timesteps", ckpt.steps)
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
        venv = wrap_normalize(config, base, None)
        model = make_model(config, venv, device)
        model.set_random_seed(config.seed)
        if config.demonstrations.episodes:
            report = pretrain(config, model, venv)
            write_json(run.root / "demonstrations.json", report)
            meta["demonstrations"] = report
            state["wall_before"] = report["wall_time_s"]
            print(
                f"cloned {report['episodes']} {report['oracle']} episodes "
                f"({report['transitions']} transitions, oracle success "
                f"{report['oracle_success_rate']:.0%}): action MSE "
                f"{report['action_mse_before']:.3g} -> {report['action_mse_after']:.3g} "
                f"in {report['wall_time_s']:.0f} s"
            )
    else:
        _, model, venv, base = restored
        print(f"resuming {run.root} from step {model.num_timesteps}")
    state["venv_base"] = base
    model.set_logger(make_logger(run, verbose))

    session: dict[str, Any] = {
        "command": command,
        "argv": argv,
        "cwd": os.getcwd(),
        "start": now_iso(),
        "start_steps": state["start_steps"],
        "status": "running",
        "pid": os.getpid(),
    }
    meta["sessions"].append(session)
    write_json(run.run_json, meta)

    from stable_baselines3.common.callbacks import ProgressBarCallback

    progress = ProgressBarCallback()  # ours, to close it on an interrupt (no shutdown noise)
    callbacks = [*make_callbacks(config, run, state), progress]
    if ckpt is not None:
        pending = ckpt.data.get("pending_log") or {}
        model.logger.name_to_value.update(pending.get("values", {}))
        model.logger.name_to_count.update(pending.get("counts", {}))
        model.logger.name_to_excluded.update(pending.get("excluded", {}))
        # last: nothing between here and learn() may draw random numbers
        set_rng_state(model, ckpt.data["rng"])
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
                "end": now_iso(),
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
        try:
            write_json(run.run_json, meta)
        except OSError as exc:  # e.g. the disk that stopped training is still full
            print(f"warning: {run.run_json} not updated: {exc.strerror or exc}", file=sys.stderr)
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
            f"cdcr-gym train {shlex.quote(str(run.config))} --run-dir "
            f"{shlex.quote(str(run.root))} --resume",
            file=sys.stderr,
        )
        return code

    save_model_dir(model, run.final)
    vecnorm = model.get_vec_normalize_env()
    if vecnorm is not None:
        atomic_write(run.vecnormalize, lambda tmp: vecnorm.save(str(tmp)))
    if state.get("last_checkpoint") != model.num_timesteps:
        save_checkpoint(model, run, state)
    print(
        f"done: {model.num_timesteps} steps in {meta['total_wall_time_s']:.0f} s; "
        f"run directory {run.root}"
    )
    for line in summary_lines(run):
        print(line)
    _close_quietly(venv)
    if state["stop_requested"]:  # the signal came during the last rollout: complete, but 130
        print(f"interrupted after training completed; {run.root} is complete", file=sys.stderr)
        return EXIT_INTERRUPTED
    return code


def summary_lines(run: RunDir) -> list[str]:
    """A few lines on a finished run: the last and the best periodic evaluation (eval_log.csv)."""

    if not run.eval_log.is_file():
        return []
    with open(run.eval_log, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return []

    def line(label: str, row: dict[str, str]) -> str:
        return (
            f"  {label} (step {row['timesteps']}): success {float(row['success_rate']):.0%}, "
            f"tip error mean {float(row['mean_error_mm']):.2f} mm, "
            f"median {float(row['median_error_mm']):.2f} mm, "
            f"return {float(row['mean_reward']):.2f}"
        )

    lines = [line("last evaluation", rows[-1])]
    best = run.best / "info.json"
    if best.is_file():
        info = json.loads(best.read_text())
        row = {k: str(v) for k, v in info.items()}
        lines.append(line(f"best by {info.get('best_metric', '?')}", row) + f" -> {run.best}")
    lines.append(f"  evaluate it: cdcr-gym evaluate {shlex.quote(str(run.root))}")
    return lines


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
        prog="cdcr-gym train",
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
        type=positive_int,
        default=None,
        help="override total_timesteps (env steps, summed over envs)",
    )
    parser.add_argument(
        "--seed", type=non_negative_int, default=None, help="override the config's seed"
    )
    parser.add_argument(
        "--verbose",
        action="store_true",
        help="print stable-baselines3's table of every rollout (default: a progress bar, "
        "then a short summary; the same numbers are in progress.csv and TensorBoard)",
    )
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
    check_demonstrations(config)

    if args.resume:
        if args.run_dir is None:
            raise ConfigError("--resume needs --run-dir (the run to continue)")
        run = RunDir(args.run_dir)
        if not run.config.is_file():
            raise ConfigError(
                f"--run-dir {str(args.run_dir)!r} is not a training run directory (no config.yaml)"
            )
        refuse_legacy(run)
        check_writable_directory(run.root, "--run-dir")
        saved = load_config(run.config)
        if args.seed is not None and args.seed != saved.seed:
            raise ConfigError(
                f"--seed {args.seed} differs from the run's seed {saved.seed}; "
                f"a resumed run keeps its seed"
            )
        # The CONFIG file (with the CLI overrides) must still describe this run. The one change
        # a resume honours is total_timesteps: it trains on to the new budget. Every other
        # changed key is refused, naming it with both values.
        mine, theirs = _flatten(config_to_dict(config)), _flatten(config_to_dict(saved))
        diff = sorted(
            k
            for k in mine.keys() | theirs.keys()
            if k != "total_timesteps" and mine.get(k) != theirs.get(k)
        )
        if diff:
            missing = "(absent)"
            changes = "; ".join(
                f"{k}: {theirs.get(k, missing)!r} in the run, {mine.get(k, missing)!r} in CONFIG"
                for k in diff
            )
            raise ConfigError(
                f"CONFIG {str(args.config)!r} differs from {run.config} in {diff} ({changes}); "
                f"--resume can only change total_timesteps: resume with the run's own "
                f"config.yaml"
            )
        if config.total_timesteps != saved.total_timesteps:
            trained = run.latest_checkpoint() or 0
            if config.total_timesteps < trained:
                raise ConfigError(
                    f"total_timesteps {config.total_timesteps} (was {saved.total_timesteps}) is "
                    f"below the {trained} steps this run has already trained; --resume cannot "
                    f"train backwards"
                )
            saved.total_timesteps = config.total_timesteps
        return saved.validate(), run.root
    if args.run_dir is None:
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        run_dir = Path("runs") / f"{config.name}_seed{config.seed}_{stamp}"
    else:
        run_dir = args.run_dir
    check_writable_directory(run_dir, "--run-dir")
    if run_dir.exists() and (
        not run_dir.is_dir() or any(p.name != LOCK_NAME for p in run_dir.iterdir())
    ):
        run = RunDir(run_dir)
        restartable = run_dir.is_dir() and run.config.is_file() and run.latest_checkpoint() is None
        if restartable:
            refuse_legacy(run)
        else:
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


def _os_error_message(exc: OSError, run_dir: Path | None) -> str:
    """One line for an OSError while training: what failed and what the run directory keeps."""
    where = f"{exc.filename}: " if exc.filename else ""
    text = f"{where}{exc.strerror or exc}"
    if run_dir is None or not Path(run_dir).is_dir():
        return text
    run = RunDir(run_dir)
    steps = run.latest_checkpoint()
    kept = (
        f"its newest complete checkpoint is at step {steps}"
        if steps is not None
        else "it has no checkpoint yet"
    )
    return (
        f"{text}; training stopped, the run directory {str(run.root)!r} is intact ({kept}): "
        f"fix the cause, then continue with cdcr-gym train "
        f"{shlex.quote(str(run.config))} --run-dir {shlex.quote(str(run.root))} --resume"
    )


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = _parse_args(argv)
    try:
        config, run_dir = _resolve(args)
        return train(config, run_dir, args.resume, argv, exiting=True, verbose=args.verbose)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a full disk, a directory made read-only meanwhile: no traceback
        print(f"error: {_os_error_message(exc, args.run_dir)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # before training started, or a second Ctrl-C while finishing
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
