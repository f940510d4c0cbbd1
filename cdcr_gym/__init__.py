"""cdcr_gym: Gymnasium environments for cable-driven continuum robots.

Importing the package registers one id per (backend × task) of the table in
``cdcr_gym.registration`` (cheap: string entry points only):

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

from cdcr_gym.defaults import MAX_EPISODE_STEPS
from cdcr_gym.registration import register_all

__version__ = "0.3.0"

__all__ = ["MAX_EPISODE_STEPS", "__version__"]

register_all()
