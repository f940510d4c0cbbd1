"""A model-based safety filter: tension commands corrected so that the predicted shape keeps
clear of the task's obstacles (a control-barrier-function projection, batched).

Every step, the commanded tensions T_cmd (N, C) N are checked on the model before the backend
gets them: the clearance h(T) (m) of the PCC/CCKA shape held by tensions T to the episode's
spheres (``Task.model_clearance``; negative = a collision). A command with h(T_cmd) >= margin
passes unchanged. Otherwise, from the held tensions T_0 (what the robot holds now):

1. the gradient g = ∂h/∂T at T_0 by central differences (step 0.1 % of max_tension, one-sided
   at the tension bounds);
2. the command is projected onto the half-space of the linearised barrier condition
   h(T_0) + g·(T − T_0) >= margin + γ·(h(T_0) − margin) (γ = 1/2: at most half of the
   remaining slack is used in a step; inside the margin, h(T_0) < margin, the condition is
   h >= h(T_0): no closer than now), within what the action can command (T_0 ± the largest
   tension change per step in ``tension_delta`` mode, and [0, max_tension]): the nearest such
   command (Euclidean, in N), T = clip(T_cmd + μ g, bounds) with the least μ >= 0
   (:func:`project_onto_half_space`) — motion along the sphere's surface is kept, only the
   motion into it removed;
3. the result is checked on the model against h >= min(margin, h(T_0)); if it fails (the
   barrier is not linear), the step from T_0 is halved (1/2, 1/4, 1/8) and finally dropped:
   holding T_0 always satisfies it.

A command passes unchanged when h(T_cmd) >= min(margin, h(T_0)).

The env passes the clearance measured on the robot after the last step; every prediction is
shifted by (measured − model at T_0), the model's shape error taken as constant over a step. On
the analytic backend without friction the offset is 0 and the prediction is the backend itself:
the robot never touches a sphere that the held shape is clear of. On a physics backend
(gravity, dynamics) or with friction it is a corrected model prediction — a margin > 0 absorbs
part of what remains (overshoot); collisions stay possible and are measured as usual.

What it guarantees on MuJoCo: every command it passes has a *static* shape (the CCKA shape,
shifted by the measured offset) no closer than ``min(margin, clearance now)`` to a sphere; it
never commands the robot further into a sphere than the static prediction allows. It does not
bound the dynamics: a robot still moving from the last command (bang-bang tensions swing the
tip ~0.1 m per 0.02 s step) can overshoot into a sphere within one step. With
``solid_obstacles=True`` the contact then stops it and pushes it out over the next steps (a
robot held against a sphere rests within ~1 mm of its surface); the backend raises
``SimulationDivergedError`` rather than report a state no shape has (a section bent past 180°).

This is a deployment layer, not a learned behaviour: a policy under the filter is a different
agent from the policy alone (docs/tasks.md reports both, and the greedy reach IK under the
same filter).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["SafetyFilter"]

#: Fraction γ of the remaining clearance slack one step may use (the barrier's decay rate).
SLACK_FRACTION = 0.5
#: Shrink factors of the projected step tried before holding the tensions.
STEP_FRACTIONS = (0.5, 0.25, 0.125)
#: Finite-difference step of the clearance gradient, as a fraction of max_tension.
GRADIENT_STEP = 1e-3


def project_onto_half_space(
    point: np.ndarray, normal: np.ndarray, offset: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """Row-wise nearest point (M, C) to ``point`` (M, C) with normal·x >= offset (M,) and
    lo <= x <= hi: x = clip(point + μ·normal, lo, hi) with the least μ >= 0 that satisfies the
    half-space (KKT of the box-constrained projection), μ found by bisection (φ(μ) = normal·x
    is non-decreasing). Rows where the box cannot reach the half-space get the box point
    farthest along ``normal``."""

    def along(mu: np.ndarray) -> np.ndarray:
        return np.sum(normal * np.clip(point + mu[:, None] * normal, lo, hi), axis=1)

    norm2 = np.sum(normal * normal, axis=1)
    safe_norm2 = np.where(norm2 > 0.0, norm2, 1.0)
    low = np.zeros(len(point))
    high = np.maximum(offset - np.sum(normal * point, axis=1), 0.0) / safe_norm2
    for _ in range(64):  # the unclipped solution, doubled until the clipped one gets there
        short = along(high) < offset
        if not short.any():
            break
        high = np.where(short, 2.0 * high + 1e-12, high)
    for _ in range(60):
        mid = 0.5 * (low + high)
        reached = along(mid) >= offset
        high = np.where(reached, mid, high)
        low = np.where(reached, low, mid)
    return np.clip(point + high[:, None] * normal, lo, hi)


class SafetyFilter:
    """Corrects tension commands whose predicted shape comes closer than ``margin`` to an
    obstacle (see the module docstring).

    Args:
        clearance: ``clearance(tensions (M, C) N, rows (M,) env indices) -> (M,) m``: the
            predicted clearance of env ``rows[k]``'s robot held by ``tensions[k]``.
        max_tension: largest cable tension (N).
        max_step: largest tension change per step (N) a command can make, or None (absolute
            tension commands: any change within [0, max_tension]).
        margin: the clearance (m, >= 0) a command must keep.
    """

    def __init__(
        self,
        clearance: Callable[[np.ndarray, np.ndarray], np.ndarray],
        max_tension: float,
        max_step: float | None,
        margin: float,
    ) -> None:
        self.clearance = clearance
        self.max_tension = float(max_tension)
        self.max_step = None if max_step is None else float(max_step)
        self.margin = float(margin)

    def bounds(self, held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lowest and highest tensions (M, C) N a command can reach from ``held`` (M, C)."""
        if self.max_step is None:
            return np.zeros_like(held), np.full_like(held, self.max_tension)
        lo = np.maximum(held - self.max_step, 0.0)
        hi = np.minimum(held + self.max_step, self.max_tension)
        return lo, hi

    def gradient(self, held: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """∂(clearance)/∂(tensions) (M, C) m/N at ``held`` (M, C), by central differences
        (one-sided where a tension is at a bound)."""
        m, c = held.shape
        h = GRADIENT_STEP * self.max_tension
        eye = np.eye(c)[None]  # (1, C, C)
        up = np.clip(held[:, None, :] + h * eye, 0.0, self.max_tension)  # (M, C, C)
        down = np.clip(held[:, None, :] - h * eye, 0.0, self.max_tension)
        both = np.concatenate([up, down], axis=1).reshape(2 * m * c, c)
        gaps = self.clearance(both, np.repeat(rows, 2 * c)).reshape(m, 2, c)
        width = np.diagonal(up - down, axis1=1, axis2=2)  # (M, C): 2h, or h at a bound
        return (gaps[:, 0] - gaps[:, 1]) / width

    def __call__(
        self, commanded: np.ndarray, held: np.ndarray, measured: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Safe tensions (N, C) N for ``commanded`` (N, C) N given the ``held`` ones (N, C), and
        which envs' commands were changed ((N,) bool). Neither input is modified.

        ``measured`` (N,) m: the clearance measured on the robot now (None: the model's). The
        model's predictions are then shifted by measured − model(held) per env — the shape
        error of the model (gravity, friction) taken as constant over one step.
        """
        n = commanded.shape[0]
        rows = np.arange(n)
        model_now = self.clearance(held, rows)
        offset = np.zeros(n)
        if measured is not None:
            offset = np.asarray(measured, dtype=np.float64) - model_now
            offset[~np.isfinite(offset)] = 0.0
        now = model_now + offset
        gap = self.clearance(commanded, rows) + offset
        unsafe = gap < np.minimum(self.margin, now)
        if not unsafe.any():
            return commanded, unsafe
        out = commanded.copy()
        idx = np.flatnonzero(unsafe)
        out[idx] = self._correct(commanded[idx], held[idx], idx, offset[idx], now[idx])
        return out, unsafe

    def _correct(
        self,
        commanded: np.ndarray,
        held: np.ndarray,
        rows: np.ndarray,
        offset: np.ndarray,
        now: np.ndarray,
    ) -> np.ndarray:
        """The projection and its fall-backs for the M unsafe commands (M, C) of envs ``rows``
        (``offset`` (M,) m added to every predicted clearance, ``now`` (M,) m the clearance at
        the held tensions)."""
        margin = self.margin
        required = np.minimum(margin, now)
        grad = self.gradient(held, rows)
        target = np.where(now >= margin, margin + SLACK_FRACTION * (now - margin), now)
        lo, hi = self.bounds(held)
        projected = project_onto_half_space(
            commanded, grad, target - now + np.sum(grad * held, 1), lo, hi
        )
        best = held.copy()  # holding always keeps the required clearance
        chosen = np.zeros(len(rows), dtype=bool)
        for f in (1.0, *STEP_FRACTIONS):
            tensions = held + f * (projected - held)
            take = ~chosen & (self.clearance(tensions, rows) + offset >= required)
            best[take] = tensions[take]
            chosen |= take
            if chosen.all():
                break
        return best
