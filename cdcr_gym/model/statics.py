"""Cable tensions ↔ bending with coupled tendon moments; tension IK; the reachable bending set.

Pure-moment statics (frictionless cables routed parallel to the backbone, no gravity, dense
disks; docs/model.md): the curvature vector of section j in its own frame is

    κ_j = w_j/ℓ_j = (1/EI) · Σ_{cables i through section j} T_i · v_i,   v_i = r_i (cos β_i, sin β_i),

so a cable of section m bends every section 1…m. Because a cable sits at the same place in every
disk, the moment a distal cable puts on a proximal section equals the one it puts on its own, and
the cables *of* section j must supply exactly

    m_j = EI·(κ_j − κ_{j+1})          (κ_{S+1} = 0).

The sections therefore decouple for tension IK: section j's own cables, at vectors v_i on a
circle, must give m_j with non-negative tensions. The minimal-sum solution uses the two cables of
the edge of the polygon conv{v_i} that the ray of m_j crosses (an LP whose optimum is at a
vertex); for 3 cables at 120° it equals T_i = (2/3)·(EI/(rℓ))·(w·u_i − min_k w·u_k). With 3
cables per section the minimal-sum tensions are also componentwise minimal, so "minimal tensions
<= max_tension" is exactly the set of shapes the tension box reaches; with more cables per
section it is the (documented, conservative) subset reachable by two cables per direction.

Units: N, m, rad. Functions broadcast over leading dimensions.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np

from cdcr_gym.model.arc import arc_from_bending, as_finite, bending_from_arc
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import CABLE_ANGLES, RobotParams

__all__ = [
    "minimal_tensions",
    "reachable_scale",
    "common_mode",
    "cached_model",
    "arc_from_tensions",
    "tensions_from_arc",
    "bending_limit",
    "payload_test_tensions",
    "check_tip_payload",
    "CABLE_DIRECTIONS",
]

#: Unit vectors u_i = (cos β_i, sin β_i) of the paper's three cables, shape (3, 2).
CABLE_DIRECTIONS = np.stack([np.cos(CABLE_ANGLES), np.sin(CABLE_ANGLES)], axis=-1)


class _SectionSolver:
    """Minimal-sum non-negative tensions of one section's own cables for a moment (N·m)."""

    def __init__(self, vectors: np.ndarray) -> None:
        n = len(vectors)
        order = np.argsort(np.arctan2(vectors[:, 1], vectors[:, 0]))
        # candidate tensions of edge k (cables a, b consecutive in angle): (m @ q[:, k, :])
        q = np.zeros((2, n, n))
        for k in range(n):
            a, b = order[k], order[(k + 1) % n]
            inv = np.linalg.inv(np.stack([vectors[a], vectors[b]], axis=1))  # (2, 2)
            q[:, k, a] = inv[0]
            q[:, k, b] = inv[1]
        self.n = n
        self.q = q.reshape(2, n * n)

    def __call__(self, moment: np.ndarray) -> np.ndarray:
        """Tensions (..., n) (N) for moments (..., 2) (N·m)."""
        # elementwise, not a matmul: a row's result must not depend on the batch it is in
        cand = (moment[..., 0, None] * self.q[0] + moment[..., 1, None] * self.q[1]).reshape(
            moment.shape[:-1] + (self.n, self.n)
        )
        best = np.argmax(cand.min(axis=-1), axis=-1)  # the edge whose two tensions are >= 0
        return np.take_along_axis(cand, best[..., None, None], axis=-2)[..., 0, :]


@lru_cache(maxsize=32)
def _tables(params: RobotParams):
    """Per-section solvers, cable indices and positive common modes (cached per robot)."""
    model = PCCModel(params)
    solvers, cables, modes = [], [], []
    for j in range(params.n_sections):
        own = np.flatnonzero(model.cable_section == j)
        solver = _SectionSolver(model.cable_vectors[own])
        # z = 1 + minimal(−Σ v_i) > 0 with Σ z_i v_i = 0: a pretension that bends nothing
        modes.append(1.0 + solver(-model.cable_vectors[own].sum(axis=0)))
        solvers.append(solver)
        cables.append(own)
    return model, solvers, cables, np.concatenate(modes)


def cached_model(params: RobotParams) -> PCCModel:
    """The :class:`PCCModel` of ``params``, built once per robot (cached)."""
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    return _tables(params)[0]


def common_mode(params: RobotParams) -> np.ndarray:
    """Tensions per newton of pretension, shape (C,), >= 1, that bend no section.

    Per section z = 1 + (minimal tensions of −Σ_i v_i): Σ z_i v_i = 0. For cables evenly spaced
    around the backbone (the presets) z = (1, …, 1).
    """
    return _tables(params)[3].copy()


