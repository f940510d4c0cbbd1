"""Tendons driven by displacement: the compliant tendon law and the quasi-static shape
(docs/robots.md, tendon drives).

Pure numpy (no simulator, no Gymnasium), float64, SI units; every function broadcasts over
leading batch dimensions.

A real tendon is wound on a position-controlled drive. The commanded displacement d_i (m,
positive = pulled in) reaches the robot through a compliance (tendon stretch + drive) of
stiffness k_i (N/m), with pretension T0_i (N) at d = 0 on the straight robot::

    T_i = clip(T0_i + k_i·(d_i − s_i(q)), 0, T_max)

where s_i(q) = L_i(straight) − L_i(q) (m) is the tendon's geometric shortening at the shape q.
With a compliant base (``RobotParams.base_compliance`` c, m/N: the mount, the backbone's clamp
and axial compression give way under the total tendon load) every drive loses c·(ΣT − ΣT0) of
its pull::

    T_i = clip(T0_i + k_i·(d_i − s_i(q) − c·Σ_l (T_l − T0_l)), 0, T_max)

(c = 0, the default, is the law above). A tendon whose raw value T0 + k(d − s) is ≤ 0 is **slack** (exactly zero tension, it acts as if
absent); one whose raw value exceeds ``max_tension`` is **saturated** (held at the limit: the
drive cannot pull harder).

Statics (PCC, :class:`~cdcr_gym.model.chain.PCCModel`): the bending is linear in the tensions,
w = T·A, and the shortening linear in the bending, so s = T·M with M = −A·B (C×C, symmetric
positive semi-definite: a Gram matrix of the cables' moment arms; its null space is the
common-mode tension that does not bend). The law above is then the box-constrained linear
complementarity problem of the strictly convex quadratic program (finite k)::

    min_T  ½ Tᵀ (M + c·11ᵀ + K⁻¹) T − (d + K⁻¹ T0 + c·ΣT0·1)ᵀ T   over  0 ≤ T ≤ T_max,
    K = diag(k),

whose unique solution :func:`solve_displacement_statics` finds exactly with a batched
primal-dual active-set (semismooth Newton) step on the slack/saturated sets, which settles a
warm-started row (the previous step's tensions) in one or two iterations; any row not settled
after two goes to a batched primal active-set method (finite termination: M is not an M-matrix,
so the primal-dual sets can cycle). Every result is checked against the law before it is
returned (measured: |T − law(s)| ≤ 4e-13 N on 10 000 random commands per preset).

``k = inf`` is the inextensible limit: the commands are first projected onto the shortenings a
shape can have (the sequential least squares of :meth:`PCCModel.bending_from_lengths`: lengths
L = L_straight − d in, shape out — the paper's eq. 2–5 for one section), and among the tensions
that hold that shape the ones closest to the pretension are reported: the k → ∞ limit of the
finite-k solution (the tensions are not unique at k = inf: M has C − 2S common-mode null
directions). Slack and saturation still apply at k = inf; rows with a tendon at a bound are
solved on M + εI, T0-regularised (ε = 1e-9 of M's scale), to find the limit's active sets,
then exactly on those sets (measured: the finite-k tensions approach them as 1/k).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from cdcr_gym.model.chain import PCCModel

__all__ = [
    "TendonState",
    "TendonSolveError",
    "tendon_tensions",
    "common_load",
    "holding_displacements",
    "shortening_matrix",
    "solve_displacement_statics",
    "solve_tendon_law",
]


class TendonSolveError(RuntimeError):
    """The displacement statics did not converge (should not happen for valid input)."""


class TendonState(NamedTuple):
    """The quasi-static state of a robot under displacement commands.

    Attributes:
        tensions: tendon tensions (..., C) (N), in [0, max_tension].
        bending: the PCC bending vectors w (..., S, 2) (rad) (see :mod:`cdcr_gym.model.chain`).
        slack: (..., C) bool, tendons with T0 + k(d − s) ≤ 0 (their tension is exactly 0).
        saturated: (..., C) bool, tendons held at ``max_tension`` (the command asks for more).
        shortening: geometric shortening s_i = L_i(straight) − L_i(w) (..., C) (m).
        iterations: active-set iterations used (the largest over the batch).
    """

    tensions: np.ndarray
    bending: np.ndarray
    slack: np.ndarray
    saturated: np.ndarray
    shortening: np.ndarray
    iterations: int


# -- validation ----------------------------------------------------------------------------------


def _array(name: str, value, *, allow_inf: bool = False) -> np.ndarray:
    """float64 array of ``value``; ValueError naming ``name`` for NaN (or inf unless allowed)."""
    try:
        x = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real array, got {value!r}") from None
    bad = np.isnan(x) if allow_inf else ~np.isfinite(x)
    if np.any(bad):
        rule = "not NaN" if allow_inf else "finite"
        raise ValueError(f"{name} must be {rule}, got {value!r}")
    return x


def _per_cable(name: str, value, n_cables: int, *, allow_inf: bool = False) -> np.ndarray:
    """A scalar, (C,) or (..., C) array (broadcast later); ValueError naming ``name``."""
    x = _array(name, value, allow_inf=allow_inf)
    if x.ndim > 0 and x.shape[-1] != n_cables:
        raise ValueError(
            f"{name} must be a scalar or have shape (..., {n_cables}) (one per cable), "
            f"got shape {x.shape}"
        )
    return x


def _stiffness(value, n_cables: int) -> np.ndarray:
    k = _per_cable("stiffness", value, n_cables, allow_inf=True)
    if np.any(k <= 0.0):
        raise ValueError(f"stiffness must be > 0 N/m (np.inf: inextensible), got {value!r}")
    return k


def _pretension(value, n_cables: int) -> np.ndarray:
    t0 = _per_cable("pretension", value, n_cables)
    if np.any(t0 < 0.0):
        raise ValueError(f"pretension must be >= 0 N, got {value!r}")
    return t0


def _robot_scale(
    name: str, value, lead: tuple[int, ...], n: int, *, allow_zero: bool = False
) -> np.ndarray:
    """A per-robot factor (n,) > 0 (``allow_zero``: ≥ 0) from ``value`` broadcast to the batch
    shape ``lead``."""
    if value is None:
        return np.ones(n)
    x = _array(name, value)
    if np.any(x < 0.0) or (not allow_zero and np.any(x == 0.0)):
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    try:
        return np.broadcast_to(x, lead).reshape(n).astype(np.float64)
    except ValueError:
        raise ValueError(f"{name} must broadcast to {lead}, got shape {x.shape}") from None


def _compliance(value) -> np.ndarray:
    """``base_compliance`` as a float64 array of finite values >= 0 (m/N)."""
    if isinstance(value, bool):
        raise ValueError(f"base_compliance must be a number >= 0 (m/N), got {value!r}")
    c = _array("base_compliance", value)
    if np.any(c < 0.0):
        raise ValueError(f"base_compliance must be >= 0 (m/N), got {value!r}")
    return c


def _max_tension(value) -> float:
    if value is None:
        return math.inf
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"max_tension must be a number > 0 (N) or None, got {value!r}")
    value = float(value)
    if math.isnan(value) or value <= 0.0:
        raise ValueError(f"max_tension must be > 0 N (np.inf: no limit), got {value!r}")
    return value


# -- the tendon law ------------------------------------------------------------------------------


def tendon_tensions(
    displacements, shortening, stiffness, pretension, max_tension=None, base_compliance=0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The compliant tendon law at a given shape: T = clip(T0 + k·(d − s), 0, max_tension),
    elementwise; with a compliant base (c > 0) T = clip(T0 + k·(d − s − c·Σ(T − T0)), 0,
    max_tension), solved exactly for the common load ΣT (:func:`common_load`).

    Args:
        displacements: commanded displacements d (..., C) (m, positive = pulled in).
        shortening: geometric shortenings s (..., C) (m) of the tendons at the current shape.
        stiffness: k (N/m), > 0: a scalar, (C,) or (..., C); ``np.inf`` = inextensible (then
            T = T0 where d = s exactly, +limit where d > s, 0 where d < s).
        pretension: T0 (N), ≥ 0: a scalar, (C,) or (..., C).
        max_tension: the tension limit (N), or None for none.
        base_compliance: c (m/N) ≥ 0, a scalar or (...) per robot (finite k only).

    Returns:
        ``(tensions, slack, saturated)``: tensions (..., C) (N); slack (..., C) bool where the raw
        value T0 + k(d − s − c·Σ(T − T0)) ≤ 0 (tension exactly 0); saturated (..., C) bool where it exceeds
        ``max_tension`` (tension = max_tension). Shapes broadcast over all arguments.

    Raises:
        ValueError: naming the argument for NaN/inf input, k ≤ 0, T0 < 0, max_tension ≤ 0, or
            arrays whose last axis disagrees.
    """
    d = _array("displacements", displacements)
    s = _array("shortening", shortening)
    if d.ndim == 0 or s.ndim == 0:
        raise ValueError(
            f"displacements and shortening must have shape (..., C), got {d.shape} and {s.shape}"
        )
    n = d.shape[-1]
    if s.shape[-1] != n:
        raise ValueError(f"shortening must have shape (..., {n}) like displacements, got {s.shape}")
    k = _stiffness(stiffness, n)
    t0 = _pretension(pretension, n)
    limit = _max_tension(max_tension)
    try:
        d, s, k, t0 = np.broadcast_arrays(d, s, k, t0)
    except ValueError:
        raise ValueError(
            f"displacements {d.shape}, shortening {s.shape}, stiffness {k.shape} and pretension "
            f"{t0.shape} do not broadcast"
        ) from None
    gap = d - s
    stiff = np.isinf(k)
    comp = _compliance(base_compliance)
    if np.any(comp > 0.0):
        if stiff.any():
            raise ValueError(
                f"base_compliance {base_compliance!r} m/N needs finite tendon stiffness, got "
                f"{stiffness!r}"
            )
        try:
            comp = np.broadcast_to(comp, d.shape[:-1])
        except ValueError:
            raise ValueError(
                f"base_compliance must broadcast to {d.shape[:-1]}, got shape {comp.shape}"
            ) from None
        free = t0 + k * gap + (k * comp[..., None]) * t0.sum(axis=-1, keepdims=True)
        total = common_load(free, k * comp[..., None], limit)
        gap = gap - comp[..., None] * (total - t0.sum(axis=-1))[..., None]
    sign = np.where(gap > 0.0, math.inf, np.where(gap < 0.0, -math.inf, t0))
    raw = np.where(stiff, sign, t0 + np.where(stiff, 0.0, k) * gap)
    slack = raw <= 0.0
    saturated = raw > limit
    tensions = np.clip(raw, 0.0, limit)
    return tensions, slack, saturated


