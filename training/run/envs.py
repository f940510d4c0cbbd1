"""The training envs (one VecEnv per run) and the checks of a config's env, algorithm and device."""

from __future__ import annotations

import pickle
import signal
import threading
from collections.abc import Callable
from typing import Any

import cloudpickle
import gymnasium as gym

import cdcr_gym  # noqa: F401
from cdcr_gym import MAX_EPISODE_STEPS
from cdcr_gym.registration import BATCHED
from training.run.config import (
    ConfigError,
    ExperimentConfig,
)
from training.run.rollout import algo_class, make_env, robot_of


# -- environments -------------------------------------------------------------------------------
def _snapshot_wrapper() -> type:

    class EnvSnapshot(gym.Wrapper):  # type: ignore[type-arg]
        """Outermost wrapper of a training env: its whole state (wrappers, RNG, robot) as bytes.

        ``get_snapshot()`` is None if the env cannot be pickled (then a resume reseeds the envs
        instead of restoring them). Called through ``VecEnv.env_method``, so it works in
        ``SubprocVecEnv`` workers too."""

        def get_snapshot(self) -> bytes | None:

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

    e = config.env
    n = e.n_envs if n_envs is None else n_envs
    if e.vec_env == "batched":
        try:
            from training.run.sb3_vec import BatchedVecEnv
        except ImportError as exc:
            raise ConfigError(
                f"env.vec_env: 'batched' needs training/run/sb3_vec.py (BatchedVecEnv), which "
                f"could not be imported ({exc}); use 'dummy' or 'subproc'"
            ) from None

        registered = gym.registry[e.id].kwargs if e.id in gym.registry else {}
        if registered.get("backend") not in BATCHED:
            raise ConfigError(
                f"env.vec_env: 'batched' supports the ids of the batched backends "
                f"{list(BATCHED)} only, not {e.id!r}; use 'dummy' or 'subproc'"
            )
        kwargs = dict(e.kwargs)
        kwargs["backend"] = registered["backend"]
        kwargs["task"] = registered["task"]
        if e.max_episode_steps is not None:
            kwargs["max_episode_steps"] = e.max_episode_steps
        if e.per_env_kwargs:
            kwargs["per_env_kwargs"] = [dict(k) for k in e.per_env_kwargs]
        try:
            venv = BatchedVecEnv(num_envs=n, seed=seed, **kwargs)
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


def registered_task(env_id: str) -> str:
    """The task name of a registered id (``"Reach"`` for ids registered elsewhere)."""

    spec = gym.registry.get(env_id)
    return str(spec.kwargs.get("task", "Reach")) if spec is not None else "Reach"


def _check_env_id(config: ExperimentConfig) -> None:

    known = sorted(k for k in gym.registry if k.startswith("cdcr_gym/"))
    if config.env.id not in gym.registry:
        raise ConfigError(f"env.id {config.env.id!r} is not registered; known ids: {known}")
    entry = gym.registry[config.env.id].entry_point
    if not (isinstance(entry, str) and entry.startswith("cdcr_gym.")):
        raise ConfigError(
            f"env.id {config.env.id!r} is not a cdcr_gym env (entry point {entry!r}); "
            f"training.run.train trains the cdcr_gym envs: {known}"
        )


def check_env_config(config: ExperimentConfig) -> None:
    """Make the env once per distinct kwargs (``env.kwargs`` updated by each
    ``env.per_env_kwargs`` entry), reset and close it, and check the algorithm's package and the
    device; raise :class:`ConfigError` naming the key. Called before the run directory exists."""

    _check_env_id(config)
    e = config.env
    cases = [("env.kwargs", dict(e.kwargs))]
    cases += [
        (f"env.per_env_kwargs[{i}]", {**e.kwargs, **extra})
        for i, extra in enumerate(e.per_env_kwargs)
    ]
    for key, kwargs in cases:
        params = kwargs.get("params")
        if params is not None and not isinstance(params, (dict, str)):
            raise ConfigError(
                f"{key}.params must be a mapping of RobotParams fields or the path of a "
                f"params YAML file, got {params!r}"
            )
        if params is not None:
            try:
                robot_of(params)
            except (TypeError, ValueError) as exc:
                raise ConfigError(f"{key}.params: {exc}") from None
        try:
            env = make_env(e.id, kwargs, e.max_episode_steps)
            try:
                env.reset(seed=config.seed)
                task = env.unwrapped.task
            finally:
                env.close()
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{key}: cannot make {e.id!r} with {kwargs}: {exc}") from None
        if config.curriculum.steps > 0 and not task.has_curriculum:
            raise ConfigError(
                f"curriculum.steps: the {type(task).__name__} task of {e.id!r} has no "
                f"curriculum (tasks with one: Obstacle); set curriculum.steps: 0"
            )
    if e.vec_env == "batched":
        build_vec_env(config, config.seed, n_envs=1).close()
    try:
        algo_class(config.algo)
    except ImportError as exc:
        raise ConfigError(str(exc)) from None
    resolve_device(config.runtime.device)


def resolve_device(device: str) -> str:
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


def registered_steps(env_id: str) -> int:
    """The episode length ``env_id`` is registered with (cdcr_gym's ``MAX_EPISODE_STEPS`` for an
    id registered without one, or not registered)."""

    spec = gym.registry.get(env_id)
    return (spec.max_episode_steps if spec is not None else None) or MAX_EPISODE_STEPS
