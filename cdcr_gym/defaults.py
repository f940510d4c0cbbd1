"""Defaults shared by the envs, the registered ids and training, in one place.

Every constructor that takes one of these arguments uses the constant here as its default, so a
change is made once (and ``training`` can import them instead of repeating the numbers).
"""

from __future__ import annotations

__all__ = [
    "ACTION_MODE",
    "TENSION_STEP",
    "LENGTH_STEP",
    "DISPLACEMENT_STEP",
    "INITIAL_STATE",
    "INITIAL_STATES",
    "REWARD_TYPE",
    "RENDER_SIZE",
    "MAX_EPISODE_STEPS",
    "DISTANCE_THRESHOLD",
    "NOMINAL_TIMESTEP",
]

#: Action mode of every env (``cdcr_gym.envs.actuation.ACTION_MODES``).
ACTION_MODE = "tension_delta"
#: Largest tension change per step in ``tension_delta`` mode, as a fraction of max_tension.
TENSION_STEP = 0.05
#: Largest cable displacement per step in ``length_delta`` mode (m).
LENGTH_STEP = 0.002
#: Largest tendon displacement change per step in ``displacement_delta`` mode (m): 1 mm, about
#: 1/20 of the paper robot's range of tendon shortenings (±29 mm·θ) and 1/22 of the FTDCR v4
#: drives' range (22.5 mm), so that a full swing takes a few tens of steps, like
#: ``TENSION_STEP``; at the drives' stiffness (7–20 kN/m) it is a 7–20 N tension step on a
#: taut tendon held straight.
DISPLACEMENT_STEP = 0.001
#: Start shapes: ``"straight"`` (zero tensions) or ``"random"`` (a shape drawn like the goals).
INITIAL_STATES = ("straight", "random")
#: Default start shape (one of :data:`INITIAL_STATES`).
INITIAL_STATE = "straight"
#: Reward type of the goal tasks (``"dense"`` or ``"sparse"``).
REWARD_TYPE = "dense"
#: Width and height (px) of a rendered image.
RENDER_SIZE = 480
#: Episode length (steps) of the registered ids (Gymnasium's ``max_episode_steps``).
MAX_EPISODE_STEPS = 100
#: Success radius (m) of the goal tasks.
DISTANCE_THRESHOLD = 0.005
#: Control timestep (s) assumed on a quasi-static backend (the analytic one has
#: ``control_timestep == 0``): the pybullet backend's default, so a speed means the same
#: distance per step on every backend (Track's target, the ``tip_velocity`` field).
NOMINAL_TIMESTEP = 0.02
