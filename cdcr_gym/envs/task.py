"""The reach task's math, written once and batched: actions → commands, observations, rewards.

Both the single env (``reach.ReachEnv``) and the batched env use these functions, so the two
cannot drift apart. Every function broadcasts over leading batch dimensions; arrays are float64
in SI units unless stated.

The elementwise functions (:func:`tensions_from_action`, :func:`reward_from_distance` and the
private feature kernels) also accept Python floats, which the single env uses for speed; the
functions that couple the three cables have private component kernels (``_lengths_from_action``)
that take floats or arrays, like those of ``cdcr_gym.kinematics``.
"""

from __future__ import annotations

import math

import numpy as np

from cdcr_gym.kinematics import _bending_from_lengths, _clip, _lengths_from_bending, _sqrt, _stack3
from cdcr_gym.params import RobotParams
from cdcr_gym.statics import _workspace_scale

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
    return _clip(held + action * (tension_step * max_tension), 0.0, max_tension)


def lengths_from_action(
    action: np.ndarray, lengths: np.ndarray, params: RobotParams, length_step: float
) -> np.ndarray:
    """Cable lengths (..., 3) m after a ``"length_delta"`` action in [−1, 1]³.

    The increments a·length_step are projected onto Σ Δl_i = 0 (the backbone is inextensible, so
    the mean cable length stays ℓ), and the resulting arc's bending angle is clipped to the
    tension-reachable limit θ_lim(φ) (radially in the curvature plane; φ is kept).
    """
    action = np.asarray(action, dtype=np.float64)
    lengths = np.asarray(lengths, dtype=np.float64)
    r, ell, ei = params.cable_radius, params.length, params.bending_stiffness
    return _stack3(
        *_lengths_from_action(
            (action[..., 0], action[..., 1], action[..., 2]),
            (lengths[..., 0], lengths[..., 1], lengths[..., 2]),
            length_step,
            ell,
            r,
            ei / (r * ell),
            params.max_tension,
        )
    )


def _lengths_from_action(action, lengths, length_step, length, r, stiffness, max_tension):
    """Component kernel of :func:`lengths_from_action` (floats or arrays).

    ``action`` and ``lengths`` are 3-tuples; ``stiffness`` = EI/(r ℓ) (N/rad). The projected
    lengths set the bending vector w (``kinematics.arc_from_lengths``); w is scaled radially onto
    the tension-reachable hexagon if outside (= ``workspace.clip_to_workspace``: θ clipped to
    θ_lim(φ), φ kept), and the lengths of the clipped arc are returned (with backbone length ℓ).
    """
    d1, d2, d3 = action[0] * length_step, action[1] * length_step, action[2] * length_step
    mean = (d1 + d2 + d3) / 3.0
    wx, wy = _bending_from_lengths(
        lengths[0] + (d1 - mean), lengths[1] + (d2 - mean), lengths[2] + (d3 - mean), r
    )
    s = _workspace_scale(wx, wy, stiffness, max_tension)
    return _lengths_from_bending(wx * s, wy * s, length, r)


def flat_observation_size() -> int:
    """Length of the flat observation vector (see :func:`flat_observation`)."""
    return 18


def _tanh(x):
    return math.tanh(x) if type(x) is float else np.tanh(x)


def _distance(error):
    """‖error‖ (m) of an error 3-tuple of components (floats or arrays)."""
    ex, ey, ez = error
    return _sqrt(ex * ex + ey * ey + ez * ez)


def _observation_constants(params: RobotParams) -> tuple[float, float, float]:
    """(max_tension, backbone_length, length_span) for the observation kernels (floats)."""
    return float(params.max_tension), float(params.length), float(np.pi * params.cable_radius)


def _flat_entries(tip, goal, tensions, lengths, constants) -> tuple[list, tuple]:
    """The 18 entries of the flat observation, in order, and the error goal − tip.

    ``tip``, ``goal``, ``tensions``, ``lengths`` are 3-tuples of components (floats or arrays);
    ``constants`` is :func:`_observation_constants`. Returns ``(entries, (ex, ey, ez))``:
    [tip, goal, goal − tip, tanh((goal − tip)/ERROR_SCALE), :func:`_state_entries`].
    """
    t1, t2, t3 = tip
    g1, g2, g3 = goal
    e1, e2, e3 = g1 - t1, g2 - t2, g3 - t3
    entries = [t1, t2, t3, g1, g2, g3, e1, e2, e3,
               _tanh(e1 / ERROR_SCALE), _tanh(e2 / ERROR_SCALE), _tanh(e3 / ERROR_SCALE)]
    entries += _state_entries(tensions, lengths, constants)
    return entries, (e1, e2, e3)


def _state_entries(tensions, lengths, constants) -> list:
    """[T_i / T_max] and [(l_i − ℓ)/(π r)] (i = 1, 2, 3): the last 6 entries of either
    observation (components as in :func:`_flat_entries`)."""
    max_tension, backbone_length, length_span = constants
    return [
        tensions[0] / max_tension,
        tensions[1] / max_tension,
        tensions[2] / max_tension,
        (lengths[0] - backbone_length) / length_span,
        (lengths[1] - backbone_length) / length_span,
        (lengths[2] - backbone_length) / length_span,
    ]


def _goal_entries(tip, tensions, lengths, constants) -> list:
    """The 9 entries of the goal-conditioned ``observation``, in order (components as above)."""
    return [tip[0], tip[1], tip[2], *_state_entries(tensions, lengths, constants)]


def _components(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=np.float64)
    return x[..., 0], x[..., 1], x[..., 2]


def _stack_f32(entries: list) -> np.ndarray:
    """Stack component entries along a new last axis as float32 (broadcasting them)."""
    return np.stack(np.broadcast_arrays(*entries), axis=-1).astype(np.float32)


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
    entries, _ = _flat_entries(
        _components(tip),
        _components(goal),
        _components(tensions),
        _components(lengths),
        _observation_constants(params),
    )
    return _stack_f32(entries)


def goal_observation(
    tip: np.ndarray, tensions: np.ndarray, lengths: np.ndarray, params: RobotParams
) -> np.ndarray:
    """The goal-free ``observation`` (..., 9) float32 of the goal-conditioned variant.

    [tip (3) m, tensions/max_tension (3), (cable length − ℓ)/(π r) (3)]
    """
    return _stack_f32(
        _goal_entries(
            _components(tip),
            _components(tensions),
            _components(lengths),
            _observation_constants(params),
        )
    )


def reward_from_distance(distance: np.ndarray, reward_type: str, threshold: float) -> np.ndarray:
    """Reward for a tip-to-goal ``distance`` (m): −distance (dense) or −(distance > threshold)."""
    if reward_type == "dense":
        return -distance
    return -((distance > threshold) * 1.0)