def holding_displacements(
    shortening, tensions, stiffness, pretension, base_compliance=0.0
) -> np.ndarray:
    """The drive displacements d (..., C) m that hold ``tensions`` T (..., C) N at a shape of
    geometric shortenings ``shortening`` s (..., C) m: the tendon law solved for d,
    d = s + (T − T0)/k + c·Σ(T − T0) (``stiffness`` k N/m, ``inf``: d = s; ``pretension`` T0 N;
    ``base_compliance`` c m/N, a scalar or (...) per robot). A slack tendon (T = 0) sits at its
    slack point s − T0/k (minus the base's give). Not clipped to a drive range.

    Raises:
        ValueError: naming the argument for NaN/inf values (k may be inf), k ≤ 0, T0 < 0,
            c < 0, or arrays whose last axis disagrees.
    """
    s = _array("shortening", shortening)
    t = _array("tensions", tensions)
    if s.ndim == 0 or t.ndim == 0 or s.shape[-1] != t.shape[-1]:
        raise ValueError(
            f"shortening and tensions must have shape (..., C), got {s.shape} and {t.shape}"
        )
    c_count = s.shape[-1]
    extra = t - _pretension(pretension, c_count)
    k = _stiffness(stiffness, c_count)
    finite = np.isfinite(k)
    give = np.where(finite, extra / np.where(finite, k, 1.0), 0.0)
    c = _compliance(base_compliance)
    return s + give + c[..., None] * np.sum(extra, axis=-1, keepdims=True)