def _check_pretension(pretension, params: RobotParams) -> float:
    try:
        pretension = float(pretension)
    except (TypeError, ValueError):
        raise ValueError(f"pretension must be a number >= 0 N, got {pretension!r}") from None
    if not math.isfinite(pretension) or pretension < 0.0:
        raise ValueError(f"pretension must be finite and >= 0 N, got {pretension!r}")
    return pretension


def _model_of(model) -> PCCModel:
    if isinstance(model, PCCModel):
        return model
    raise ValueError(f"model must be a PCCModel, got {model!r}")


def minimal_tensions(model: PCCModel, w, pretension: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Tension IK: the minimal non-negative tensions that hold the shape w, clipped.

    Args:
        model: the robot's :class:`PCCModel`.
        w: bending vectors, shape (..., S, 2), rad.
        pretension: added along :func:`common_mode` (N, >= 0; all ones for evenly spaced
            cables): every cable carries at least this much, and the shape is unchanged.

    Returns:
        ``(tensions, clipped)``: tensions (..., C) in N, clipped to [0, max_tension]; ``clipped``
        (...) bool, True where clipping changed a tension by more than 1e-12·max_tension (the
        shape is outside what the tension limit allows, see :func:`reachable_scale`).
    """
    model = _model_of(model)
    pretension = _check_pretension(pretension, model.params)
    tensions = _minimal(model, w)
    if pretension:
        tensions = tensions + pretension * _tables(model.params)[3]
    t_max = model.params.max_tension
    limited = np.clip(tensions, 0.0, t_max)
    # rounding on the boundary (a shape scaled by reachable_scale) is not reported as clipping
    return limited, np.any(np.abs(limited - tensions) > 1e-12 * t_max, axis=-1)


def _minimal(model: PCCModel, w) -> np.ndarray:
    """Unclipped minimal-sum tensions (..., C) (N) of the shape w (..., S, 2)."""
    w = as_finite("w", w)
    S = model.n_sections
    if w.shape[-2:] != (S, 2):
        raise ValueError(f"w must have shape (..., {S}, 2), got shape {w.shape}")
    _, solvers, cables, _ = _tables(model.params)
    moment = w * (model.params.bending_stiffness / model.section_lengths)[:, None]  # EI κ_j
    if S > 1:
        moment = np.concatenate(
            [moment[..., :-1, :] - moment[..., 1:, :], moment[..., -1:, :]], axis=-2
        )
    if S == 1:
        return solvers[0](moment[..., 0, :])
    out = np.empty(w.shape[:-2] + (model.n_cables,))
    for j in range(S):
        out[..., cables[j]] = solvers[j](moment[..., j, :])
    return out


def reachable_scale(model: PCCModel, w) -> np.ndarray:
    """Factor s in (0, 1], shape (...), that brings the shape w (..., S, 2) into the reachable set.

    s = T_max / max(max_i T_i(w), T_max) with the minimal tensions T(w) (no pretension); they
    are positively homogeneous in w, so s·w is w itself when reachable and otherwise w scaled
    radially (all sections together) onto the boundary of the tension-reachable set.
    """
    model = _model_of(model)
    t_max = model.params.max_tension
    return t_max / np.maximum(np.max(_minimal(model, w), axis=-1), t_max)


# -- one-section compatibility (the former cdcr_gym.statics API, any one-section cable layout) ----


def _one_section(params) -> RobotParams:
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    if params.n_sections != 1:
        raise ValueError(
            f"params must describe a one-section robot for this function, got "
            f"{params.n_sections} sections (use PCCModel and minimal_tensions)"
        )
    return params


def arc_from_tensions(tensions, params: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """Bending of a one-section robot under cable tensions.

    Args:
        tensions: cable tensions, shape (..., C), N, finite and >= 0.
        params: a one-section robot.

    Returns:
        ``(theta, phi)``, each of shape (...): bending angle θ = κℓ (rad) and bending-plane angle
        (rad, towards the pulling cables; 0 when θ = 0).
    """
    params = _one_section(params)
    tensions = as_finite("tensions", tensions, params.n_cables)
    if np.any(tensions < 0.0):
        raise ValueError(f"tensions must be >= 0 N (a cable cannot push), got {tensions!r}")
    w = _tables(params)[0].bending_from_tensions(tensions)
    return arc_from_bending(w[..., 0, :])


def tensions_from_arc(
    theta, phi, params: RobotParams, pretension: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Tension IK of a one-section robot: the smallest non-negative tensions that give (θ, φ).

    Args:
        theta: wanted bending angle, shape (...), rad (>= 0).
        phi: wanted bending-plane angle, shape (...), rad.
        params: a one-section robot.
        pretension: common-mode tension (N, >= 0) added to all cables (along
            :func:`common_mode`); it does not bend.

    Returns:
        ``(tensions, clipped)``: tensions (..., C) in N, clipped to [0, params.max_tension];
        ``clipped`` (...) bool, True where clipping changed a tension.
    """
    params = _one_section(params)
    theta = as_finite("theta", theta)
    if np.any(theta < 0.0):
        raise ValueError(f"theta (bending angle) must be >= 0 rad, got {theta!r}")
    phi = as_finite("phi", phi)
    w = bending_from_arc(theta, phi)[..., None, :]
    return minimal_tensions(_tables(params)[0], w, pretension)


def bending_limit(phi, params: RobotParams, pretension: float = 0.0) -> np.ndarray:
    """Largest bending angle θ (rad) reachable in plane φ with tensions in [0, max_tension].

    Along the direction u = (cos φ, sin φ) the minimal tensions are a·s for a moment s·u
    (a = minimal tensions of the unit moment), plus p·z for a pretension p; the limit is the
    largest s with a_i·s + p·z_i <= T_max for all cables, θ = s·ℓ/EI. For the paper's robot the
    reachable curvatures form a regular hexagon: θ_max = T_max·r·ℓ/EI at φ = 0°, 60°, …,
    θ_max·cos 30° mid-edge.

    Args:
        phi: bending-plane angle, shape (...), rad.
        params: a one-section robot.
        pretension: common-mode tension (N), with pretension·max(common_mode) < max_tension.

    Returns:
        θ limit, shape (...), rad.
    """
    params = _one_section(params)
    pretension = _check_pretension(pretension, params)
    model, solvers, _, modes = _tables(params)
    headroom = params.max_tension - pretension * modes  # (C,)
    if np.any(headroom <= 0.0):
        raise ValueError(
            f"pretension must leave room below max_tension={params.max_tension} N "
            f"(pretension·{np.max(modes):.6g} < max_tension), got {pretension!r}"
        )
    phi = as_finite("phi", phi)
    unit = solvers[0](np.stack([np.cos(phi), np.sin(phi)], axis=-1))  # N per N·m
    ratio = np.where(unit > 0.0, headroom / np.where(unit > 0.0, unit, 1.0), np.inf)
    return np.min(ratio, axis=-1) * params.length / params.bending_stiffness


def payload_test_tensions(params: RobotParams) -> np.ndarray:
    """The tension-box corners at which a tip payload must be held, shape (1 + C + C(C−1)/2, C) N.

    No tension, then each cable alone at ``max_tension``, then each pair of cables at
    ``max_tension``: the most bent shapes the robot takes (goals and random starts are drawn
    from them), where a payload's weight has the longest lever arm.
    """
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    c, top = params.n_cables, params.max_tension
    eye = np.eye(c)
    corners = [np.zeros(c)]
    corners += [eye[i] * top for i in range(c)]
    corners += [(eye[i] + eye[j]) * top for i in range(c) for j in range(i)]
    return np.stack(corners)


def check_tip_payload(
    tip_payload: float,
    params: RobotParams,
    gravity: bool,
    has_equilibrium: Callable[[np.ndarray], bool],
) -> None:
    """Refuse a tip payload that the robot cannot hold under gravity, naming ``tip_payload``.

    The shared check of the physics backends: ``has_equilibrium(tensions)`` ((C,) N → bool)
    is the backend's own static solve (its discretisation, its gravity in the base frame), and
    it must find an equilibrium at every :func:`payload_test_tensions` corner. Without this
    check, such a payload is accepted and resets then fail with "no static equilibrium" (or
    the dynamics fold the robot over). The limit is that of the backend's solve (a fixed-point
    iteration from the straight pose), which also stops converging when a hanging payload
    stiffens the chain more than its joints: so it is the heaviest payload the backend's resets
    handle, not a buckling load. Nothing is checked when ``tip_payload`` is 0 or
    ``gravity`` is off (a payload without weight bends nothing).

    Args:
        tip_payload: point mass (kg, >= 0) at the tip disk centre, already validated.
        params: the robot.
        gravity: whether gravity acts.
        has_equilibrium: the backend's static solve of one tension vector (C,) N.

    Raises:
        ValueError: naming ``tip_payload`` and the first tensions with no equilibrium.
    """
    if tip_payload == 0.0 or not gravity:
        return
    for t in payload_test_tensions(params):
        if not has_equilibrium(t):
            raise ValueError(
                f"tip_payload={tip_payload!r} kg is more than this robot holds under "
                f"gravity: the static solve from the straight pose finds no equilibrium with "
                f"tensions {t.tolist()} N (the payload's weight overpowers the bent backbone), "
                f"so resets there would fail; use a lighter tip_payload, gravity=False, a "
                f"stiffer backbone or a lower max_tension"
            )
