"""Entry points of the registered ids (the (backend × task) table of ``cdcr_gym.registration``),
keyword arguments routed by signature.

``gymnasium.make("cdcr_gym/BulletReach-v0", robot="tdcr2", gravity=False, action_mode="tension")``
lands in :func:`make_env` with ``backend="Bullet"`` and ``task="Reach"`` (the registered
kwargs). Every keyword goes to the one object whose signature names it: the backend class
(``params``, ``gravity``, ``physics_timestep``, ...), the task class (``reward_type``,
``distance_threshold``, ...) or the env (``action_mode``, ``initial_state``, ...). The sets are
read from the signatures, so a documented argument cannot go missing; an unknown keyword is a
``ValueError`` that lists the accepted ones. The env's arguments are those of
:class:`~cdcr_gym.envs.core.EnvCore` (their one signature) and the single env's rendering ones
(:data:`RENDER_KEYS`).

:func:`assemble` builds the robot and the task of both Gymnasium faces: :func:`make_env` (the
single env, ``gymnasium.make``) and :class:`~cdcr_gym.envs.vector.CDCRVectorEnv`
(``gymnasium.make_vec``).
"""

from __future__ import annotations

import importlib
import inspect
from os import PathLike
from pathlib import Path
from typing import Any

from cdcr_gym import validation
from cdcr_gym.backends.base import Backend
from cdcr_gym.envs.core import EnvCore
from cdcr_gym.envs.env import RENDER_KEYS, CDCREnv, GoalCDCREnv
from cdcr_gym.model.params import RobotParams
from cdcr_gym.registration import BACKENDS, DEFAULT_ROBOTS, TASKS
from cdcr_gym.tasks.base import Task

__all__ = [
    "BACKENDS",
    "TASKS",
    "make_env",
    "assemble",
    "env_keywords",
    "split_kwargs",
    "resolve_params",
    "keyword_names",
    "default_robot",
    "DEFAULT_ROBOTS",
]


def _load(table: dict[str, str], name: Any, what: str) -> Any:
    if not isinstance(name, str) or name not in table:
        raise ValueError(f"{what} must be one of {sorted(table)}, got {name!r}")
    module, attribute = table[name].split(":")
    return getattr(importlib.import_module(module), attribute)


def keyword_names(callable_: Any) -> tuple[str, ...]:
    """The keyword-argument names of a class's ``__init__`` (or a function)."""
    target = callable_.__init__ if inspect.isclass(callable_) else callable_
    return tuple(
        name
        for name, p in inspect.signature(target).parameters.items()
        if name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    )


def resolve_params(robot: Any = None, params: Any = None, default: str = "paper") -> RobotParams:
    """The robot: ``params`` (a RobotParams, or the path of a YAML file such as
    ``cdcr-gym calibrate``'s ``params.yaml``, read by ``RobotParams.from_yaml``) or a preset name
    ``robot``; else preset ``default``."""
    if robot is not None and params is not None:
        raise ValueError("give either robot (a preset name) or params (a RobotParams), not both")
    if isinstance(params, (str, PathLike)):
        return RobotParams.from_yaml(Path(params))
    if params is not None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        return params
    return RobotParams.preset(default if robot is None else robot)


def env_keywords() -> tuple[str, ...]:
    """The env's own keyword arguments: :class:`EnvCore`'s options (its signature) and the
    rendering ones (:data:`RENDER_KEYS`); ``goal_conditioned`` is chosen by the entry point."""
    core = [k for k in keyword_names(EnvCore) if k not in ("backend", "task", "goal_conditioned")]
    return (*core, *RENDER_KEYS)


def split_kwargs(
    backend: str, task: str, kwargs: dict[str, Any]
) -> tuple[type, dict[str, Any], type, dict[str, Any], dict[str, Any]]:
    """Route ``kwargs`` by signature: (backend class, backend kwargs, task class, task kwargs,
    env kwargs). Raises ValueError for a keyword nobody accepts."""
    backend_class = _load(BACKENDS, backend, "backend")
    task_class = _load(TASKS, task, "task")
    backend_keys = set(keyword_names(backend_class)) - {"params"}
    task_keys = set(keyword_names(task_class))
    env_keys = set(env_keywords())
    unknown = set(kwargs) - backend_keys - task_keys - env_keys
    if unknown:
        accepted = sorted(
            backend_keys | task_keys | env_keys | {"robot", "params", "goal_conditioned"}
        )
        raise ValueError(
            f"unknown keyword argument(s) {sorted(unknown)} for {backend}{task}; "
            f"accepted: {accepted}"
        )
    pick = lambda keys: {k: v for k, v in kwargs.items() if k in keys}  # noqa: E731
    return backend_class, pick(backend_keys), task_class, pick(task_keys), pick(env_keys)


def default_robot(backend: Any, task: Any) -> str:
    """The robot preset of ``task`` on ``backend`` when none is given (:data:`DEFAULT_ROBOTS`,
    else "paper")."""
    key = (backend, task)
    return DEFAULT_ROBOTS.get(key, "paper") if all(isinstance(k, str) for k in key) else "paper"


def assemble(
    backend: str,
    task: str,
    kwargs: dict[str, Any],
    *,
    robot: Any = None,
    params: Any = None,
    num_robots: int | None = None,
) -> tuple[Backend, Task, dict[str, Any]]:
    """The robot and the task of the env of ``task`` on ``backend`` (registry names), and the
    env's keyword arguments: ``kwargs`` routed by signature (:func:`split_kwargs`), the robot
    from ``robot``/``params`` (:func:`resolve_params`, default :func:`default_robot`).
    ``num_robots``: a batched backend of that many robots (None: one robot, the backend's
    default).

    Raises:
        ValueError: for an unknown keyword (listing the accepted ones), an unknown backend or
            task, or ``num_robots`` on a backend that holds one robot.
    """
    params = resolve_params(robot, params, default_robot(backend, task))
    backend_class, backend_kw, task_class, task_kw, env_kw = split_kwargs(backend, task, kwargs)
    if num_robots is not None:
        if "num_robots" not in keyword_names(backend_class):
            raise ValueError(
                f"backend {backend!r} holds one robot: the batched env needs a backend with "
                f"num_robots (CCKA, MuJoCo); use gymnasium.make_vec(..., "
                f"vectorization_mode='sync')"
            )
        backend_kw["num_robots"] = num_robots
    task_object = task_class(**task_kw)
    return backend_class(params=params, **backend_kw), task_object, env_kw


def make_env(
    backend: str,
    task: str,
    *,
    goal_conditioned: bool = False,
    robot: Any = None,
    params: Any = None,
    **kwargs: Any,
) -> CDCREnv:
    """Entry point of every registered id (``backend`` and ``task`` come from the registry):
    the env of ``task`` on ``backend``, every keyword routed to its owner (module docstring)."""
    env_class = GoalCDCREnv if validation.flag(goal_conditioned, "goal_conditioned") else CDCREnv
    backend_object, task_object, env_kw = assemble(
        backend, task, kwargs, robot=robot, params=params
    )
    try:
        return env_class(backend_object, task_object, **env_kw)
    except Exception:
        backend_object.close()
        raise