def common_load(free, coupling, max_tension=math.inf) -> np.ndarray:
    """The total tension Σ (...) N that solves Σ = Σ_i clip(free_i − coupling_i·Σ, 0, T_max).

    The tendon law with a compliant base at a given shape: ``free`` (..., C) N is each tendon's
    raw tension without the base's give (T0 + k(d − s) + k·c·ΣT0), ``coupling`` (..., C) = k·c
    (1/1) how much it loses per newton of total load. The right-hand side is piecewise linear and
    non-increasing in Σ, so the root is unique; it is found exactly between the breakpoints
    (where a tendon goes slack or leaves the limit).
    """
    free = np.asarray(free, dtype=np.float64)
    a = np.broadcast_to(np.asarray(coupling, dtype=np.float64), free.shape)
    safe = np.where(a > 0.0, a, 1.0)
    lows = np.where(a > 0.0, (free - max_tension) / safe, -np.inf)
    highs = np.where(a > 0.0, free / safe, -np.inf)
    points = np.concatenate([np.zeros(free.shape[:-1] + (1,)), lows, highs], axis=-1)
    points = np.sort(np.where(np.isfinite(points), np.maximum(points, 0.0), 0.0), axis=-1)

    def excess(x):  # Σ_i T_i(x) − x, non-increasing; x (..., P)
        t = np.clip(free[..., None, :] - a[..., None, :] * x[..., None], 0.0, max_tension)
        return t.sum(axis=-1) - x

    f = excess(points)
    # the last breakpoint with f >= 0 (f(0) >= 0 always) and the next one: f is linear between
    last = points.shape[-1] - 1
    idx = np.maximum(np.sum(f >= 0.0, axis=-1) - 1, 0)
    nxt = np.minimum(idx + 1, last)
    x0, x1 = (np.take_along_axis(points, i[..., None], axis=-1)[..., 0] for i in (idx, nxt))
    f0, f1 = (np.take_along_axis(f, i[..., None], axis=-1)[..., 0] for i in (idx, nxt))
    step = np.where(f0 > f1, f0 / np.where(f0 > f1, f0 - f1, 1.0), 0.0)
    return x0 + np.clip(step, 0.0, 1.0) * (x1 - x0)


