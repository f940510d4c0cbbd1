"""The registered ids, from one (backend × task) table.

``import cdcr_gym`` calls :func:`register_all`: one id per row of :data:`BACKENDS` × :data:`TASKS`,
``cdcr_gym/<Backend><Task>-v0`` and the short ``<Backend><Task>-v0`` (so that Gymnasium's
``"module:id"`` form works in a fresh interpreter). The classes are named as
``"module:attribute"`` strings and imported only when an env is made
(``cdcr_gym.envs.factory``), so registering stays cheap. A new backend is one row here.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from cdcr_gym.defaults import MAX_EPISODE_STEPS

__all__ = ["BACKENDS", "TASKS", "BATCHED", "DEFAULT_ROBOTS", "env_ids", "register_all"]

#: Backend name (id prefix) → its class, as "module:attribute".
BACKENDS = {
    "CCKA": "cdcr_gym.backends.analytic:AnalyticBackend",
    "Bullet": "cdcr_gym.backends.bullet:BulletBackend",
    "MuJoCo": "cdcr_gym.backends.mujoco:MuJoCoBackend",
}
#: Backends with a batched vector entry point (``gymnasium.make_vec(...,
#: vectorization_mode="vector_entry_point")``: ``cdcr_gym.envs.vector.CDCRVectorEnv``).
BATCHED = ("CCKA", "MuJoCo")
#: Task name (id infix) → its class, as "module:attribute".
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


def env_ids(short: bool = False) -> list[str]:
    """Every registered id (``cdcr_gym/...``; with ``short``, the short forms)."""
    prefix = "" if short else "cdcr_gym/"
    return [f"{prefix}{backend}{task}-v0" for backend in BACKENDS for task in TASKS]


def register_all() -> None:
    """Register every id of the table (ids already registered are left alone)."""
    for backend in BACKENDS:
        for task in TASKS:
            name = f"{backend}{task}-v0"
            for env_id in (f"cdcr_gym/{name}", name):
                if env_id not in registry:
                    register(
                        id=env_id,
                        entry_point="cdcr_gym.envs.factory:make_env",
                        vector_entry_point="cdcr_gym.envs.vector:CDCRVectorEnv"
                        if backend in BATCHED
                        else None,
                        max_episode_steps=MAX_EPISODE_STEPS,
                        kwargs={"backend": backend, "task": task},
                    )
