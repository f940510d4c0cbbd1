"""The reach task's math, written once and batched: actions → commands, observations, rewards.

Both the single env (``reach.ReachEnv``) and the batched env use these functions, so the two
cannot drift apart. Every function broadcasts over leading batch dimensions; arrays are float64
in SI units unless stated.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import kinematics
from cdcr_gym.params import RobotParams
from cdcr_gym.workspace import clip_to_workspace

__all__ = [
    "ACTION_MODES",
    "REWARD_TYPES",
    "ERROR_SCALE",
    "tensions_from_action",
    "lengths_from_action",
    "flat_observation",
    "goal_observation",
    "flat_observation_size",
    "reward_from_distance",
]

#: Action modes: absolute tensions, tension increments, cable-length increments (CCKA only).
ACTION_MODES = ("tension", "tension_delta", "length_delta")
#: Reward types: dense −distance (m), or sparse −1/0 by the success threshold.
REWARD_TYPES = ("dense", "sparse")
#: Length scale (m) of the saturated error feature tanh((goal − tip)/ERROR_SCALE).
ERROR_SCALE = 0.01


def tensions_from_action(
    action: np.ndarray,
    held: np.ndarray,
    mode: str,
    max_tension: float,
    tension_step: float,
) -> np.ndarray:
    """Cable tensions (..., 3) N commanded by an action in [−1, 1]³.

    ``"tension"``: T = max_tension·(a + 1)/2 (absolute). ``"tension_delta"``:
    T = clip(held + a·tension_step·max_tension, 0, max_tension), ``held`` being the tensions
    commanded at the previous step.
    """
    if mode == "tension":
        return max_tension * 0.5 * (action + 1.0)
    return np.clip(held + action * (tension_step * max_tension), 0.0, max_tension)


def lengths_from_action(
    action: np.ndarray, lengths: np.ndarray, params: RobotParams, length_step: float
) -> np.ndarray:
    """Cable lengths (..., 3) m after a ``"length_delta"`` action in [−1, 1]³.

    The increments a·length_step are projected onto Σ Δl_i = 0 (the backbone is inextensible, so
    the mean cable length stays ℓ), and the resulting arc's bending angle is clipped to the
    tension-reachable limit θ_lim(φ) (radially in the curvature plane; φ is kept).
    """
    delta = action * length_step
    delta = delta - delta.mean(axis=-1, keepdims=True)
    theta, phi, _ = kinematics.arc_from_lengths(lengths + delta, params.cable_radius)
    theta, _ = clip_to_workspace(theta, phi, params)
    return kinematics.lengths_from_arc(theta, phi, params.length, params.cable_radius)


def flat_observation_size() -> int:
    """Length of the flat observation vector (see :func:`flat_observation`)."""
    return 18


def _state_features(tensions: np.ndarray, lengths: np.ndarray, params: RobotParams) -> np.ndarray:
    return np.concatenate(
        [
            tensions / params.max_tension,
            (lengths - params.length) / (np.pi * params.cable_radius),
        ],
        axis=-1,
    )


def flat_observation(
    tip: np.ndarray,
    goal: np.ndarray,
    tensions: np.ndarray,
    lengths: np.ndarray,
    params: RobotParams,
) -> np.ndarray:
    """The flat observation (..., 18) float32; the index table is in ``ReachEnv``'s docstring.

    [tip (3) m, goal (3) m, goal − tip (3) m, tanh((goal − tip)/1 cm) (3),
    tensions/max_tension (3), (cable length − ℓ)/(π r) (3)]
    """
    error = goal - tip
    return np.concatenate(
        [tip, goal, error, np.tanh(error / ERROR_SCALE), _state_features(tensions, lengths, params)],
        axis=-1,
    ).astype(np.float32)


def goal_observation(
    tip: np.ndarray, tensions: np.ndarray, lengths: np.ndarray, params: RobotParams
) -> np.ndarray:
    """The goal-free ``observation`` (..., 9) float32 of the goal-conditioned variant.

    [tip (3) m, tensions/max_tension (3), (cable length − ℓ)/(π r) (3)]
    """
    return np.concatenate([tip, _state_features(tensions, lengths, params)], axis=-1).astype(
        np.float32
    )


def reward_from_distance(distance: np.ndarray, reward_type: str, threshold: float) -> np.ndarray:
    """Reward for a tip-to-goal ``distance`` (m): −distance (dense) or −(distance > threshold)."""
    if reward_type == "dense":
        return -distance
    return -(distance > threshold).astype(np.float64)
