"""Entry points of the registered ids: build the backend from its kwargs, inject it into ReachEnv.

``gymnasium.make("cdcr_gym/BulletReach-v0", gravity=False, action_mode="tension")`` lands here:
the keyword arguments that belong to the backend (``BACKEND_KWARGS``) build the backend object;
the rest go to :class:`~cdcr_gym.envs.reach.ReachEnv`.
"""

from __future__ import annotations

from typing import Any

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.envs.reach import GoalReachEnv, ReachEnv

__all__ = ["make_ccka_reach", "make_bullet_reach", "BULLET_BACKEND_KWARGS"]

#: gym.make kwargs that configure the pybullet backend (see ``BulletBackend``).
BULLET_BACKEND_KWARGS = (
    "params",
    "gravity",
    "links_per_span",
    "control_timestep",
    "physics_timestep",
    "base_orientation",
    "tip_payload",
)


def _env_class(goal_conditioned: Any) -> type[ReachEnv]:
    if not isinstance(goal_conditioned, bool):
        raise ValueError(f"goal_conditioned must be a bool, got {goal_conditioned!r}")
    return GoalReachEnv if goal_conditioned else ReachEnv


def make_ccka_reach(
    params: Any = None, goal_conditioned: bool = False, **env_kwargs: Any
) -> ReachEnv:
    """``cdcr_gym/CCKAReach-v0``: :class:`ReachEnv` on the analytic constant-curvature backend.

    ``goal_conditioned=True`` gives :class:`GoalReachEnv` (Dict observation, for HER).
    """
    return _env_class(goal_conditioned)(AnalyticBackend(params), **env_kwargs)


def make_bullet_reach(goal_conditioned: bool = False, **kwargs: Any) -> ReachEnv:
    """``cdcr_gym/BulletReach-v0``: :class:`ReachEnv` on the pybullet multibody backbone.

    ``goal_conditioned=True`` gives :class:`GoalReachEnv` (Dict observation, for HER).
    """
    env_class = _env_class(goal_conditioned)
    from cdcr_gym.backends.bullet import BulletBackend  # pybullet imported only when used

    backend_kwargs = {k: kwargs.pop(k) for k in BULLET_BACKEND_KWARGS if k in kwargs}
    backend_kwargs["gui"] = kwargs.get("render_mode") == "human"
    backend = BulletBackend(**backend_kwargs)
    try:
        return env_class(backend, **kwargs)
    except Exception:
        backend.close()
        raise
