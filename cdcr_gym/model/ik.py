"""Inverse kinematics within the tension limits: tip position (and tip direction) → tensions.

Pure numpy, batched over goals, deterministic.

* One section (:func:`solve_ik`): closed form (``arc.arc_from_tip``) when its arc is within the
  tension limit θ <= θ_lim(φ); otherwise the nearest tip of the tension-reachable region, the
  best of (a) the nearest arc in the goal's bending plane and in the opposite one with θ clamped
  to [0, θ_lim] (grid + projected Newton) and (b) the nearest point of the limit curve
  θ = θ_lim(φ) (grid over φ + golden-section refinement). An interior minimiser of the distance
  lies in one of those two planes, so (a) and (b) together find the nearest reachable tip.
* Several sections: damped Gauss–Newton (Levenberg–Marquardt) on the cable tensions, kept in
  the box [0, max_tension] by the substitution T = max_tension·sin²ξ, minimum-norm steps; run
  from a fixed set of starting tensions. Among the runs that reach the goal (residual < 1e-10 m)
  the solution of least total (minimal) tension is returned; if none does, the one nearest the
  goal. The returned tensions are the minimal tensions of the solution's shape
  (``statics.minimal_tensions``), so one cable per section is slack.

``residual`` reports the distance (m) between the goal and the tip reached: goals that are not
reachable within the tension limits show up there.

* Displacement drives (:func:`solve_displacement_ik`): the drive displacements d within
  ``displacement_range`` whose quasi-static equilibrium through the compliant one-sided tendons
  (``tendons.solve_displacement_statics``: T = clip(T0 + k(d − s), 0, T_max)) puts the tip at the
  goal. The minimal tensions of a shape are not always reachable by the drives: a slack cable's
  slack point s − T0/k can lie below the range's lower end (then the clipped command pulls it
  taut: centimetres of tip error), so the search runs on d itself (Levenberg–Marquardt, d kept in
  the range by d = d_min + (d_max − d_min)·sin²ξ, Jacobian exact on the statics' active set).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cdcr_gym.model.arc import (
    arc_from_tip,
    arc_profile,
    as_finite,
    bending_from_arc,
    in_plane_distance,
    newton_nearest,
)
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import bending_limit, cached_model, minimal_tensions
from cdcr_gym.model.tendons import (
    holding_displacements,
    shortening_matrix,
    solve_displacement_statics,
)

__all__ = [
    "IKSolution",
    "DisplacementIKSolution",
    "solve_ik",
    "solve_pose_ik",
    "solve_displacement_ik",
    "drive_displacements",
]


class IKSolution(NamedTuple):
    """Result of :func:`solve_ik` / :func:`solve_pose_ik` (batched over goals).

    Attributes:
        tensions: cable tensions (..., C), N, within [0, max_tension].
        bending: bending vectors (..., S, 2), rad.
        tip: tip position reached (..., 3), m.
        residual: distance from the goal position to ``tip`` (...), m.
        angle_residual: angle (rad) between the wanted and the reached tip direction (...), for
            :func:`solve_pose_ik`; ``None`` for :func:`solve_ik`.
    """

    tensions: np.ndarray
    bending: np.ndarray
    tip: np.ndarray
    residual: np.ndarray
    angle_residual: np.ndarray | None = None


def _check_params(params) -> RobotParams:
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    return params


def _finish(model: PCCModel, w: np.ndarray, goal: np.ndarray) -> IKSolution:
    tensions, _ = minimal_tensions(model, w)
    w = model.bending_from_tensions(tensions)
    tip = model.tip_from_bending(w)
    return IKSolution(tensions, w, tip, np.linalg.norm(tip - goal, axis=-1))


def solve_ik(goal, params: RobotParams) -> IKSolution:
    """Tensions that put the tip at ``goal`` (or as near as the tension limits allow).

    Args:
        goal: wanted tip positions in R0, shape (..., 3), m.
        params: the robot.

    Returns:
        An :class:`IKSolution`; ``residual`` > 0 marks goals outside the reachable set.
    """
    params = _check_params(params)
    goal = as_finite("goal", goal, 3)
    model = cached_model(params)
    flat = goal.reshape(-1, 3)
    if params.n_sections == 1:
        w = _one_section_bending(flat, params)
    else:
        w = _numerical(model, flat, None)
    sol = _finish(model, w, flat)
    batch = goal.shape[:-1]
    return IKSolution(
        sol.tensions.reshape(batch + (model.n_cables,)),
        sol.bending.reshape(batch + (model.n_sections, 2)),
        sol.tip.reshape(batch + (3,)),
        sol.residual.reshape(batch),
    )


# -- one section -----------------------------------------------------------------------------


def _one_section_bending(goal: np.ndarray, params: RobotParams) -> np.ndarray:
    """Bending vectors (M, 1, 2) of the nearest tension-reachable tips to goals (M, 3)."""
    length = params.length
    theta, phi, _ = arc_from_tip(goal, length)
    limit = bending_limit(phi, params)
    outside = theta > limit * (1.0 + 1e-12)
    theta = np.minimum(theta, limit)  # a last-bit excess on the limit curve itself
    if np.any(outside):
        th_o, ph_o = _nearest_reachable(goal[outside], params)
        theta[outside], phi[outside] = th_o, ph_o
    return bending_from_arc(theta, phi)[:, None, :]


def _tip_distance(theta, phi, goal, length):
    f, g = arc_profile(theta)
    lf = length * f * theta
    return np.sqrt(
        (goal[..., 0] - lf * np.cos(phi)) ** 2
        + (goal[..., 1] - lf * np.sin(phi)) ** 2
        + (goal[..., 2] - length * g) ** 2
    )


def _nearest_reachable(goal: np.ndarray, params: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """(θ, φ) (M,) of the nearest tip with θ <= θ_lim(φ) to goals (M, 3) off the region."""
    length = params.length
    x, y, z = goal[:, 0], goal[:, 1], goal[:, 2]
    rho = np.hypot(x, y)
    phi_goal = np.where(rho == 0.0, 0.0, np.arctan2(y, x))
    best_theta = np.zeros(len(goal))
    best_phi = np.zeros(len(goal))
    best = _tip_distance(best_theta, best_phi, goal, length)
    # (a) in the goal's plane and the opposite one, θ clamped to the limit there
    grid = np.linspace(0.0, 1.0, 65)
    for side, phi_side in ((1.0, phi_goal), (-1.0, phi_goal + np.pi)):
        upper = bending_limit(phi_side, params)
        dist = in_plane_distance(grid * upper[:, None], side * rho[:, None], z[:, None], length)
        start = grid[np.argmin(dist, axis=-1)] * upper
        cand = newton_nearest(start, side * rho, z, length, upper)
        d = _tip_distance(cand, phi_side, goal, length)
        better = d < best
        best, best_theta, best_phi = (
            np.where(better, d, best),
            np.where(better, cand, best_theta),
            np.where(better, phi_side, best_phi),
        )
    # (b) on the limit curve θ = θ_lim(φ)
    n_grid = 720
    step = 2.0 * np.pi / n_grid
    phis = -np.pi + step * np.arange(n_grid)
    lims = bending_limit(phis, params)
    dist = _tip_distance(lims[None, :], phis[None, :], goal[:, None, :], length)
    lo = phis[np.argmin(dist, axis=-1)] - step
    hi = lo + 2.0 * step
    ratio = 0.5 * (np.sqrt(5.0) - 1.0)

    def curve(p):
        return _tip_distance(bending_limit(p, params), p, goal, length)

    c, d_ = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fc, fd = curve(c), curve(d_)
    for _ in range(60):
        left = fc < fd
        hi = np.where(left, d_, hi)
        lo = np.where(left, lo, c)
        new_c = hi - ratio * (hi - lo)
        new_d = lo + ratio * (hi - lo)
        c_next = np.where(left, new_c, d_)
        d_next = np.where(left, c, new_d)
        fc_next = np.where(left, curve(new_c), fd)
        fd_next = np.where(left, fc, curve(new_d))
        c, d_, fc, fd = c_next, d_next, fc_next, fd_next
    cand_phi = 0.5 * (lo + hi)
    cand_theta = bending_limit(cand_phi, params)
    d = _tip_distance(cand_theta, cand_phi, goal, length)
    better = d < best
    best_theta = np.where(better, cand_theta, best_theta)
    best_phi = np.where(better, cand_phi, best_phi)
    return best_theta, best_phi


# -- several sections: Levenberg–Marquardt on the tensions -------------------------------------

_STARTS = (0.5, 0.25, 0.75)  # fractions of max_tension for the start patterns below
_TOL = 1e-10  # m (and rad·length for poses): a run "reaches" the goal below this residual


def _start_patterns(model: PCCModel) -> np.ndarray:
    """Deterministic starting tensions (K, C) as fractions of max_tension in (0, 1)."""
    c = model.n_cables
    rows = [np.full(c, s) for s in _STARTS]
    alternating = np.where(np.arange(c) % 2 == 0, 0.3, 0.7)
    rows += [alternating, 1.0 - alternating]
    return np.asarray(rows)


def _residuals(model: PCCModel, tensions: np.ndarray, goal, direction, scale):
    """Stacked residuals (..., 3 or 6): tip − goal and scale·(tangent − direction)."""
    w = model.bending_from_tensions(tensions)
    if direction is None:
        return model.tip_from_bending(w) - goal
    tip, tangent = model.tip_and_direction_from_bending(w)
    return np.concatenate([tip - goal, scale * (tangent - direction)], axis=-1)


def _numerical(
    model: PCCModel,
    goal: np.ndarray,
    direction: np.ndarray | None,
    iterations: int = 200,
    every_run: bool = False,
) -> np.ndarray:
    """Bending vectors (M, S, 2) solving the tip (and direction) goals (M, 3) by LM; with
    ``every_run`` those of every start pattern, (K, M, S, 2)."""
    t_max = model.params.max_tension
    scale = float(np.sum(model.section_lengths))
    starts = _start_patterns(model)  # (K, C)
    k, c, m = len(starts), model.n_cables, len(goal)
    xi = np.broadcast_to(np.arcsin(np.sqrt(starts))[:, None, :], (k, m, c)).copy()
    g = np.broadcast_to(goal, (k, m, 3))
    d = None if direction is None else np.broadcast_to(direction, (k, m, 3))
    h = 1e-7
    eye = np.eye(c)

    def evaluate(xi_):
        return _residuals(model, t_max * np.sin(xi_) ** 2, g, d, scale)

    r = evaluate(xi)
    cost = np.sum(r * r, axis=-1)
    mu = np.full((k, m), 1e-3)
    for _ in range(iterations):
        if np.all(cost < _TOL**2 * 1e-4):
            break
        # central differences in ξ (C columns), all at once
        pert = xi[..., None, :] + h * eye  # (K, M, C, C)
        back = xi[..., None, :] - h * eye
        jac = (
            _residuals(
                model,
                t_max * np.sin(pert) ** 2,
                g[..., None, :],
                None if d is None else d[..., None, :],
                scale,
            )
            - _residuals(
                model,
                t_max * np.sin(back) ** 2,
                g[..., None, :],
                None if d is None else d[..., None, :],
                scale,
            )
        ) / (2.0 * h)
        jac = np.swapaxes(jac, -1, -2)  # (K, M, E, C)
        jtj = np.swapaxes(jac, -1, -2) @ jac
        jtr = (np.swapaxes(jac, -1, -2) @ r[..., None])[..., 0]
        damp = mu[..., None, None] * (np.trace(jtj, axis1=-2, axis2=-1)[..., None, None] + 1e-30)
        step = np.linalg.solve(jtj + damp * eye, -jtr[..., None])[..., 0]
        trial = xi + step
        r_trial = evaluate(trial)
        cost_trial = np.sum(r_trial * r_trial, axis=-1)
        better = cost_trial < cost
        xi = np.where(better[..., None], trial, xi)
        r = np.where(better[..., None], r_trial, r)
        cost = np.where(better, cost_trial, cost)
        mu = np.clip(np.where(better, mu / 5.0, mu * 4.0), 1e-15, 1e6)
    tensions = t_max * np.sin(xi) ** 2  # (K, M, C)
    w = model.bending_from_tensions(tensions)
    if every_run:
        return w
    effort = np.sum(minimal_tensions(model, w)[0], axis=-1)  # (K, M)
    reached = np.sqrt(cost) < _TOL
    # least effort among the runs that reached the goal, else the nearest run
    key = np.where(reached, effort, np.inf)
    pick = np.where(np.any(reached, axis=0), np.argmin(key, axis=0), np.argmin(cost, axis=0))
    return np.take_along_axis(w, pick[None, :, None, None], axis=0)[0]


def solve_pose_ik(position, direction, params: RobotParams) -> IKSolution:
    """Tensions that put the tip at ``position`` with its tangent along ``direction``.

    Least squares of (tip − position, ℓ_total·(tangent − direction)) by the same LM on the
    tensions as :func:`solve_ik` (robots of any number of sections; a one-section robot has only
    2 shape degrees of freedom, so most poses are reachable only approximately).

    Args:
        position: wanted tip positions in R0, shape (..., 3), m.
        direction: wanted tip tangents in R0, shape (..., 3) (normalised here; non-zero).
        params: the robot.

    Returns:
        An :class:`IKSolution` with ``angle_residual`` (rad) between the wanted and the reached
        tangent.
    """
    params = _check_params(params)
    position = as_finite("position", position, 3)
    direction = as_finite("direction", direction, 3)
    norm = np.linalg.norm(direction, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise ValueError("direction must be non-zero vectors (the wanted tip tangent)")
    position, direction = np.broadcast_arrays(position, direction / norm)
    batch = position.shape[:-1]
    model = cached_model(params)
    p_flat, d_flat = position.reshape(-1, 3), direction.reshape(-1, 3)
    w = _numerical(model, p_flat, d_flat)
    sol = _finish(model, w, p_flat)
    tangent = model.tip_direction_from_bending(sol.bending)
    angle = np.arctan2(
        np.linalg.norm(np.cross(tangent, d_flat), axis=-1), np.sum(tangent * d_flat, axis=-1)
    )
    return IKSolution(
        sol.tensions.reshape(batch + (model.n_cables,)),
        sol.bending.reshape(batch + (model.n_sections, 2)),
        sol.tip.reshape(batch + (3,)),
        sol.residual.reshape(batch),
        angle.reshape(batch),
    )


# -- displacement drives ----------------------------------------------------------------------


class DisplacementIKSolution(NamedTuple):
    """Result of :func:`solve_displacement_ik` (batched over goals).

    Attributes:
        displacements: drive displacements (..., C), m, within ``params.displacement_range``.
        tensions: the equilibrium's tendon tensions (..., C), N.
        bending: the equilibrium's bending vectors (..., S, 2), rad.
        tip: tip position reached (..., 3), m.
        residual: distance from the goal to ``tip`` (...), m.
    """

    displacements: np.ndarray
    tensions: np.ndarray
    bending: np.ndarray
    tip: np.ndarray
    residual: np.ndarray


def drive_displacements(tensions, bending, params: RobotParams) -> np.ndarray:
    """Displacements (..., C) m that hold ``tensions`` (..., C) N at the shape ``bending``
    (..., S, 2) rad: d = s(w) + (T − T0)/k + c·Σ(T − T0) (s the shortening of the shape, c the
    robot's ``base_compliance``; k = inf: d = s); a slack cable (T = 0) at its slack point. Not
    clipped to the drives' range."""
    params = _check_params(params)
    model = cached_model(params)
    return holding_displacements(
        model.straight_lengths - model.lengths_from_bending(bending),
        tensions,
        params.cable_stiffness,
        params.cable_pretension,
        params.base_compliance,
    )


def _drive_jacobian(model, h_mat, state, rows, h=1e-6):
    """∂tip/∂d (N, 3, C) at the equilibria ``state[rows]`` (N rows): exact on the active set
    (the free tendons' tensions solve H_FF T_F = d_F + … − H_F,fixed T_fixed with H = K⁻¹ + M +
    c·11ᵀ, the
    others are fixed at 0 or T_max); h (rad) the central-difference step of tip(w)."""
    free = ~(state.slack[rows] | state.saturated[rows])  # (N, C)
    n, c = free.shape
    both = free[:, :, None] & free[:, None, :]
    hm = np.where(both, h_mat, 0.0)
    idx = np.arange(c)
    hm[:, idx, idx] += np.where(free, 0.0, 1.0)
    g = np.where(both, np.linalg.pinv(hm, rcond=1e-12, hermitian=True), 0.0)  # ∂T/∂d (N, C, C)
    s2 = 2 * model.n_sections
    w = state.bending[rows].reshape(n, s2)
    probe = h * np.eye(s2)
    tips = model.tip_from_bending(
        np.concatenate([w[:, None] + probe, w[:, None] - probe], axis=1).reshape(
            n, 2 * s2, model.n_sections, 2
        )
    )
    jw = np.swapaxes((tips[:, :s2] - tips[:, s2:]) / (2.0 * h), 1, 2)  # (N, 3, 2S)
    return jw @ model.tension_to_bending.T @ g


def solve_displacement_ik(
    goal, params: RobotParams, start=None, iterations: int = 100, from_ik: bool = True
) -> DisplacementIKSolution:
    """Drive displacements within ``params.displacement_range`` that put the tip at ``goal``.

    The plant is the quasi-static PCC equilibrium of the compliant one-sided tendon drives
    (:func:`cdcr_gym.model.tendons.solve_displacement_statics` with the robot's stiffness,
    pretension and ``max_tension``: the CCKA backend in a displacement mode). Levenberg–Marquardt
    on d (minimum-norm steps: 3 equations, C unknowns; projected on the range, a drive at a bound
    the descent pushes against held there) with the exact Jacobian of the equilibrium on its
    active set, run from each ``start`` (if given) and from the displacements of
    :func:`solve_ik`'s solution (one section) or of every one of its Levenberg–Marquardt runs
    (several sections: its solution and other shapes for the goal) — their minimal tensions,
    clipped to the range (a slack point below d_min raised to it) — all together. A goal is done as soon as one of its runs reaches
    it (residual < 1e-10 m); the first such run (in the order of the starts) is returned, else
    the one nearest the goal.

    Args:
        goal: wanted tip positions in R0, shape (..., 3), m.
        params: the robot (its drives: ``tendon_stiffness``, ``tendon_pretension``,
            ``displacement_range``).
        start: optional displacements (..., C) m to start from (e.g. the held command), or a
            list of such starts (tried in order).
        iterations: LM iteration budget, >= 1.
        from_ik: also start from :func:`solve_ik`'s solution and runs (after ``start``); at
            least one start is needed.

    Returns:
        A :class:`DisplacementIKSolution`; ``residual`` > 0 marks goals the drives cannot reach.

    Raises:
        ValueError: naming the argument for a goal or start of the wrong shape or not finite.
    """
    params = _check_params(params)
    goal = as_finite("goal", goal, 3)
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)):
        raise ValueError(f"iterations must be an int >= 1, got {iterations!r}")
    if iterations < 1:
        raise ValueError(f"iterations must be >= 1, got {iterations!r}")
    model = cached_model(params)
    c = model.n_cables
    batch = goal.shape[:-1]
    flat = goal.reshape(-1, 3)
    m = len(flat)
    lo, hi = params.displacement_range
    runs = []
    for s0 in [] if start is None else start if isinstance(start, (list, tuple)) else [start]:
        s0 = as_finite("start", s0, c)
        try:
            runs.append(np.broadcast_to(s0, batch + (c,)).reshape(m, c))
        except ValueError:
            raise ValueError(
                f"start must broadcast to {batch + (c,)}, got shape {s0.shape}"
            ) from None
    if from_ik and model.n_sections == 1:
        sol = solve_ik(flat, params)
        runs.append(drive_displacements(sol.tensions, sol.bending, params))
    elif from_ik:  # every LM run of solve_ik (its solution is one): other shapes for the goal
        w = _numerical(model, flat, None, every_run=True)  # (K, M, S, 2)
        tensions = minimal_tensions(model, w.reshape(-1, model.n_sections, 2))[0]
        runs.extend(drive_displacements(tensions.reshape(w.shape[:2] + (c,)), w, params))
    if not runs:
        raise ValueError("solve_displacement_ik needs a start: pass start or from_ik=True")
    d = np.clip(np.stack(runs), lo, hi).reshape(-1, c)  # (K·M, C)
    k_runs = len(runs)
    g = np.broadcast_to(flat, (k_runs, m, 3)).reshape(-1, 3)
    k = np.asarray(params.cable_stiffness, dtype=np.float64)
    t0 = np.asarray(params.cable_pretension, dtype=np.float64)
    h_mat = (
        shortening_matrix(model)
        + np.diag(np.where(np.isfinite(k), 1.0 / k, 0.0))
        + params.base_compliance  # the compliant base: c·11ᵀ
    )

    def equilibrium(d_, goal_, warm=None):
        st = solve_displacement_statics(model, d_, k, t0, params.max_tension, initial_tensions=warm)
        return st, model.tip_from_bending(st.bending) - goal_

    state, r = equilibrium(d, g)
    tensions = state.tensions
    cost = np.sum(r * r, axis=-1)
    mu = np.full(len(d), 1e-3)
    for _ in range(iterations):
        # a goal is done once one of its runs reaches it
        solved = np.any(cost.reshape(k_runs, m) < _TOL**2, axis=0)
        # ... and a run is over once it reaches it or stalls (damping at its cap: no step of
        # any length lowers the cost)
        act = np.flatnonzero(~np.tile(solved, k_runs) & (cost >= _TOL**2 * 1e-4) & (mu < 1e6))
        if act.size == 0:
            break
        jac = _drive_jacobian(model, h_mat, state, act)  # (N, 3, C)
        jtr = (np.swapaxes(jac, -1, -2) @ r[act, :, None])[..., 0]
        # projected LM: a drive at a bound the descent pushes against stays there
        da = d[act]
        pinned = ((da <= lo) & (jtr > 0.0)) | ((da >= hi) & (jtr < 0.0))
        jac = np.where(pinned[:, None, :], 0.0, jac)
        jtj = np.swapaxes(jac, -1, -2) @ jac
        jtr = np.where(pinned, 0.0, jtr)
        damp = mu[act, None, None] * (np.trace(jtj, axis1=-2, axis2=-1)[:, None, None] + 1e-30)
        step = np.linalg.solve(jtj + damp * np.eye(c), -jtr[..., None])[..., 0]
        trial = np.clip(da + step, lo, hi)
        st_trial, r_trial = equilibrium(trial, g[act], tensions[act])
        cost_trial = np.sum(r_trial * r_trial, axis=-1)
        better = cost_trial < cost[act]
        rows = act[better]
        d[rows], r[rows], cost[rows] = trial[better], r_trial[better], cost_trial[better]
        tensions[rows] = st_trial.tensions[better]
        state.bending[rows] = st_trial.bending[better]
        state.slack[rows] = st_trial.slack[better]
        state.saturated[rows] = st_trial.saturated[better]
        mu[act] = np.clip(np.where(better, mu[act] / 5.0, mu[act] * 4.0), 1e-15, 1e6)
    d = d.reshape(k_runs, m, c)
    cost = cost.reshape(k_runs, m)
    reached = np.sqrt(cost) < _TOL
    pick = np.where(np.any(reached, axis=0), np.argmax(reached, axis=0), np.argmin(cost, axis=0))
    d = np.take_along_axis(d, pick[None, :, None], axis=0)[0]
    final = solve_displacement_statics(model, d, k, t0, params.max_tension)
    tip = model.tip_from_bending(final.bending)
    return DisplacementIKSolution(
        d.reshape(batch + (c,)),
        final.tensions.reshape(batch + (c,)),
        final.bending.reshape(batch + (model.n_sections, 2)),
        tip.reshape(batch + (3,)),
        np.linalg.norm(tip - flat, axis=-1).reshape(batch),
    )
