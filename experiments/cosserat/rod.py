"""The Cosserat rod of the discrete-disk robot and its static solvers (issue 21, item 2).

The robot of ``cdcr_gym.model.params`` (any preset) modelled as what it physically is: a
continuous elastic rod, clamped upright at the base disk, carrying rigid spacer disks; every
cable runs *straight* from pinhole to pinhole (base plate → every disk of its sections → its
anchor disk) and loads the rod only where it touches it — point forces at the pinholes,
``T_k·u_k − T_{k−1}·u_{k−1}`` (u_k the unit vector of segment k, from this pinhole to the next;
at the anchor disk ``−T·u`` back along the last segment), applied at the pinhole, i.e. a force
at the disk centre plus the couple ``(pinhole − centre) × F``. The loads follow the deformed
shape. Gravity (optional, −Z0, base upright): the rod's weight per length and each disk's weight
at its station. ``T_k`` may differ per segment (a capstan-decayed cable, Part B of the issue).

Two independent solvers of that problem:

:func:`solve_static`
    Cosserat statics by shooting (Rucker & Webster 2011): the ODEs
    ``p' = R v``, ``R' = R û``, ``n' = −f``, ``m' = −p' × n`` with ``u = K_bt⁻¹ Rᵀ m`` and
    ``v = e3 + K_se⁻¹ Rᵀ n`` (shear and extension as in PyElastica; ``extensible=False``: a
    Kirchhoff rod, v = e3), integrated disk span by disk span with ``scipy.integrate.solve_ivp``
    (DOP853, rtol 1e-11); the point loads of the disks are jumps of the internal force n and
    moment m. The cable's *outgoing* segment at a disk depends on the next disk, not yet
    reached when shooting, so its direction in that disk's frame is an unknown too: Newton on
    n(0), m(0) and the two transverse components of every loaded segment's direction, with
    residuals the free-tip conditions n(ℓ⁺) = m(ℓ⁺) = 0 and the mismatch between assumed and
    shot directions (finite-difference Jacobian, all shots stacked in one ``solve_ivp`` call;
    trust region, backtracking, load continuation from the straight rod). No mesh: its
    discretisation error is the ODE tolerance (checked by dividing it by 100).

:func:`solve_pyelastica`
    PyElastica 1.0 (``CosseratRod`` with dynamic relaxation: an ``AnalyticalLinearDamper`` to a
    static state). The rod is extended half an element past both ends so that its element
    centres fall on s = 0, h/m, …, ℓ: the clamped first element is centred on the base disk
    (a rod starting at the clamp would leave half an element rigid), every disk sits at an
    element centre (forces split to its two nodes, the couple as an element torque in the
    material frame). The loads are recomputed from the deformed shape every step. Mesh:
    ``elements_per_span`` m; converged when doubling m moves the tip < 0.3 mm.

The static solver is exact to its ODE tolerance and fast (seconds), so it gives the reference
tips; PyElastica cross-checks it on a subset (their difference is recorded per case).

The committed reference, its cases and the study are in
:mod:`experiments.cosserat.reference`; PyElastica in
:mod:`experiments.cosserat.pyelastica_solver`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.integrate import solve_ivp

from cdcr_gym.model.params import STANDARD_GRAVITY, RobotParams

__all__ = [
    "RodModel",
    "StaticSolution",
    "solve_static",
    "capstan_segment_tensions",
    "solve_static_capstan",
    "SHEAR_FACTOR",
    "POISSON_RATIO",
]


#: PyElastica's shear correction factor (``CosseratRod.straight_rod``), used by both solvers.
SHEAR_FACTOR = 27.0 / 28.0
#: Poisson's ratio of the backbone (not in RobotParams; only torsion and shear depend on it).
POISSON_RATIO = 0.3


# ------------------------------------------------------------------------------------ the model
@dataclass(frozen=True)
class RodModel:
    """The discrete-disk robot as a rod: stations, cable routing and stiffnesses (SI units).

    Attributes:
        params: the robot.
        stations: (D + 1,) arc length of the base disk (0) and of every spacer disk (m).
        pinholes: (C, 3) pinhole of every cable in its disk's frame (m).
        anchors: (C,) index (1..D) of each cable's anchor disk.
        k_bt: (3,) bending, bending, torsion stiffness EI, EI, GJ (N·m²).
        k_se: (3,) shear, shear, axial stiffness αGA, αGA, EA (N).
        weight_per_length: rod weight (N/m) (0 without gravity).
        disk_weight: weight of one disk (N) (0 without gravity).
        gravity_direction: (3,) unit vector of gravity in R0 (−Z0: base upright).
        stretch_scaled: bending/twist couple K_bt·u/e³ (e the axial stretch), PyElastica's
            volume-conserving law, instead of K_bt·u (default: constant EI, GJ).
    """

    params: RobotParams
    stations: np.ndarray
    pinholes: np.ndarray
    anchors: np.ndarray
    k_bt: np.ndarray
    k_se: np.ndarray
    weight_per_length: float
    disk_weight: float
    gravity_direction: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    stretch_scaled: bool = False

    @classmethod
    def of(cls, params: RobotParams, gravity: bool) -> RodModel:
        s = [0.0]
        for sec in params.sections:
            s.extend(s[-1] + sec.disk_spacing * np.arange(1, sec.n_disks + 1))
        ends = np.cumsum([sec.n_disks for sec in params.sections])
        beta = np.asarray(params.cable_angles)
        radius = np.asarray(params.cable_radii)
        pins = radius[:, None] * np.stack([np.cos(beta), np.sin(beta), 0 * beta], axis=-1)
        e = params.youngs_modulus
        g_mod = e / (2.0 * (1.0 + POISSON_RATIO))
        area = math.pi * params.backbone_diameter**2 / 4.0
        i = params.second_moment_of_area
        g = STANDARD_GRAVITY if gravity else 0.0
        return cls(
            params=params,
            stations=np.asarray(s),
            pinholes=pins,
            anchors=ends[np.asarray(params.cable_section)],
            k_bt=np.array([e * i, e * i, g_mod * 2.0 * i]),
            k_se=np.array([SHEAR_FACTOR * g_mod * area, SHEAR_FACTOR * g_mod * area, e * area]),
            weight_per_length=params.backbone_linear_density * g,
            disk_weight=params.disk_mass * g,
        )

    @property
    def n_disks(self) -> int:
        return len(self.stations) - 1

    def segment_tensions(self, tensions) -> np.ndarray:
        """(D, C) N: tension of every cable in every segment (row k: disk k → k + 1).

        ``tensions`` is (C,) (frictionless: the same in every segment) or (D, C) (per segment);
        rows at or beyond a cable's anchor are set to 0.
        """
        t = np.asarray(tensions, dtype=np.float64)
        d, c = self.n_disks, len(self.anchors)
        if t.shape == (c,):
            t = np.broadcast_to(t, (d, c))
        if t.shape != (d, c):
            raise ValueError(f"tensions must have shape ({c},) or ({d}, {c}), got {t.shape}")
        routed = np.arange(d)[:, None] < self.anchors[None, :]
        return np.where(routed, t, 0.0)


@dataclass
class StaticSolution:
    """A converged static shape.

    Attributes:
        tip: (3,) tip-disk centre (m, R0).
        disk_centres: (D + 1, 3) base and spacer disk centres (m).
        disk_rotations: (D + 1, 3, 3) disk frames (columns: disk x, y, backbone tangent).
        base_force, base_moment: (3,) n(0) (N), m(0) (N·m): the clamp's reaction (negated).
        iterations: fixed-point iterations of the cable directions.
        residual: max |n(ℓ⁺)| (N), |m(ℓ⁺)|/ℓ (N) at the end.
    """

    tip: np.ndarray
    disk_centres: np.ndarray
    disk_rotations: np.ndarray
    base_force: np.ndarray
    base_moment: np.ndarray
    iterations: int
    residual: float


def _hat(u: np.ndarray) -> np.ndarray:
    z = np.zeros(u.shape[:-1])
    return np.stack(
        [
            np.stack([z, -u[..., 2], u[..., 1]], -1),
            np.stack([u[..., 2], z, -u[..., 0]], -1),
            np.stack([-u[..., 1], u[..., 0], z], -1),
        ],
        -2,
    )


def _rhs_factory(model: RodModel, extensible: bool, copies: int, stretch_scaled: bool = False):
    kbt_inv = 1.0 / model.k_bt
    kse_inv = 1.0 / model.k_se
    f = model.weight_per_length * model.gravity_direction
    e3 = np.array([0.0, 0.0, 1.0])

    def rhs(_s, y):
        y = y.reshape(copies, 18)
        r = y[:, 3:12].reshape(copies, 3, 3)
        n = y[:, 12:15]
        m = y[:, 15:18]
        rt_n = np.einsum("kji,kj->ki", r, n)
        rt_m = np.einsum("kji,kj->ki", r, m)
        u = rt_m * kbt_inv
        v = e3 + rt_n * kse_inv if extensible else np.broadcast_to(e3, u.shape)
        if stretch_scaled:  # PyElastica's law: couple = K_bt·u/e³, e the stretch
            u = u * np.linalg.norm(v, axis=1, keepdims=True) ** 3
        dp = np.einsum("kij,kj->ki", r, v)
        dr = r @ _hat(u)
        dn = np.broadcast_to(-f, n.shape)
        dm = -np.cross(dp, n)
        return np.concatenate([dp, dr.reshape(copies, 9), dn, dm], axis=1).reshape(-1)

    return rhs


def _shoot(
    model: RodModel,
    z: np.ndarray,
    seg_t: np.ndarray,
    out_dirs: np.ndarray,
    extensible: bool,
    rtol: float,
):
    """Integrate from the base with n(0), m(0) = z (copies, 6).

    ``seg_t`` (D, C) segment tensions; ``out_dirs`` (D, C, 3) frozen outgoing segment directions
    (world) at disks 0..D−1. Returns the residual (copies, 6), the disk centres (copies, D+1, 3),
    rotations (copies, D+1, 3, 3) and the pinholes (copies, D+1, C, 3).
    """
    copies = z.shape[0]
    d = model.n_disks
    y = np.zeros((copies, 18))
    y[:, 3:12] = np.eye(3).reshape(-1)
    y[:, 12:18] = z
    rhs = _rhs_factory(model, extensible, copies, model.stretch_scaled)
    centres = np.zeros((copies, d + 1, 3))
    rots = np.zeros((copies, d + 1, 3, 3))
    rots[:, 0] = np.eye(3)
    pins = np.zeros((copies, d + 1, len(model.anchors), 3))
    pins[:, 0] = model.pinholes
    for k in range(1, d + 1):
        sol = solve_ivp(
            rhs,
            (model.stations[k - 1], model.stations[k]),
            y.reshape(-1),
            method="DOP853",
            rtol=rtol,
            atol=rtol * 1e-3,
        )
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed in span {k}: {sol.message}")
        y = sol.y[:, -1].reshape(copies, 18).copy()
        p = y[:, 0:3]
        r = y[:, 3:12].reshape(copies, 3, 3)
        centres[:, k] = p
        rots[:, k] = r
        offs = np.einsum("kij,cj->kci", r, model.pinholes)  # (copies, C, 3)
        pins[:, k] = p[:, None, :] + offs
        incoming = pins[:, k] - pins[:, k - 1]
        incoming /= np.linalg.norm(incoming, axis=-1, keepdims=True)
        t_in = seg_t[k - 1]  # (C,)
        t_out = seg_t[k] if k < d else np.zeros_like(t_in)
        if k < d:  # outgoing: frozen in the disk's frame
            outgoing = np.einsum("kij,kcj->kci", r, out_dirs[:, k])
        else:
            outgoing = np.zeros_like(incoming)
        force = t_out[None, :, None] * outgoing - t_in[None, :, None] * incoming  # (copies, C, 3)
        total = force.sum(axis=1)
        moment = np.cross(offs, force).sum(axis=1)
        y[:, 12:15] -= total
        y[:, 15:18] -= moment
        if model.disk_weight:
            y[:, 12:15] -= model.disk_weight * model.gravity_direction  # n jumps by −F
    length = model.stations[-1]
    residual = np.concatenate([y[:, 12:15], y[:, 15:18] / length], axis=1)
    return residual, centres, rots, pins


def _directions(pins: np.ndarray, rots: np.ndarray) -> np.ndarray:
    """Outgoing unit segment directions (D, C, 3) in the frame of the disk they leave, from
    pinholes (D + 1, C, 3) and disk rotations (D + 1, 3, 3)."""
    seg = np.diff(pins, axis=0)
    seg /= np.linalg.norm(seg, axis=-1, keepdims=True)
    return np.einsum("kji,kcj->kci", rots[:-1], seg)


def solve_static(
    params: RobotParams,
    tensions,
    gravity: bool = False,
    *,
    extensible: bool = True,
    rtol: float = 1e-11,
    tol: float = 1e-10,
    max_iter: int = 200,
    guess: StaticSolution | None = None,
    stretch_scaled: bool = False,
) -> StaticSolution:
    """The static shape of the robot under cable ``tensions`` (module docstring, first solver).

    Args:
        params: the robot.
        tensions: (C,) N actuator tensions (frictionless cables), or (D, C) N per segment
            (row k: segment from disk k to k + 1; a capstan-decayed cable).
        gravity: rod and disk weights along −Z0 (base upright).
        extensible: shear and extension as in PyElastica (``False``: inextensible Kirchhoff rod,
            like the bullet chain).
        rtol: ODE tolerance; tol: largest residual (N; moments over ℓ; direction mismatch).
        guess: a previous solution to start from.
        stretch_scaled: PyElastica's constitutive law (:class:`RodModel`), to compare with it.

    Raises:
        RuntimeError: no convergence in ``max_iter`` iterations.
    """
    model = RodModel.of(params, gravity)
    if stretch_scaled:
        model = replace(model, stretch_scaled=True)
    seg_t = model.segment_tensions(tensions)
    if guess is None:
        # load continuation: Newton from the straight rod converges for moderate bends only
        steps = max(1, math.ceil(float(np.max(seg_t, initial=0.0)) / (0.1 * params.max_tension)))
        for j in range(1, steps):
            guess = _solve(model, seg_t * (j / steps), extensible, rtol, 1e-6, max_iter, guess)
    return _solve(model, seg_t, extensible, rtol, tol, max_iter, guess)


def _solve(model, seg_t, extensible, rtol, tol, max_iter, guess) -> StaticSolution:
    """Newton on x = (n(0), m(0), the transverse components (a, b) of every loaded segment's
    direction in the frame of the disk it leaves): residuals the free-tip conditions and the
    mismatch between the assumed and the shot directions. Finite-difference Jacobian, all
    1 + len(x) shots stacked in one ``solve_ivp`` call; trust region and backtracking."""
    d, c = model.n_disks, len(model.anchors)
    active = np.argwhere(seg_t > 0.0)  # (n_act, 2): (segment, cable)
    if guess is None:
        ab = np.zeros((d, c, 2))
        z = np.zeros(6)
    else:
        pins0 = guess.disk_centres[:, None, :] + np.einsum(
            "kij,cj->kci", guess.disk_rotations, model.pinholes
        )
        dirs0 = _directions(pins0, guess.disk_rotations)
        ab = dirs0[..., :2] / dirs0[..., 2:3]
        z = np.concatenate([guess.base_force, guess.base_moment])
    length = model.stations[-1]
    scale = np.concatenate([[1.0, 1.0, 1.0, length, length, length], np.ones(2 * len(active))])

    def unpack(x):  # (copies, n) -> z (copies, 6), directions (copies, D, C, 3)
        copies = x.shape[0]
        full = np.zeros((copies, d, c, 3))
        full[..., 2] = 1.0
        full[:, active[:, 0], active[:, 1], :2] = x[:, 6:].reshape(copies, -1, 2)
        full /= np.linalg.norm(full, axis=-1, keepdims=True)
        return x[:, :6], full

    def residual(x):
        zz, dirs = unpack(x)
        res, centres, rots, pins = _shoot(model, zz, seg_t, dirs, extensible, rtol)
        shot = _directions_batch(pins, rots)
        shot_ab = shot[:, active[:, 0], active[:, 1], :2] / shot[:, active[:, 0], active[:, 1], 2:3]
        mismatch = (shot_ab - x[:, 6:].reshape(x.shape[0], -1, 2)).reshape(x.shape[0], -1)
        return np.concatenate([res, mismatch], axis=1), centres, rots

    x = np.concatenate([z, ab[active[:, 0], active[:, 1]].reshape(-1)])
    n = x.size
    for it in range(1, max_iter + 1):
        h = 1e-7 * np.maximum(1.0, np.abs(x / scale)) * scale
        xs = np.tile(x, (n + 1, 1))
        xs[1:] += np.diag(h)
        res, centres, rots = residual(xs)
        r0 = res[0]
        if np.max(np.abs(r0)) < tol:
            zz = x[:6]
            return StaticSolution(
                centres[0, -1].copy(),
                centres[0],
                rots[0],
                zz[:3].copy(),
                zz[3:].copy(),
                it,
                float(np.max(np.abs(r0))),
            )
        jac = ((res[1:] - r0) / h[:, None]).T
        step = np.linalg.solve(jac, r0)
        # trust region: a step may change the bend it causes by at most 0.5 rad and a
        # segment direction by at most 0.1
        bend = max(
            np.max(np.abs(step[3:6])) * length / model.k_bt[0],
            np.max(np.abs(step[:3])) * length**2 / model.k_bt[0],
            10.0 * np.max(np.abs(step[6:]), initial=0.0),
        )
        if bend > 0.5:
            step *= 0.5 / bend
        norm0 = np.linalg.norm(r0 / scale)
        for _ in range(30):
            try:
                trial = residual((x - step)[None])[0][0]
                if np.linalg.norm(trial / scale) < norm0:
                    break
            except RuntimeError:
                pass
            step = 0.5 * step
        else:  # no descent: the residual is at the noise floor of the ODE tolerance
            if np.max(np.abs(r0)) < 1e3 * tol:
                return StaticSolution(
                    centres[0, -1].copy(),
                    centres[0],
                    rots[0],
                    x[:3].copy(),
                    x[3:6].copy(),
                    it,
                    float(np.max(np.abs(r0))),
                )
            raise RuntimeError(f"solve_static: stalled at residual {np.max(np.abs(r0)):.3g}")
        x = x - step
        if np.max(np.abs(step / scale)) < 1e-13:
            res, centres, rots = residual(x[None])
            return StaticSolution(
                centres[0, -1].copy(),
                centres[0],
                rots[0],
                x[:3].copy(),
                x[3:6].copy(),
                it,
                float(np.max(np.abs(res[0]))),
            )
    raise RuntimeError(f"solve_static: no convergence in {max_iter} iterations")


def _directions_batch(pins: np.ndarray, rots: np.ndarray) -> np.ndarray:
    """:func:`_directions` over a leading batch axis."""
    seg = np.diff(pins, axis=1)
    seg /= np.linalg.norm(seg, axis=-1, keepdims=True)
    return np.einsum("bkji,bkcj->bkci", rots[:, :-1], seg)


# ------------------------------------------------------------------------- capstan friction
def capstan_segment_tensions(
    params: RobotParams, solution: StaticSolution, tensions, mu: float, slip: float = 1.0
) -> np.ndarray:
    """Capstan-decayed segment tensions (D, C) N on a solved shape, computed here from the
    rod's own pinholes (independently of ``cdcr_gym.model.friction`` and the bullet chain).

    The wrap at the base disk is the angle between +Z0 (where the cable arrives from the
    actuator) and the first segment; at disk k between segments k − 1 and k.
    Segment k carries ``T·exp(−slip·μ·Σ_{j≤k} α_j)`` (slip +1: pulled, the tension falls towards
    the anchor; −1: released).
    """
    model = RodModel.of(params, gravity=False)
    pins = solution.disk_centres[:, None, :] + np.einsum(
        "kij,cj->kci", solution.disk_rotations, model.pinholes
    )
    seg = np.diff(pins, axis=0)
    u = seg / np.linalg.norm(seg, axis=-1, keepdims=True)  # (D, C, 3)
    incoming = np.concatenate([np.broadcast_to([0.0, 0.0, 1.0], u[:1].shape), u[:-1]], axis=0)
    cosines = np.clip(np.sum(incoming * u, axis=-1), -1.0, 1.0)
    wraps = np.arccos(cosines)  # (D, C)
    t = np.asarray(tensions, dtype=np.float64)
    return t[None, :] * np.exp(-slip * mu * np.cumsum(wraps, axis=0))


def solve_static_capstan(
    params: RobotParams,
    tensions,
    mu: float,
    gravity: bool = False,
    slip: float = 1.0,
    *,
    tol: float = 1e-9,
    max_iter: int = 50,
) -> tuple[StaticSolution, np.ndarray]:
    """Static shape with capstan-decayed cable tensions: the segment tensions of
    :func:`capstan_segment_tensions` on the shape they produce (fixed point from the
    frictionless shape). Returns the solution and the segment tensions (D, C) N."""
    sol = solve_static(params, tensions, gravity, rtol=1e-9)
    for _ in range(max_iter):
        seg_t = capstan_segment_tensions(params, sol, tensions, mu, slip)
        new = solve_static(params, seg_t, gravity, rtol=1e-9, guess=sol)
        if np.max(np.abs(new.tip - sol.tip)) < tol:
            return new, seg_t
        sol = new
    raise RuntimeError("solve_static_capstan: no convergence")