# -- the statics ---------------------------------------------------------------------------------


def shortening_matrix(model: PCCModel) -> np.ndarray:
    """M (C, C) (m/N), symmetric PSD, with shortening s = T @ M for tensions T (N) (frictionless
    PCC statics: s = L_straight − L(w(T)))."""
    m = -(model.tension_to_bending @ model.bending_to_lengths)
    return 0.5 * (m + m.T)


def _solve_sets(h, q, t_fix, free, anchor, scale, singular):
    """T (N, C) with T = t_fix off ``free`` and (H T − q)_free = 0; for singular H the solution
    nearest ``anchor`` (min-norm deviation, least squares if inconsistent)."""
    n, c = free.shape
    both = free[:, :, None] & free[:, None, :]
    hm = np.where(both, h, 0.0)
    idx = np.arange(c)
    hm[:, idx, idx] += np.where(free, 0.0, scale)
    t_fixed = np.where(free, 0.0, t_fix)
    rhs = np.where(free, q - np.einsum("nij,nj->ni", h, t_fixed), scale * t_fixed)
    if not singular:
        x = np.linalg.solve(hm, rhs[..., None])[..., 0]
    else:
        base = np.where(free, anchor, t_fixed)
        resid = rhs - np.einsum("nij,nj->ni", hm, base)
        pinv = np.linalg.pinv(hm, rcond=1e-10, hermitian=True)
        x = base + np.einsum("nij,nj->ni", pinv, resid)
    return np.where(free, x, t_fixed)  # the fixed tendons exactly at their bounds


