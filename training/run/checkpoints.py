"""Checkpoints that resume bit for bit: model, VecNormalize, replay buffer, env and RNG states."""

from __future__ import annotations

import pickle
import random
import sys
import time
from pathlib import Path
from typing import Any

import cloudpickle
import numpy as np

from training.run.algorithms import wrap_normalize
from training.run.config import (
    OFF_POLICY,
    ConfigError,
    ExperimentConfig,
)
from training.run.envs import build_vec_env
from training.run.logs import plot_learning_curve
from training.run.rollout import algo_class
from training.run.rundir import KEEP_REPLAY_BUFFERS, Checkpoint, RunDir, atomic_write, sha256_file


def save_model_dir(model: Any, directory: Path) -> None:
    """``model.zip`` and ``vecnormalize.pkl`` into ``directory``, each written atomically."""
    directory.mkdir(parents=True, exist_ok=True)
    atomic_write(directory / "model.zip", lambda tmp: model.save(tmp))
    vecnorm = model.get_vec_normalize_env()
    if vecnorm is not None:
        atomic_write(directory / "vecnormalize.pkl", lambda tmp: vecnorm.save(str(tmp)))


def _env_snapshot(venv_base: Any) -> dict[str, Any] | None:
    """The training envs' state (below VecNormalize), or None if they cannot be pickled."""
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


def rng_state(model: Any) -> dict[str, Any]:
    import torch

    return {
        "python": random.getstate(),
        "numpy": np.random.get_state(),  # noqa: NPY002 - SB3 draws from the legacy global RNG
        "torch": torch.get_rng_state().numpy().copy(),
        "action_space": model.action_space.np_random.bit_generator.state,
    }


def set_rng_state(model: Any, rng: dict[str, Any]) -> None:
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
    atomic_write(model_path, lambda tmp: model.save(tmp))
    if vecnorm is not None:
        atomic_write(vn_path, lambda tmp: vecnorm.save(str(tmp)))
        paths.append(vn_path)
    if hasattr(model, "replay_buffer") and model.replay_buffer is not None:
        rb_path = run.replay_buffer_path(steps)
        atomic_write(rb_path, lambda tmp: model.save_replay_buffer(tmp))
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
        "files": {p.name: (p.stat().st_size, sha256_file(p)) for p in paths},
        "rng": rng_state(model),
        "envs": envs,
        "vecnormalize_returns": None if vecnorm is None else vecnorm.returns.copy(),
        "best_score": state.get("best_score"),
        "last_eval_step": state.get("last_eval_step"),
        "wall_time_s": state["wall_before"] + time.perf_counter() - state["t_start"],
        # values recorded (e.g. train/* of the update just done) but not yet written to the logs
        "pending_log": _pending_log(model.logger),
    }
    atomic_write(run.state_path(steps), lambda tmp: tmp.write_bytes(pickle.dumps(data)))
    state["last_checkpoint"] = steps
    # Replay buffers are large: only the newest few off-policy checkpoints stay resumable (older
    # ones keep their model and statistics, as a history).
    for old in run.checkpoint_steps()[KEEP_REPLAY_BUFFERS:]:
        if old < steps and run.replay_buffer_path(old).exists():
            run.state_path(old).unlink(missing_ok=True)
            run.replay_buffer_path(old).unlink()
    try:
        plot_learning_curve(run.root)
    except Exception as exc:  # noqa: BLE001 - a plot must never kill a training run
        print(f"warning: learning curve not written: {exc}", file=sys.stderr)
    return steps


def restore_checkpoint(
    config: ExperimentConfig, run: RunDir, ckpt: Checkpoint, device: str
) -> tuple[Any, Any, Any]:
    """(model, VecNormalize-wrapped venv, base venv) exactly as at checkpoint ``ckpt``.

    Raises on any failure (the caller falls back to an older checkpoint)."""

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
        venv = wrap_normalize(config, base, vn_path if vn_path.exists() else None)
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


def load_newest_checkpoint(
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
            model, venv, base = restore_checkpoint(config, run, ckpt, device)
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
