"""Entry points of the registered ids: a (backend × task) table, keyword arguments routed by
signature.

``gymnasium.make("cdcr_gym/BulletReach-v0", robot="tdcr2", gravity=False, action_mode="tension")``
lands in :func:`make_env` with ``backend="Bullet"`` and ``task="Reach"`` (the registered
kwargs). Every keyword goes to the one object whose signature names it: the backend class
(``params``, ``gravity``, ``physics_timestep``, ...), the task class (``reward_type``,
``distance_threshold``, ...) or the env (``action_mode``, ``initial_state``, ...). The sets are
read from the signatures, so a documented argument cannot go missing; an unknown keyword is a
``ValueError`` that lists the accepted ones.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from cdcr_gym import validation
from cdcr_gym.envs.env import CDCREnv, GoalCDCREnv
from cdcr_gym.model.params import RobotParams

__all__ = [
    "BACKENDS",
    "TASKS",
    "make_env",
    "split_kwargs",
    "resolve_params",
    "keyword_names",
    "default_robot",
    "DEFAULT_ROBOTS",
]

#: Backend name (id prefix) → class, as "module:attribute" (imported only when used).
BACKENDS = {
    "CCKA": "cdcr_gym.backends.analytic:AnalyticBackend",
    "Bullet": "cdcr_gym.backends.bullet:BulletBackend",
    "MuJoCo": "cdcr_gym.backends.mujoco:MuJoCoBackend",
}
#: Task name (id infix) → class, as "module:attribute".
TASKS = {
    "Reach": "cdcr_gym.tasks.reach:Reach",
    "Track": "cdcr_gym.tasks.track:Track",
    "Pose": "cdcr_gym.tasks.pose:Pose",
    "Obstacle": "cdcr_gym.tasks.obstacle:Obstacle",
}
#: The robot preset of a (backend, task) when neither ``robot`` nor ``params`` is given (else
#: "paper"). Pose defaults to the two-section robot (a one-section tip direction is fixed by its
#: position) on every backend that models several sections.
DEFAULT_ROBOTS = {
    ("CCKA", "Pose"): "tdcr2",
    ("Bullet", "Pose"): "tdcr2",
    ("MuJoCo", "Pose"): "tdcr2",
}


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
    """The robot: ``params`` (a RobotParams) or a preset name ``robot``; else preset ``default``."""
    if robot is not None and params is not None:
        raise ValueError("give either robot (a preset name) or params (a RobotParams), not both")
    if params is not None:
        if not isinstance(params, RobotParams):
            raise ValueError(f"params must be a cdcr_gym.params.RobotParams, got {params!r}")
        return params
    return RobotParams.preset(default if robot is None else robot)


def split_kwargs(
    backend: str, task: str, kwargs: dict[str, Any], env_class: type = CDCREnv
) -> tuple[type, dict[str, Any], type, dict[str, Any], dict[str, Any]]:
    """Route ``kwargs`` by signature: (backend class, backend kwargs, task class, task kwargs,
    env kwargs). Raises ValueError for a keyword nobody accepts."""
    backend_class = _load(BACKENDS, backend, "backend")
    task_class = _load(TASKS, task, "task")
    backend_keys = set(keyword_names(backend_class)) - {"params"}
    task_keys = set(keyword_names(task_class))
    env_keys = set(keyword_names(env_class)) - {"backend", "task"}
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
    params = resolve_params(robot, params, default_robot(backend, task))
    backend_class, backend_kw, task_class, task_kw, env_kw = split_kwargs(
        backend, task, kwargs, env_class
    )
    task_object = task_class(**task_kw)
    backend_object = backend_class(params=params, **backend_kw)
    try:
        return env_class(backend_object, task_object, **env_kw)
    except Exception:
        backend_object.close()
        raise