def _primal_active_set(h, q, upper, start, anchor, scale, max_iter):
    """Rows (N, C): min ½xᵀHx − qᵀx over 0 ≤ x ≤ upper, H SPD (N, C, C), batched. The primal
    active-set method (Nocedal & Wright, Alg. 16.3): feasible iterates, one bound added (a step
    blocked) or released (the most negative multiplier) per iteration; finite termination.
    Returns (x, converged (N,) bool, iterations)."""
    n, c = q.shape
    x = np.clip(start, 0.0, upper)
    lower_set = x <= 0.0
    upper_set = (x >= upper) & ~lower_set
    done = np.zeros(n, bool)
    big = np.finfo(np.float64).max
    iterations = 0
    for _ in range(max_iter * c):
        todo = np.flatnonzero(~done)
        if todo.size == 0:
            break
        iterations += 1
        lo, up, xr, ur = lower_set[todo], upper_set[todo], x[todo], upper[todo]
        free = ~(lo | up)
        fixed = np.where(up, ur, 0.0)
        target = _solve_sets(h[todo], q[todo], fixed, free, anchor[todo], scale, False)
        target = np.where(free, target, fixed)
        step = target - xr
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(
                free & (target < 0.0),
                xr / (xr - target),
                np.where(free & (target > ur), (ur - xr) / (target - xr), big),
            )
        block = np.argmin(ratio, axis=1)
        alpha = ratio[np.arange(todo.size), block]
        blocked = alpha < 1.0
        # blocked rows: step to the bound, add it
        rows = np.flatnonzero(blocked)
        if rows.size:
            r_all, col = todo[rows], block[rows]
            x[r_all] = xr[rows] + alpha[rows, None] * step[rows]
            hits_upper = step[rows, col] > 0.0
            x[r_all, col] = np.where(hits_upper, ur[rows, col], 0.0)
            upper_set[r_all, col] = hits_upper
            lower_set[r_all, col] = ~hits_upper
        # full steps: the minimiser on the working set; check the multipliers
        rows = np.flatnonzero(~blocked)
        if rows.size:
            r_all = todo[rows]
            x[r_all] = target[rows]
            g = np.einsum("nij,nj->ni", h[r_all], x[r_all]) - q[r_all]
            viol = np.where(lower_set[r_all], -g, 0.0) + np.where(upper_set[r_all], g, 0.0)
            size = np.max(np.abs(q[r_all]), axis=1) + np.max(
                np.abs(np.einsum("nij,nj->ni", np.abs(h[r_all]), np.abs(x[r_all]))), axis=1
            )
            worst = np.argmax(viol, axis=1)
            vmax = viol[np.arange(rows.size), worst]
            finished = vmax <= 64.0 * np.finfo(np.float64).eps * size
            done[r_all[finished]] = True
            rel = r_all[~finished]
            lower_set[rel, worst[~finished]] = False
            upper_set[rel, worst[~finished]] = False
    return x, done, iterations


