"""cdcr_gym: Gymnasium environments for a 2-DOF cable-driven continuum robot.

Importing the package registers the environment ids (cheap: string entry points only):

* ``cdcr_gym/CCKAReach-v0`` — tip reaching on the analytic constant-curvature model;
* ``cdcr_gym/BulletReach-v0`` — tip reaching on a pybullet multibody backbone.

The short ids ``CCKAReach-v0`` and ``BulletReach-v0`` are registered as well, so that
Gymnasium's ``"module:id"`` form, ``gymnasium.make("cdcr_gym:CCKAReach-v0")``, works in a fresh
interpreter without a prior ``import cdcr_gym``.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

#: Episode length (steps) of the registered ids.
MAX_EPISODE_STEPS = 100

_ENTRY_POINTS = {
    "CCKAReach-v0": "cdcr_gym.envs.factory:make_ccka_reach",
    "BulletReach-v0": "cdcr_gym.envs.factory:make_bullet_reach",
}

#: Batched implementations for ``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``.
_VECTOR_ENTRY_POINTS = {
    "CCKAReach-v0": "cdcr_gym.envs.vector:CCKAReachVectorEnv",
}


def _register_all() -> None:
    for name, entry_point in _ENTRY_POINTS.items():
        for env_id in (f"cdcr_gym/{name}", name):
            if env_id not in registry:
                register(
                    id=env_id,
                    entry_point=entry_point,
                    vector_entry_point=_VECTOR_ENTRY_POINTS.get(name),
                    max_episode_steps=MAX_EPISODE_STEPS,
                )


_register_all()
