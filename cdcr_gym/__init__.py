"""cdcr_gym: Gymnasium environments for cable-driven continuum robots.

Importing the package registers one id per (backend × task) (cheap: string entry points only):

* ``cdcr_gym/CCKAReach-v0`` — tip reaching on the analytic piecewise-constant-curvature model;
* ``cdcr_gym/BulletReach-v0`` — tip reaching on a pybullet multibody backbone;
* ``cdcr_gym/MuJoCoReach-v0`` — tip reaching on a MuJoCo chain with one tendon per cable
  (batched: ``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``);
* ``cdcr_gym/{CCKA,Bullet,MuJoCo}Track-v0`` — follow a moving target (``cdcr_gym.tasks.track``);
* ``cdcr_gym/{CCKA,Bullet,MuJoCo}Pose-v0`` — reach a tip position and direction (default robot
  ``tdcr2``; ``cdcr_gym.tasks.pose``);
* ``cdcr_gym/{CCKA,Bullet,MuJoCo}Obstacle-v0`` — reach a goal around spheres (``cdcr_gym.tasks.obstacle``).

The short ids (``CCKAReach-v0``, ...) are registered as well, so that Gymnasium's
``"module:id"`` form, ``gymnasium.make("cdcr_gym:CCKAReach-v0")``, works in a fresh interpreter
without a prior ``import cdcr_gym``. The robot is chosen by ``robot="paper"`` (default) or
``"tdcr2"``, or ``params=RobotParams(...)``.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

__version__ = "0.2.0"

#: Episode length (steps) of the registered ids.
MAX_EPISODE_STEPS = 100

#: Backends (id prefix) and whether they have a batched vector entry point.
_BACKENDS = {"CCKA": True, "Bullet": False, "MuJoCo": True}
#: Tasks (id infix).
_TASKS = ("Reach", "Track", "Pose", "Obstacle")


def _register_all() -> None:
    for backend, batched in _BACKENDS.items():
        for task in _TASKS:
            name = f"{backend}{task}-v0"
            for env_id in (f"cdcr_gym/{name}", name):
                if env_id not in registry:
                    register(
                        id=env_id,
                        entry_point="cdcr_gym.envs.factory:make_env",
                        vector_entry_point="cdcr_gym.envs.vector:CDCRVectorEnv"
                        if batched
                        else None,
                        max_episode_steps=MAX_EPISODE_STEPS,
                        kwargs={"backend": backend, "task": task},
                    )


_register_all()