def _box_qp(h, q, t02, c_scale, scale, limit, singular, initial_tensions, batch, max_iter, tol, d2):
    """The tensions T (N, C) of the box-constrained QP min ½TᵀHT − qᵀT over 0 ≤ T ≤ limit
    (the law's complementarity problem, module docstring) for rows of H (N, C, C), q (N, C):
    two primal-dual steps, then the primal active-set method; checked against the law.
    Returns (T, iterations); TendonSolveError if a row did not converge."""
    n, C = q.shape
    upper = np.full((n, C), limit)

    # start: the warm start, or the unconstrained solution, then the law's sets
    if initial_tensions is not None:
        start = _array("initial_tensions", initial_tensions)
        try:
            start = np.broadcast_to(start, batch).reshape(n, C)
        except ValueError:
            raise ValueError(
                f"initial_tensions must broadcast to {batch}, got shape {start.shape}"
            ) from None
        start = np.clip(start, 0.0, limit)
    else:
        start = _solve_sets(h, q, t02, np.ones((n, C), bool), t02, scale, singular)
    y = start - c_scale * (np.einsum("nij,nj->ni", h, start) - q)
    y = np.where(np.isfinite(y), y, start)
    # set decisions with a margin of the round-off of y (degenerate rows, where a tendon sits
    # exactly at the slack boundary, would otherwise flip between the sets on round-off)
    eps = (
        64.0
        * np.finfo(np.float64).eps
        * (1.0 + np.max(np.abs(t02) + np.abs(c_scale * q), axis=1, keepdims=True))
    )
    lower_set = y <= eps
    upper_set = (y >= upper - eps) & ~lower_set
    t = start
    done = np.zeros(n, bool)
    iterations = 0
    budget = min(max_iter, 2)  # primal-dual steps; then the primal active-set method
    for it in range(1, budget + 1):
        iterations = it
        free = ~(lower_set | upper_set)
        t_fix = np.where(upper_set, upper, 0.0)
        todo = ~done
        t_new = _solve_sets(h[todo], q[todo], t_fix[todo], free[todo], t02[todo], scale, singular)
        t = t.copy()
        t[todo] = t_new
        g = np.einsum("nij,nj->ni", h, t) - q
        y = t - c_scale * g
        new_lower = y <= eps
        new_upper = (y >= upper - eps) & ~new_lower
        same = np.all((new_lower == lower_set) & (new_upper == upper_set), axis=1)
        lower_set, upper_set = (
            np.where(todo[:, None], new_lower, lower_set),
            np.where(todo[:, None], new_upper, upper_set),
        )
        done |= same
        if done.all():
            break

    # any row whose sets cycle: the primal active-set method (finite termination for SPD H).
    # For k = inf (H = M singular) it runs on M + εI, which identifies the active sets of the
    # limit problem; one exact solve on those sets then gives the tensions nearest T0.
    if singular:
        # k = inf with a tendon at a bound: the tensions are not unique; the regularised
        # problem below picks those nearest T0 (the k → ∞ limit), then one exact solve
        done &= ~np.any(lower_set | upper_set, axis=1)
    fallback = np.flatnonzero(~done)
    if fallback.size:
        reg = 1e-9 * scale if singular else 0.0  # k = inf: M + εI picks the active sets
        x, ok, extra = _primal_active_set(
            h[fallback] + reg * np.eye(C),
            q[fallback] + reg * t02[fallback],
            upper[fallback],
            t[fallback],
            t02[fallback],
            scale,
            max_iter,
        )
        iterations += extra
        if singular:  # the exact solve of the limit problem on those sets
            lo, up = x <= 0.0, x >= upper[fallback]
            x = _solve_sets(
                h[fallback],
                q[fallback],
                np.where(up, upper[fallback], 0.0),
                ~(lo | up),
                t02[fallback],
                scale,
                True,
            )
        t[fallback] = x
        done[fallback] = ok

    t = np.clip(t, 0.0, upper)
    g = np.einsum("nij,nj->ni", h, t) - q
    residual = np.abs(t - np.clip(t - c_scale * g, 0.0, upper))
    size = 1.0 + np.max(np.abs(t) + np.abs(c_scale * q), axis=1, initial=0.0)
    bad = ~done | np.any(residual > tol * size[:, None] * C, axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise TendonSolveError(
            f"displacement statics did not converge in {max_iter} iterations on {int(bad.sum())} "
            f"of {n} robots (first: displacements {d2[row].tolist()}, residual "
            f"{float(np.max(residual[row])):.3g} N); raise max_iter or tol"
        )
    return t, iterations


def solve_displacement_statics(
    model: PCCModel,
    displacements,
    stiffness,
    pretension,
    max_tension=None,
    tol: float = 1e-12,
    max_iter: int = 100,
    initial_tensions=None,
    bending_scale=None,
    length_scale=None,
    base_compliance=None,
) -> TendonState:
    """The quasi-static PCC shape under tendon displacement commands.

    Solves T = clip(T0 + k·(d − s(w(T))), 0, max_tension) together with the frictionless
    pure-moment statics w = w(T) of ``model`` (see the module docstring), exactly: the result's
    tensions satisfy the law at the result's shape to ``tol`` (relative).

    Args:
        model: the robot's :class:`PCCModel` (S sections, C cables).
        displacements: commands d (..., C) (m, positive = pulled in at the drive).
        stiffness: k (N/m) > 0, a scalar, (C,) or (..., C); ``np.inf`` (all cables) = the
            inextensible limit (shape from the commands by least squares, as
            :meth:`PCCModel.bending_from_lengths` with lengths L_straight − d).
        pretension: T0 (N) ≥ 0 at d = 0 on the straight robot; scalar, (C,) or (..., C).
        max_tension: tension limit (N); None = the robot's ``params.max_tension``; ``np.inf``
            for none.
        tol: relative tolerance of the final complementarity check.
        max_iter: iteration budget (the primal active-set fallback may take up to max_iter·C).
        initial_tensions: optional warm start (..., C) (N), e.g. the previous step's tensions.
        bending_scale: optional per-robot factor (...) > 0 on the bending under given tensions
            (a robot whose cable radius r and modulus E differ from ``model``'s: (r/r₀)(E₀/E)).
        length_scale: optional per-robot factor (...) > 0 on the cable-length changes of a
            shape (r/r₀). The shortening matrix of such a robot is bending_scale·length_scale·M.
        base_compliance: c (m/N) ≥ 0, a scalar or (...) per robot; None = the robot's
            ``params.base_compliance``. Needs finite k.

    Returns:
        :class:`TendonState` with leading shape that of the broadcast arguments.

    Raises:
        ValueError: naming the argument, for NaN/inf commands, k ≤ 0 or NaN, T0 < 0, a wrong
            last axis, or stiffness mixing finite and infinite values.
        TendonSolveError: if the iteration fails to converge (a bug: the problem is convex).
    """
    if not isinstance(model, PCCModel):
        raise ValueError(f"model must be a PCCModel, got {model!r}")
    C, S = model.n_cables, model.n_sections
    d = _array("displacements", displacements)
    if d.ndim == 0 or d.shape[-1] != C:
        raise ValueError(f"displacements must have shape (..., {C}), got {d.shape}")
    k = _stiffness(stiffness, C)
    t0 = _pretension(pretension, C)
    limit = _max_tension(model.params.max_tension if max_tension is None else max_tension)
    if not (isinstance(tol, (int, float)) and 0.0 < tol < 1.0):
        raise ValueError(f"tol must be in (0, 1), got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    inextensible = np.isinf(k)
    if inextensible.any() and not inextensible.all():
        raise ValueError(
            f"stiffness must be all finite or all np.inf (inextensible), got {stiffness!r}"
        )
    singular = bool(inextensible.any())
    comp = _compliance(model.params.base_compliance if base_compliance is None else base_compliance)
    if singular and np.any(comp > 0.0):
        raise ValueError(
            f"base_compliance {base_compliance!r} m/N needs finite tendon stiffness: with k = inf "
            f"the compliant base is the only compliance (give finite k, or base_compliance=0)"
        )
    try:
        batch = np.broadcast_shapes(d.shape, k.shape, t0.shape)
    except ValueError:
        raise ValueError(
            f"displacements {d.shape}, stiffness {k.shape} and pretension {t0.shape} do not "
            f"broadcast"
        ) from None
    n = math.prod(batch[:-1])
    d2 = np.broadcast_to(d, batch).reshape(n, C)
    t02 = np.broadcast_to(t0, batch).reshape(n, C)
    bs = _robot_scale("bending_scale", bending_scale, batch[:-1], n)
    ls = _robot_scale("length_scale", length_scale, batch[:-1], n)
    m = shortening_matrix(model)
    h = np.einsum("n,ij->nij", bs * ls, m)
    mean_diag = float(np.mean(np.diag(m))) * float(np.mean(bs * ls))
    if singular:
        # the shape whose length changes are −d (least squares), and its shortenings
        w_star = ((-d2) @ model.lengths_to_bending) / ls[:, None]
        q = -((w_star * ls[:, None]) @ model.bending_to_lengths)
        c_scale = 1.0 / np.diagonal(h, axis1=1, axis2=2)
        scale = mean_diag
    else:
        k2 = np.broadcast_to(k, batch).reshape(n, C)
        idx = np.arange(C)
        h[:, idx, idx] += 1.0 / k2
        q = d2 + t02 / k2
        if np.any(comp > 0.0):
            c2 = _robot_scale("base_compliance", comp, batch[:-1], n, allow_zero=True)
            h += c2[:, None, None]
            q = q + (c2 * t02.sum(axis=1))[:, None]
        c_scale = k2
        scale = mean_diag + float(np.mean(1.0 / k2))
    t, iterations = _box_qp(
        h, q, t02, c_scale, scale, limit, singular, initial_tensions, batch, max_iter, tol, d2
    )
    upper = np.full((n, C), limit)
    slack = t <= 0.0
    saturated = t >= upper
    w_flat = (t @ model.tension_to_bending) * bs[:, None]
    if singular:
        # rows where no tendon is slack or saturated hold the commanded shape exactly
        exact = ~np.any(slack | saturated, axis=1)
        w_flat = np.where(exact[:, None], w_star, w_flat)
    shortening = -(w_flat @ model.bending_to_lengths) * ls[:, None]
    lead = batch[:-1]
    return TendonState(
        tensions=t.reshape(batch),
        bending=w_flat.reshape(lead + (S, 2)),
        slack=slack.reshape(batch),
        saturated=saturated.reshape(batch),
        shortening=shortening.reshape(batch),
        iterations=int(iterations),
    )


def solve_tendon_law(
    shortening_matrices,
    displacements,
    stiffness,
    pretension,
    max_tension=None,
    tol: float = 1e-12,
    max_iter: int = 100,
    base_compliance=0.0,
) -> tuple[np.ndarray, int]:
    """The tensions of N robots, each with its own shortening matrix, under the compliant law
    T = clip(T0 + k·(d − T @ M − c·Σ(T − T0)), 0, max_tension) (finite k; the solver of
    :func:`solve_displacement_statics`, for robots whose geometry differs beyond a scale, e.g.
    the parameter sets of a calibration).

    Args:
        shortening_matrices: M (N, C, C) (m/N), symmetric positive semi-definite, s = T @ M.
        displacements: commands d (N, C) (m, positive = pulled in).
        stiffness: k (N/m) > 0 and finite, a scalar, (C,) or (N, C).
        pretension: T0 (N) ≥ 0, a scalar, (C,) or (N, C).
        max_tension: tension limit (N); None or ``np.inf``: none.
        tol, max_iter: as :func:`solve_displacement_statics`.
        base_compliance: c (m/N) ≥ 0, a scalar or (N,): the compliant base of the module
            docstring (0: rigid).

    Returns:
        ``(tensions (N, C) N, iterations)``; slack/saturated tendons are those at 0 / the limit.

    Raises:
        ValueError: naming the argument for wrong shapes, non-finite values, k ≤ 0 or inf,
            T0 < 0.
        TendonSolveError: if the iteration fails to converge (a bug: the problem is convex).
    """
    m = _array("shortening_matrices", shortening_matrices)
    if m.ndim != 3 or m.shape[1] != m.shape[2]:
        raise ValueError(f"shortening_matrices must have shape (N, C, C), got {m.shape}")
    n, C = m.shape[0], m.shape[1]
    d = _array("displacements", displacements)
    if d.shape != (n, C):
        raise ValueError(f"displacements must have shape ({n}, {C}), got {d.shape}")
    k = _stiffness(stiffness, C)
    if np.any(np.isinf(k)):
        raise ValueError(f"stiffness must be finite here (N/m), got {stiffness!r}")
    t0 = _pretension(pretension, C)
    limit = _max_tension(max_tension)
    if not (isinstance(tol, (int, float)) and 0.0 < tol < 1.0):
        raise ValueError(f"tol must be in (0, 1), got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    try:
        k2 = np.broadcast_to(k, (n, C))
        t02 = np.broadcast_to(t0, (n, C))
    except ValueError:
        raise ValueError(
            f"stiffness {k.shape} and pretension {t0.shape} must broadcast to ({n}, {C})"
        ) from None
    comp = _robot_scale("base_compliance", _compliance(base_compliance), (n,), n, allow_zero=True)
    h = 0.5 * (m + np.swapaxes(m, 1, 2)) + comp[:, None, None]
    idx = np.arange(C)
    h[:, idx, idx] += 1.0 / k2
    q = d + t02 / k2 + (comp * t02.sum(axis=1))[:, None]
    scale = float(np.mean(np.diagonal(m, axis1=1, axis2=2))) + float(np.mean(1.0 / k2))
    return _box_qp(h, q, t02, k2, scale, limit, False, None, (n, C), max_iter, tol, d)
