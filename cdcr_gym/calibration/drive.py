"""The CCKA (piecewise constant curvature) model of a robot driven by tendon **displacements**,
batched over measurement rows and over parameter sets (for a one-call finite-difference Jacobian).

Model (docs/calibration.md, robots driven by tendon displacement): section j bends with a
constant curvature vector κ_j = (κx, κy)_j in its own frame (sections compose without torsion).
Tendon i belongs to section m_i, sits at radius r_i and angle β_i and runs through sections
1…m_i; with g_ij = r_i·(cos β_i, sin β_i) (a helical tendon, pitch p: r_i·sinc(p·ℓ_j/2)·(cos, sin)
(β_i + p·z_j) with z_j the middle of section j, ``RobotParams.section_cable_vectors``) its
geometric shortening is ``s_i = Σ_{j ≤ m_i} ℓ_j·g_ij·κ_j`` (linear in κ: ``s = G·Λ·u`` with u the
stacked curvatures, G (C, 2S) holding g_ij in the blocks of the sections the tendon runs through
and Λ = diag(ℓ_j, ℓ_j)). The drive law is ``T_i = clip(T0_i + k_i·(d_i − s_i), 0, T_max)`` (slack: a
tendon with ``T0 + k(d − s) ≤ 0`` carries nothing; ``slack=False`` drops the clip at zero: the
linear law, an ablation) and the rod balances the tendon moments: ``EI·κ_j = Σ_{m_i ≥ j} T_i g_i``
(``EI·u = Gᵀ·T``).

``Λ·(EI·u − Gᵀ·T(u))`` is the gradient of a strictly convex energy (the rod's bending energy plus
each tendon's spring energy ``(1/2k)·clip(…)²``), so the equilibrium is unique. Eliminating u
(``u = Gᵀ·T/EI``, so ``s = M·T`` with the shortening matrix ``M = G·Λ·Gᵀ/EI``, symmetric PSD)
leaves the tendon law's box-constrained QP in T, solved exactly (active sets, machine precision)
by :func:`cdcr_gym.model.tendons.solve_tendon_law`: the same solver as the robots' displacement
statics (:func:`cdcr_gym.model.tendons.solve_displacement_statics`), each parameter set with its
own M.

Geometry of a prediction: ``tip = R_base·(Σ_j R_1…R_{j−1}·p_j + R_1…R_S·(0, 0, marker)) + t_base``
with p_j, R_j the arc of section j (``p_j = ℓ_j·((1−cosθ)/θ²·w, sinθ/θ)``, w = κ_j ℓ_j, θ = |w|;
``R_j`` the rotation by θ about (−w_y, w_x, 0)/θ), everything in metres; the marker offset is
along the tip tangent (a motion-capture marker above the last disk).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cdcr_gym.model.drive_softening import check_rate

__all__ = ["DriveGeometry", "DriveState", "solve_drive", "forward_tips", "rotation_zyx"]


@dataclass
class DriveGeometry:
    """A batch of B robots (parameter sets) in array form, SI units.

    Attributes:
        lengths: (B, S) section lengths, m.
        section_of: (C,) int, the section (0-based) each tendon ends in.
        radii: (B, C) tendon routing radii, m.
        angles: (B, C) tendon angles β, rad.
        ei: (B,) bending stiffness EI, N·m².
        stiffness: (B, C) tendon stiffness k, N/m (``inf`` not allowed: use a large value).
        pretension: (B, C) pretension T0 at d = 0 on the straight robot, N.
        max_tension: tension cap, N (``inf``: none).
        base_compliance: (B,) the base's give c under the total tendon load, m/N (None: 0).
        slack: whether tendons go slack (the clip at zero); False = linear law.
        base_rotation: (B, 3, 3) robot base frame in the measurement frame.
        base_translation: (B, 3) robot base origin in the measurement frame, m.
        marker: (B,) marker offset along the tip tangent, m.
        pitch: (B,) helical routing pitch p (``RobotParams.cable_pitch``), rad/m (None: 0).
    """

    lengths: np.ndarray
    section_of: np.ndarray
    radii: np.ndarray
    angles: np.ndarray
    ei: np.ndarray
    stiffness: np.ndarray
    pretension: np.ndarray
    max_tension: float = np.inf
    base_compliance: np.ndarray | None = None
    slack: bool = True
    base_rotation: np.ndarray | None = None
    base_translation: np.ndarray | None = None
    marker: np.ndarray | None = None
    pitch: np.ndarray | None = None

    @property
    def batch(self) -> int:
        return int(self.lengths.shape[0])

    @property
    def n_sections(self) -> int:
        return int(self.lengths.shape[1])

    def coupling(self) -> tuple[np.ndarray, np.ndarray]:
        """G (B, C, 2S) and the diagonal of Λ (B, 2S)."""
        b, s = self.lengths.shape
        c = self.section_of.shape[0]
        g = np.zeros((b, c, 2 * s))
        pitch = np.zeros(b) if self.pitch is None else np.asarray(self.pitch, dtype=np.float64)
        middles = np.cumsum(self.lengths, axis=1) - 0.5 * self.lengths  # (B, S)
        for j in range(s):
            through = self.section_of >= j
            angles = self.angles[:, through] + (pitch * middles[:, j])[:, None]
            half = 0.5 * pitch * self.lengths[:, j]
            sinc = np.sinc(half / np.pi)  # sin(x)/x, 1 at x = 0
            radii = self.radii[:, through] * sinc[:, None]
            g[:, through, 2 * j] = radii * np.cos(angles)
            g[:, through, 2 * j + 1] = radii * np.sin(angles)
        lam = np.repeat(self.lengths, 2, axis=1)
        return g, lam


@dataclass
class DriveState:
    """The equilibrium of B robots × M rows.

    Attributes:
        curvature: (B, M, S, 2) section curvature vectors κ_j in their own frames, 1/m.
        tensions: (B, M, C) tendon tensions, N.
        slack: (B, M, C) bool, tendons carrying nothing.
        saturated: (B, M, C) bool, tendons at ``max_tension``.
        shortening: (B, M, C) geometric shortenings s_i, m.
        iterations: solver iterations used (the largest over the batch).
    """

    curvature: np.ndarray
    tensions: np.ndarray
    slack: np.ndarray
    saturated: np.ndarray
    shortening: np.ndarray
    iterations: int


def solve_drive(
    geom: DriveGeometry, displacements: np.ndarray, max_iter: int = 100, tol: float = 1e-12
) -> DriveState:
    """The equilibrium (module docstring) of every robot of ``geom`` under every row of
    ``displacements`` (M, C) m (positive = pulled in).

    The tensions solve the tendon law against each robot's shortening matrix
    ``M = G·Λ·Gᵀ/EI`` (s = M·T) with :func:`cdcr_gym.model.tendons.solve_tendon_law` (the
    solver of the robots' displacement statics); the curvatures follow as ``u = Gᵀ·T/EI``.
    ``slack=False`` (the linear law, no clip at zero) is the same problem for ``T_max − T``
    with no upper bound (a plain linear solve without a tension cap).

    Raises:
        ValueError: for a displacement array of the wrong shape or with non-finite values.
    """
    from cdcr_gym.model.tendons import solve_tendon_law

    d = np.asarray(displacements, dtype=np.float64)
    c = geom.section_of.shape[0]
    if d.ndim != 2 or d.shape[1] != c or not np.isfinite(d).all():
        raise ValueError(f"displacements must be finite (M, {c}) m, got shape {d.shape}")
    g, lam = geom.coupling()  # (B, C, 2S), (B, 2S)
    b, n = lam.shape
    rows = d.shape[0]
    a = g * lam[:, None, :]  # s = a @ u  (B, C, 2S)
    gt = np.swapaxes(g, 1, 2)  # (B, 2S, C)
    ei = geom.ei[:, None, None]
    shortening_matrix = np.einsum("bcn,bnp->bcp", a, gt) / ei  # (B, C, C): s = M·T
    m_rows = np.repeat(shortening_matrix, rows, axis=0)  # (B·M, C, C)
    k = np.repeat(geom.stiffness, rows, axis=0)
    t0 = np.repeat(geom.pretension, rows, axis=0)
    dd = np.tile(d, (b, 1))
    limit = geom.max_tension
    comp = np.zeros(b) if geom.base_compliance is None else np.asarray(geom.base_compliance)
    if np.any(comp > 0.0):  # the compliant base is the shortening matrix's c·11ᵀ
        m_rows = m_rows + np.repeat(comp, rows)[:, None, None]
        dd = dd + (np.repeat(comp, rows) * np.maximum(t0, 0.0).sum(axis=1))[:, None]
    if geom.slack:
        t, iterations = solve_tendon_law(m_rows, dd, k, np.maximum(t0, 0.0), limit, tol, max_iter)
    elif np.isfinite(limit):
        # T' = T_max − T ≥ 0 obeys the law with T0' = 0, d' = (T_max − T0)/k − d + M·T_max
        # and no cap: T' = max(0, k·(d' − M·T')), i.e. T = min(T0 + k·(d − M·T), T_max)
        shift = (limit - t0) / k - dd + np.einsum("nij,j->ni", m_rows, np.full(c, limit))
        t_prime, iterations = solve_tendon_law(m_rows, shift, k, 0.0, None, tol, max_iter)
        t = limit - t_prime
    else:
        h = m_rows + np.einsum("ni,ij->nij", 1.0 / k, np.eye(c))
        t = np.linalg.solve(h, (dd + t0 / k)[..., None])[..., 0]
        iterations = 1
    t = t.reshape(b, rows, c)
    u = np.einsum("bnc,bmc->bmn", gt, t) / ei
    s = np.einsum("bcn,bmn->bmc", a, u)
    give = comp[:, None, None] * (
        t.sum(axis=2, keepdims=True) - t0.reshape(b, rows, c).sum(2, keepdims=True)
    )
    raw = geom.pretension[:, None, :] + geom.stiffness[:, None, :] * (d[None] - s - give)
    return DriveState(
        curvature=u.reshape(b, rows, n // 2, 2),
        tensions=t,
        slack=raw <= 0.0 if geom.slack else np.zeros_like(raw, dtype=bool),
        saturated=raw >= geom.max_tension,
        shortening=s,
        iterations=iterations,
    )


def _sinc(x: np.ndarray) -> np.ndarray:
    return np.sinc(x / np.pi)


def forward_tips(geom: DriveGeometry, curvature: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tips (B, M, 3) m and unit tip tangents (B, M, 3) in the measurement frame for section
    curvatures (B, M, S, 2) (module docstring: base frame and marker offset applied)."""
    b, m, s, _ = curvature.shape
    rot = np.broadcast_to(np.eye(3), (b, m, 3, 3)).copy()
    pos = np.zeros((b, m, 3))
    for j in range(s):
        w = curvature[:, :, j, :] * geom.lengths[:, j, None, None]  # (B, M, 2)
        theta = np.hypot(w[..., 0], w[..., 1])
        f1 = _sinc(theta)  # sinθ/θ
        f2 = 0.5 * _sinc(0.5 * theta) ** 2  # (1−cosθ)/θ²
        ell = geom.lengths[:, j, None]
        p = np.stack([ell * f2 * w[..., 0], ell * f2 * w[..., 1], ell * f1], axis=-1)
        # Rodrigues with the (unnormalised) axis ω = (−w_y, w_x, 0), |ω| = θ
        ox, oy = -w[..., 1], w[..., 0]
        zero = np.zeros_like(ox)
        kx = np.stack(
            [
                np.stack([zero, zero, oy], -1),
                np.stack([zero, zero, -ox], -1),
                np.stack([-oy, ox, zero], -1),
            ],
            -2,
        )
        rj = np.eye(3) + f1[..., None, None] * kx + f2[..., None, None] * (kx @ kx)
        pos = pos + np.einsum("bmij,bmj->bmi", rot, p)
        rot = rot @ rj
    tangent = rot[..., :, 2]
    if geom.marker is not None:
        pos = pos + geom.marker[:, None, None] * tangent
    if geom.base_rotation is not None:
        pos = np.einsum("bij,bmj->bmi", geom.base_rotation, pos)
        tangent = np.einsum("bij,bmj->bmi", geom.base_rotation, tangent)
    if geom.base_translation is not None:
        pos = pos + geom.base_translation[:, None, :]
    return pos, tangent


def rotation_zyx(yaw: np.ndarray, tilt_y: np.ndarray, tilt_x: np.ndarray) -> np.ndarray:
    """R = Rz(yaw)·Ry(tilt_y)·Rx(tilt_x), (B, 3, 3), for angles (B,) rad."""
    cz, sz = np.cos(yaw), np.sin(yaw)
    cy, sy = np.cos(tilt_y), np.sin(tilt_y)
    cx, sx = np.cos(tilt_x), np.sin(tilt_x)
    one, zero = np.ones_like(cz), np.zeros_like(cz)
    rz = np.stack(
        [
            np.stack([cz, -sz, zero], -1),
            np.stack([sz, cz, zero], -1),
            np.stack([zero, zero, one], -1),
        ],
        -2,
    )
    ry = np.stack(
        [
            np.stack([cy, zero, sy], -1),
            np.stack([zero, one, zero], -1),
            np.stack([-sy, zero, cy], -1),
        ],
        -2,
    )
    rx = np.stack(
        [
            np.stack([one, zero, zero], -1),
            np.stack([zero, cx, -sx], -1),
            np.stack([zero, sx, cx], -1),
        ],
        -2,
    )
    return rz @ ry @ rx


@dataclass(frozen=True)
class TendonDrive:
    """The nominal tendon drive of a robot (docs/robots.md), SI units.

    Attributes:
        stiffness: (C,) tendon stiffness k, N/m.
        pretension: (C,) pretension T0 at d = 0 on the straight robot, N.
        displacement_range: (low, high) commanded displacements the drive accepts, m (the
            reader's unit check).
        max_tension: tension cap of the drive law, N (``inf``: none).
        base_compliance: c, the robot base's give under the total tendon load, m/N (every
            drive loses c·Σ(T − T0); 0: a rigid base).
        backlash: w, the play between each drive's command and its tendon, m (the replays
            pass the rows' commands through :func:`cdcr_gym.calibration.backlash.play`;
            0: none).
        softening: σ, the rate at which each drive's pull saturates, 1/m (a drive at y > 0
            after its play pulls by tanh(σy)/σ: :mod:`cdcr_gym.model.drive_softening`;
            0: a linear drive).
    """

    stiffness: tuple[float, ...]
    pretension: tuple[float, ...]
    displacement_range: tuple[float, float] = (-np.inf, np.inf)
    max_tension: float = np.inf
    base_compliance: float = 0.0
    backlash: float = 0.0
    softening: float = 0.0

    def __post_init__(self) -> None:
        k = np.asarray(self.stiffness, dtype=np.float64)
        t0 = np.asarray(self.pretension, dtype=np.float64)
        if k.ndim != 1 or t0.shape != k.shape:
            raise ValueError(
                f"tendon stiffness and pretension must be (C,) each, got {k.shape} and {t0.shape}"
            )
        if not (np.isfinite(k).all() and np.all(k > 0.0)):
            raise ValueError(f"tendon stiffness must be finite and > 0 N/m, got {k.tolist()}")
        if not np.isfinite(t0).all():
            raise ValueError(f"tendon pretension must be finite (N), got {t0.tolist()}")
        lo, hi = (float(v) for v in self.displacement_range)
        if not lo < hi:
            raise ValueError(f"displacement_range must be (low, high), got {(lo, hi)}")
        if not self.max_tension > 0.0:
            raise ValueError(f"max_tension must be > 0 N, got {self.max_tension!r}")
        c = float(self.base_compliance)
        if not (np.isfinite(c) and c >= 0.0):
            raise ValueError(f"base_compliance must be finite and >= 0 m/N, got {c!r}")
        object.__setattr__(self, "base_compliance", c)
        w = float(self.backlash)
        if not (np.isfinite(w) and w >= 0.0):
            raise ValueError(f"backlash must be finite and >= 0 m, got {w!r}")
        object.__setattr__(self, "backlash", w)
        object.__setattr__(self, "softening", check_rate(self.softening, "softening"))
        object.__setattr__(self, "stiffness", tuple(float(v) for v in k))
        object.__setattr__(self, "pretension", tuple(float(v) for v in t0))
        object.__setattr__(self, "displacement_range", (lo, hi))

    @classmethod
    def of(cls, params: Any) -> TendonDrive | None:
        """The drive a ``RobotParams`` carries (``tendon_stiffness``, ``tendon_pretension``,
        ``displacement_range`` fields, where the robot has them), else None."""
        k = getattr(params, "tendon_stiffness", None)
        t0 = getattr(params, "tendon_pretension", None)
        if k is None or t0 is None:
            return None
        n = int(params.n_cables)
        k_arr = np.broadcast_to(np.asarray(k, dtype=np.float64), (n,))
        t_arr = np.broadcast_to(np.asarray(t0, dtype=np.float64), (n,))
        rng = getattr(params, "displacement_range", None) or (-np.inf, np.inf)
        rng_arr = np.asarray(rng, dtype=np.float64)
        if rng_arr.ndim == 2:  # per tendon (C, 2): the widest
            rng_arr = np.array([rng_arr[:, 0].min(), rng_arr[:, 1].max()])
        comp = float(getattr(params, "base_compliance", 0.0))
        return cls(
            tuple(k_arr), tuple(t_arr), (float(rng_arr[0]), float(rng_arr[1])), base_compliance=comp
        )

    def to_dict(self) -> dict:
        lo, hi = self.displacement_range
        out: dict = {"stiffness": list(self.stiffness), "pretension": list(self.pretension)}
        if np.isfinite(lo) and np.isfinite(hi):
            out["displacement_range"] = [lo, hi]
        if np.isfinite(self.max_tension):
            out["max_tension"] = float(self.max_tension)
        if self.base_compliance > 0.0:
            out["base_compliance"] = self.base_compliance
        if self.backlash > 0.0:
            out["backlash"] = self.backlash
        if self.softening > 0.0:
            out["softening"] = self.softening
        return out

    @classmethod
    def from_dict(cls, data: dict, n: int, where: str) -> TendonDrive:
        """From a mapping with ``stiffness``, ``pretension`` (a number or C numbers each) and
        optional ``displacement_range``, ``max_tension``, ``base_compliance``, ``backlash``,
        ``softening`` (ValueError naming ``where``)."""
        allowed = {
            "stiffness",
            "pretension",
            "displacement_range",
            "max_tension",
            "base_compliance",
            "backlash",
            "softening",
        }
        if not isinstance(data, dict) or set(data) - allowed or "stiffness" not in data:
            raise ValueError(
                f"{where}: a mapping with stiffness (N/m), pretension (N) and optional "
                f"displacement_range (m), max_tension (N), base_compliance (m/N), backlash (m), "
                f"softening (1/m), got {data!r}"
            )
        try:
            k = np.broadcast_to(np.asarray(data["stiffness"], dtype=np.float64), (n,))
            t0 = np.broadcast_to(np.asarray(data.get("pretension", 0.0), dtype=np.float64), (n,))
        except ValueError as exc:
            raise ValueError(
                f"{where}: stiffness/pretension need 1 or {n} values ({exc})"
            ) from None
        rng = tuple(data.get("displacement_range", (-np.inf, np.inf)))
        return cls(
            tuple(k),
            tuple(t0),
            rng,  # type: ignore[arg-type]
            float(data.get("max_tension", np.inf)),
            float(data.get("base_compliance", 0.0)),
            float(data.get("backlash", 0.0)),
            float(data.get("softening", 0.0)),
        )
