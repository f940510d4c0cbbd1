"""The paper's CCKA-vs-simulation study (``python -m training.studies.reproduce``), and beyond.

The paper (section 4) pulls cable 1 with 0–80 N in a nonlinear SolidWorks simulation, feeds the
resulting cable lengths to the constant-curvature forward kinematics (CCKA, its eq. 5) and compares
the two tips: mean Euclidean error 4.95 mm (0.77 % of ℓ) against the simulation, 2.4 mm (0.37 %)
against an experiment. This module repeats that study with a physics backbone in place of
SolidWorks: any backend factory (``mujoco_factory``: ``MuJoCoBackend``, the CLI's default;
``bullet_factory``: ``cdcr_gym.backends.bullet.BulletBackend``, ``run_study``'s default). The
study is about the paper's one-section robot with its three cables (``C = params.n_cables = 3``); a backend is driven through
the batched :class:`cdcr_gym.backends.base.Backend` interface with one robot (N = 1):

1. CCKA alone (paper Fig. 6/7): cable lengths l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2 → tip X, Y, Z, and a
   few backbone shapes in 3-D.
2. Physics alone (Fig. 5): tension T on cable 1 from 0 to 80 N, settled tip against T.
3. CCKA vs physics (Fig. 10–12): at each settled state, the CCKA tip computed from the *sensed*
   cable lengths (pinhole-to-pinhole) against the simulated tip, per axis and Euclidean — gravity
   off (as the paper's simulation) and on.
4. Beyond the paper: a tip payload (0–200 g by default), the model resolution (links per disk
   span, gravity off and on), the number of spacer disks, and a horizontal base; a paragraph saying, with the numbers of the run, where the
   constant-curvature assumption stops holding.

Every state is a *verified* static equilibrium: :func:`settle` resets the backend to its
equilibrium under the tensions, then keeps applying the same tensions until the tip moves less
than a tolerance (1 µm by default) over a window of control steps, and raises
:class:`SettleError` if it does not within a cap.

Outputs (one folder, ``--out``): PNG figures (:mod:`training.studies.reproduce.plots`), one CSV per
sweep (SI units, unit in each column name), ``summary.csv`` (the table), ``report.md``
(:mod:`training.studies.reproduce.report`) and ``run.json`` (configuration, timings).

Usage::

    python -m training.studies.reproduce [--out DIR] [--quick] [--forces N] [--payloads-g 0,50,...]
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from cdcr_gym import kinematics as K
from cdcr_gym.backends.base import Backend
from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.backends.mujoco import MuJoCoBackend
from cdcr_gym.model import statics
from cdcr_gym.model.params import RobotParams

__all__ = [
    "PAPER_RESULTS",
    "SettleError",
    "SettleInfo",
    "StudyConfig",
    "Sweep",
    "StudyResults",
    "settle",
    "tip_of",
    "cable1_tensions",
    "bullet_factory",
    "mujoco_factory",
    "FACTORIES",
    "backend_label",
    "ccka_cable_sweep",
    "robot_mass",
    "run_force_sweep",
    "run_study",
]

#: The paper's mean Euclidean errors (section 4.4): (label, mm, % of ℓ).
PAPER_RESULTS: tuple[tuple[str, float, float], ...] = (
    ("paper: CCKA vs SolidWorks (nonlinear dynamic simulation)", 4.95, 0.77),
    ("paper: CCKA vs experiment (FARO arm, hanging weights)", 2.4, 0.37),
)

#: Default output folder.
DEFAULT_OUT = Path("runs") / "reproduce"

#: Quaternion (x, y, z, w) of a base rotated by −90° about world Y: the backbone (+Z0) points
#: along world −X, cable 1 (+X0) points up, so pulling cable 1 lifts the sagging cantilever.
HORIZONTAL_BASE = (0.0, -math.sin(math.pi / 4.0), 0.0, math.cos(math.pi / 4.0))


# ---------------------------------------------------------------------------------------------
# Settling
# ---------------------------------------------------------------------------------------------
class SettleError(RuntimeError):
    """The backend did not reach a static equilibrium within the step cap (or went non-finite)."""


@dataclass(frozen=True)
class SettleInfo:
    """How an equilibrium was reached and confirmed.

    Attributes:
        steps: control steps applied after the reset until the check passed.
        motion: tip displacement (m) over the last check window (at most the tolerance).
        drift: tip displacement (m) between the state right after ``reset(tensions)`` and the
            confirmed equilibrium (≈ 0 when ``reset`` gives the equilibrium); NaN on the
            dynamic route.
        route: ``"reset"`` (the backend's reset-to-equilibrium, then verified) or
            ``"dynamic"`` (the backend's reset refused these tensions: reset to zero tension,
            ramp the tensions up, hold them until settled).
    """

    steps: int
    motion: float
    drift: float
    route: str = "reset"


def tip_of(backend: Backend) -> np.ndarray:
    """Tip position (3,) m of the backend's robot 0 (a fresh float64 copy)."""
    return np.array(backend.read().tip[0], dtype=np.float64)


def settle(
    backend: Backend,
    tensions: np.ndarray,
    *,
    tol: float = 1e-6,
    window: int = 25,
    max_steps: int = 5000,
    ramp_steps: int = 50,
) -> SettleInfo:
    """Put ``backend`` at its static equilibrium under ``tensions`` and verify it is settled.

    Calls ``backend.reset(tensions[None])``, then applies the same tensions in windows of ``window``
    control steps until the tip moves by at most ``tol`` over one window. If the backend's
    reset raises (a ``RuntimeError``, e.g. its equilibrium solver did not converge), takes the
    dynamic route instead: reset to zero tension, tensions ramped linearly over ``ramp_steps`` control
    steps, then held and checked the same way.

    Args:
        backend: the robot model, one robot (N = 1).
        tensions: cable tensions (C,), N (``C = backend.params.n_cables``).
        tol: settling tolerance on the tip displacement over one window, m.
        window: control steps per check.
        max_steps: cap on the control steps after the reset (ramp included).
        ramp_steps: control steps of the tension ramp on the dynamic route.

    Returns:
        A :class:`SettleInfo`.

    Raises:
        SettleError: if the tip is not finite, or still moves more than ``tol`` per window after
            ``max_steps`` steps; the message gives the tensions, the motion and how to proceed.
    """
    tensions = np.asarray(tensions, dtype=np.float64)
    command = tensions[None]  # (1, C): the backend's batch of one robot
    route = "reset"
    steps = 0
    try:
        backend.reset(command)
    except RuntimeError as exc:
        route = "dynamic"
        reset_error = exc
        try:
            backend.reset(np.zeros_like(command))
            for k in range(1, ramp_steps + 1):
                backend.apply_tensions(command * (k / ramp_steps))
        except RuntimeError as exc2:
            raise SettleError(
                f"the backend's reset to tensions {tensions} N failed ({reset_error}), and so did "
                f"the dynamic route from zero tension ({exc2})"
            ) from exc2
        steps = ramp_steps
    start = tip_of(backend)
    prev = start
    while True:
        try:
            for _ in range(window):
                backend.apply_tensions(command)
        except RuntimeError as exc:  # e.g. the backend's divergence error
            raise SettleError(
                f"the backend failed while settling under tensions {tensions} N after {steps} "
                f"control steps ({route} route): {exc}"
            ) from exc
        steps += window
        tip = tip_of(backend)
        if not np.all(np.isfinite(tip)):
            raise SettleError(
                f"backend state became non-finite while settling under tensions {tensions} N "
                f"(after {steps} control steps, {route} route)"
            )
        motion = float(np.linalg.norm(tip - prev))
        if motion <= tol:
            drift = float(np.linalg.norm(tip - start)) if route == "reset" else float("nan")
            return SettleInfo(steps=steps, motion=motion, drift=drift, route=route)
        if steps >= max_steps:
            why = "" if route == "reset" else f" (the backend's reset had failed: {reset_error})"
            raise SettleError(
                f"no static equilibrium under tensions {tensions} N: after {steps} control steps "
                f"the tip still moved {motion:.3g} m over the last {window} steps (tolerance "
                f"{tol:g} m){why}. Raise --settle-max-steps, loosen --settle-tol, or check the "
                f"backend's damping/timestep."
            )
        prev = tip


# ---------------------------------------------------------------------------------------------
# Configuration and results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StudyConfig:
    """What the study sweeps. SI units (N, m, kg).

    Attributes:
        params: the robot (defaults: the paper's Table 1, E = 35 GPa).
        forces: tensions on cable 1 for every physics sweep, N (the paper: 0–80 N).
        dl_max: largest Δl of the CCKA-alone sweep, m; ``None``: r·θ(max force), i.e. the bend
            the pure-moment model gives at the largest force.
        n_dl: points of the CCKA-alone sweep.
        shape_dls: Δl values (m) whose backbones are drawn in 3-D; ``None``: 5 evenly spaced.
        payloads: tip payloads for the payload study (gravity on), kg.
        links_per_span_values: links per disk span of the model-resolution study (the robot of
            ``params``, gravity off and on).
        n_disks_values: disk counts of the disk-count study (gravity off), each cut into about
            ``disk_study_links`` links (links per span = max(1, disk_study_links // n_disks)).
            At least 4 for the paper's robot: with 3 disks a span (213.7 mm) buckles under the
            three cables at max_tension (240 N > π²·EI/h² = 232 N), which the pybullet backend
            rejects (``cdcr_gym.model.discrete.check_span_buckling``).
        disk_study_links: target number of links of the disk-count study.
        resolution_forces: forces (N) of both studies; ``None``: ``forces``.
        horizontal: also run the sweep with a horizontal base (gravity across the backbone).
        links_per_span: links per disk span of the main sweeps (default 4: converged, see the
            resolution study; 1 over-states the discrete-routing excess threefold).
        threshold_pct: the error (% of ℓ) above which CCKA is said to stop holding.
        settle_tol, settle_window, settle_max_steps: see :func:`settle`.
        backend_kwargs: extra keyword arguments for the backend constructor.
    """

    params: RobotParams = field(default_factory=RobotParams)
    forces: tuple[float, ...] = tuple(np.linspace(0.0, 80.0, 17).tolist())
    dl_max: float | None = None
    n_dl: int = 41
    shape_dls: tuple[float, ...] | None = None
    payloads: tuple[float, ...] = (0.0, 0.05, 0.1, 0.15, 0.2)
    links_per_span_values: tuple[int, ...] = (1, 2, 4)
    n_disks_values: tuple[int, ...] = (4, 5, 9, 17, 33)
    disk_study_links: int = 36
    resolution_forces: tuple[float, ...] | None = (0.0, 20.0, 40.0, 60.0, 80.0)
    horizontal: bool = True
    links_per_span: int = 4
    threshold_pct: float = 1.0
    settle_tol: float = 1e-6
    settle_window: int = 25
    settle_max_steps: int = 5000
    backend_kwargs: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        p = self.params
        if not isinstance(p, RobotParams):
            raise ValueError(f"params must be a RobotParams, got {p!r}")
        if p.n_sections != 1 or p.n_cables != 3:
            raise ValueError(
                f"the study is about one section driven by three cables (the paper's robot, "
                f"CCKA from three cable lengths), got {p.n_sections} section(s) and "
                f"{p.n_cables} cables"
            )
        f = np.asarray(self.forces, dtype=np.float64)
        if f.ndim != 1 or f.size < 2 or not np.all(np.isfinite(f)):
            raise ValueError(f"forces must be >= 2 finite values (N), got {self.forces!r}")
        if np.any(f < 0.0) or np.any(f > p.max_tension) or np.any(np.diff(f) <= 0.0):
            raise ValueError(
                f"forces must increase strictly within [0, max_tension={p.max_tension}] N, "
                f"got {self.forces!r}"
            )
        if self.dl_max is not None and not (math.isfinite(self.dl_max) and self.dl_max > 0.0):
            raise ValueError(f"dl_max must be finite and > 0 m, got {self.dl_max!r}")
        if self.n_dl < 2:
            raise ValueError(f"n_dl must be >= 2, got {self.n_dl!r}")
        pl = np.asarray(self.payloads, dtype=np.float64)
        if pl.ndim != 1 or pl.size < 1 or not np.all(np.isfinite(pl)) or np.any(pl < 0.0):
            raise ValueError(f"payloads must be finite and >= 0 kg, got {self.payloads!r}")
        if np.any(np.diff(pl) <= 0.0):
            raise ValueError(f"payloads must increase strictly, got {self.payloads!r}")
        for name in ("n_disks_values", "links_per_span_values"):
            vals = getattr(self, name)
            if any(isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in vals):
                raise ValueError(f"{name} must be integers >= 1, got {vals!r}")
        for name in ("links_per_span", "disk_study_links"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
        if not (math.isfinite(self.threshold_pct) and self.threshold_pct > 0.0):
            raise ValueError(f"threshold_pct must be > 0, got {self.threshold_pct!r}")
        if not (math.isfinite(self.settle_tol) and self.settle_tol > 0.0):
            raise ValueError(f"settle_tol must be > 0 m, got {self.settle_tol!r}")
        if self.settle_window < 1 or self.settle_max_steps < self.settle_window:
            raise ValueError(
                f"need 1 <= settle_window <= settle_max_steps, got {self.settle_window!r}, "
                f"{self.settle_max_steps!r}"
            )

    @property
    def resolved_dl_max(self) -> float:
        """Largest Δl of the CCKA sweep (m)."""
        if self.dl_max is not None:
            return float(self.dl_max)
        theta, _ = statics.arc_from_tensions(
            cable1_tensions(max(self.forces), self.params), self.params
        )
        return float(self.params.cable_radius * theta)


@dataclass
class CCKASweep:
    """CCKA alone: l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2 (paper section 4.2). Arrays in m / rad."""

    dl: np.ndarray  # (n,)
    lengths: np.ndarray  # (n, 3)
    tip: np.ndarray  # (n, 3)
    theta: np.ndarray  # (n,)
    shape_dl: np.ndarray  # (k,)
    shapes: np.ndarray  # (k, m, 3)


@dataclass
class Sweep:
    """One physics sweep over the tension on cable 1, with its CCKA comparison.

    Arrays are SI (N, m); rows follow ``forces``.
    """

    label: str
    gravity: bool
    payload: float  # kg
    n_disks: int
    links_per_span: int
    base_orientation: tuple[float, float, float, float]
    forces: np.ndarray  # (n,)
    tensions: np.ndarray  # (n, 3)
    tip_sim: np.ndarray  # (n, 3)
    lengths: np.ndarray  # (n, 3) sensed
    tip_ccka: np.ndarray  # (n, 3) CCKA from the sensed lengths
    settle_steps: np.ndarray  # (n,)
    settle_motion: np.ndarray  # (n,)
    settle_drift: np.ndarray  # (n,)
    settle_route: np.ndarray  # (n,) str: "reset" or "dynamic"
    shapes: dict[float, np.ndarray] = field(default_factory=dict)  # force -> backbone (m, 3)
    seconds: float = 0.0
    cable_radius: float = 0.029  # m, for theta_ccka

    @property
    def error(self) -> np.ndarray:
        """CCKA − simulation, per axis, (n, 3) m."""
        return self.tip_ccka - self.tip_sim

    @property
    def error_norm(self) -> np.ndarray:
        """Euclidean CCKA error, (n,) m."""
        return np.linalg.norm(self.error, axis=-1)

    @property
    def theta_sim(self) -> np.ndarray:
        """Bending angle (rad) of the chord-based arc through the simulated tip (2·atan2(ρ, z))."""
        return 2.0 * np.arctan2(
            np.hypot(self.tip_sim[:, 0], self.tip_sim[:, 1]), self.tip_sim[:, 2]
        )

    @property
    def theta_ccka(self) -> np.ndarray:
        """Bending angle (rad) CCKA reads from the sensed cable lengths."""
        return K.arc_from_lengths(self.lengths, self.cable_radius)[0]

    def stats(self, length: float) -> dict[str, float]:
        """Mean and max Euclidean error, in m and in % of ``length``."""
        e = self.error_norm
        return {
            "mean_m": float(e.mean()),
            "max_m": float(e.max()),
            "mean_pct": float(100.0 * e.mean() / length),
            "max_pct": float(100.0 * e.max() / length),
            "force_at_max_N": float(self.forces[int(np.argmax(e))]),
        }


@dataclass
class StudyResults:
    """Everything the study computed."""

    config: StudyConfig
    ccka: CCKASweep
    gravity_off: Sweep
    gravity_on: Sweep
    payload: list[Sweep]
    resolution_links: list[Sweep]  # gravity off, the robot of params, links per span varied
    resolution_links_on: list[Sweep]  # the same with gravity on
    resolution_disks: list[Sweep]  # gravity off, disk count varied
    horizontal: Sweep | None
    seconds: float = 0.0
    horizontal_error: str | None = None  # why the horizontal sweep is missing, if it failed
    backend_name: str = ""


# ---------------------------------------------------------------------------------------------
# Sweeps
# ---------------------------------------------------------------------------------------------
BackendFactory = Callable[..., Backend]


def bullet_factory(
    params: RobotParams,
    *,
    gravity: bool,
    links_per_span: int,
    tip_payload: float,
    base_orientation: tuple[float, float, float, float],
    **kwargs,
) -> Backend:
    """The pybullet backbone (imported here, so that the CCKA part runs without pybullet)."""

    return BulletBackend(
        params,
        gravity=gravity,
        links_per_span=links_per_span,
        tip_payload=tip_payload,
        base_orientation=base_orientation,
        **kwargs,
    )


def mujoco_factory(
    params: RobotParams,
    *,
    gravity: bool,
    links_per_span: int,
    tip_payload: float,
    base_orientation: tuple[float, float, float, float],
    **kwargs,
) -> Backend:
    """The MuJoCo backbone (``MuJoCoBackend``: ball joints, the corrected cable routing — the
    package's reference physics, within 0.2 % of ℓ of a converged Cosserat rod at one link per
    span; docs/mujoco_backend.md). Imported here, so that the CCKA part runs without MuJoCo."""

    return MuJoCoBackend(
        params,
        gravity=gravity,
        links_per_span=links_per_span,
        tip_payload=tip_payload,
        base_orientation=base_orientation,
        **kwargs,
    )


#: ``cdcr-gym reproduce --backend NAME`` → the backend factory.
FACTORIES: dict[str, BackendFactory] = {"bullet": bullet_factory, "mujoco": mujoco_factory}
#: The factory's name (``StudyResults.backend_name``) → how the report names the simulation.
_LABELS = {"bullet_factory": "pybullet", "mujoco_factory": "MuJoCo"}


def backend_label(backend_name: str) -> str:
    """How the report, table and figures name the physics of a study ("pybullet", "MuJoCo")."""
    return _LABELS.get(backend_name, "pybullet" if not backend_name else backend_name)


def cable1_tensions(forces, params: RobotParams) -> np.ndarray:
    """Tensions (..., C) N pulling cable 1 with ``forces`` (...) N, every other cable slack."""
    forces = np.asarray(forces, dtype=np.float64)
    t = np.zeros(forces.shape + (params.n_cables,))
    t[..., 0] = forces
    return t


def ccka_cable_sweep(params: RobotParams, dl_max: float, n: int, shape_dls=None) -> CCKASweep:
    """The paper's Fig. 6/7 input: l1 = ℓ − Δl, l2 = l3 = ℓ + Δl/2 for Δl in [0, dl_max] (m)."""
    ell = params.length
    dl = np.linspace(0.0, dl_max, n)
    lengths = np.stack([ell - dl, ell + dl / 2.0, ell + dl / 2.0], axis=-1)
    tip = K.forward_kinematics(lengths, params.cable_radius)
    theta, _, _ = K.arc_from_lengths(lengths, params.cable_radius)
    shape_dl = np.linspace(0.0, dl_max, 5) if shape_dls is None else np.asarray(shape_dls, float)
    s_len = np.stack([ell - shape_dl, ell + shape_dl / 2.0, ell + shape_dl / 2.0], axis=-1)
    s_theta, s_phi, _ = K.arc_from_lengths(s_len, params.cable_radius)
    shapes = K.backbone_points(s_theta, s_phi, ell, n=60)
    return CCKASweep(dl=dl, lengths=lengths, tip=tip, theta=theta, shape_dl=shape_dl, shapes=shapes)


def run_force_sweep(
    factory: BackendFactory,
    params: RobotParams,
    forces: Sequence[float],
    *,
    label: str,
    gravity: bool,
    payload: float = 0.0,
    links_per_span: int = 1,
    base_orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0),
    shape_forces: Sequence[float] = (),
    settle_tol: float = 1e-6,
    settle_window: int = 25,
    settle_max_steps: int = 5000,
    backend_kwargs: dict | None = None,
) -> Sweep:
    """Tension ``forces`` (N) on cable 1, one verified equilibrium each; CCKA from sensed lengths.

    The factory builds a backend of one robot (N = 1) for a one-section robot of three cables
    (CCKA reads its three sensed cable lengths).

    Raises:
        SettleError: if a state does not settle (the message names the sweep).
    """
    t0 = time.perf_counter()
    forces = np.asarray(forces, dtype=np.float64)
    n = forces.size
    tensions = cable1_tensions(forces, params)
    tip_sim = np.empty((n, 3))
    lengths = np.empty((n, params.n_cables))
    steps = np.empty(n, dtype=int)
    motion = np.empty(n)
    drift = np.empty(n)
    route = np.empty(n, dtype=object)
    shapes: dict[float, np.ndarray] = {}
    backend = factory(
        params,
        gravity=gravity,
        links_per_span=links_per_span,
        tip_payload=payload,
        base_orientation=tuple(base_orientation),
        **(backend_kwargs or {}),
    )
    try:
        for i, t in enumerate(tensions):
            try:
                info = settle(
                    backend, t, tol=settle_tol, window=settle_window, max_steps=settle_max_steps
                )
            except SettleError as exc:
                raise SettleError(f"[{label}] {exc}") from exc
            readings = backend.read()
            tip_sim[i] = readings.tip[0]
            lengths[i] = readings.cable_lengths[0]
            steps[i], motion[i], drift[i], route[i] = (
                info.steps,
                info.motion,
                info.drift,
                info.route,
            )
            if any(abs(forces[i] - f) < 1e-9 for f in shape_forces):
                shapes[float(forces[i])] = np.asarray(backend.backbone_points(0), dtype=np.float64)
    finally:
        backend.close()
    tip_ccka = K.forward_kinematics(lengths, params.cable_radius)
    return Sweep(
        label=label,
        gravity=gravity,
        payload=float(payload),
        n_disks=params.n_disks,
        links_per_span=links_per_span,
        base_orientation=tuple(float(v) for v in base_orientation),
        forces=forces,
        tensions=tensions,
        tip_sim=tip_sim,
        lengths=lengths,
        tip_ccka=tip_ccka,
        settle_steps=steps,
        settle_motion=motion,
        settle_drift=drift,
        settle_route=route,
        shapes=shapes,
        seconds=time.perf_counter() - t0,
        cable_radius=params.cable_radius,
    )


def run_study(
    config: StudyConfig,
    factory: BackendFactory = bullet_factory,
    log: Callable[[str], None] = print,
) -> StudyResults:
    """Run every sweep of the study (see the module docstring)."""
    t0 = time.perf_counter()
    p = config.params
    forces = config.forces
    common = dict(
        settle_tol=config.settle_tol,
        settle_window=config.settle_window,
        settle_max_steps=config.settle_max_steps,
        backend_kwargs=config.backend_kwargs,
        links_per_span=config.links_per_span,
    )
    f_max = max(forces)
    shape_forces = tuple(sorted({forces[0], forces[len(forces) // 2], f_max}))

    preflight(config, factory)
    log("CCKA alone: cable-length sweep")
    ccka = ccka_cable_sweep(p, config.resolved_dl_max, config.n_dl, config.shape_dls)

    def sweep(label: str, **kw) -> Sweep:
        s = run_force_sweep(
            factory,
            kw.pop("params", p),
            forces=kw.pop("forces", forces),
            label=label,
            **{**common, **kw},
        )
        st = s.stats(p.length)
        log(
            f"  {label:<38s} mean {1e3 * st['mean_m']:7.2f} mm  max {1e3 * st['max_m']:7.2f} mm"
            f"  ({s.seconds:5.1f} s)"
        )
        return s

    log(f"physics vs CCKA (tension 0–{f_max:.0f} N on cable 1)")
    off = sweep("gravity off", gravity=False, shape_forces=shape_forces)
    on = sweep("gravity on", gravity=True, shape_forces=shape_forces)

    log("tip payload (gravity on)")
    payload = [
        on
        if m == 0.0
        else sweep(f"payload {1e3 * m:g} g", gravity=True, payload=m, shape_forces=(f_max,))
        for m in config.payloads
    ]

    res_forces = config.resolution_forces or forces

    def per_span(k: int) -> str:
        return f"{k} link{'s' if k > 1 else ''} per span"

    log(f"model resolution ({p.n_disks} disks; gravity off, then on)")
    res_links = [
        sweep(
            f"{p.n_disks} disks, {per_span(k)}", gravity=False, forces=res_forces, links_per_span=k
        )
        for k in config.links_per_span_values
    ]
    res_links_on = [
        sweep(
            f"{p.n_disks} disks, {per_span(k)}, gravity on",
            gravity=True,
            forces=res_forces,
            links_per_span=k,
        )
        for k in config.links_per_span_values
    ]
    log(f"number of spacer disks (≈ {config.disk_study_links} links each, gravity off)")
    res_disks = []
    for n in config.n_disks_values:
        k = max(1, config.disk_study_links // n)
        res_disks.append(
            sweep(
                f"{n} disks, {per_span(k)}",
                gravity=False,
                params=_with_disks(p, n),
                forces=res_forces,
                links_per_span=k,
            )
        )
    horizontal, horizontal_error = None, None
    if config.horizontal:
        # An extension beyond the paper and the issue: a failure here is reported, not fatal.
        log("horizontal base (gravity across the backbone)")
        try:
            horizontal = sweep(
                "horizontal base, gravity on",
                gravity=True,
                base_orientation=HORIZONTAL_BASE,
                shape_forces=shape_forces,
            )
        except SettleError as exc:
            horizontal_error = str(exc)
            log(f"  horizontal base: skipped, {exc}")
    return StudyResults(
        config=config,
        ccka=ccka,
        gravity_off=off,
        gravity_on=on,
        payload=payload,
        resolution_links=res_links,
        resolution_links_on=res_links_on,
        resolution_disks=res_disks,
        horizontal=horizontal,
        horizontal_error=horizontal_error,
        seconds=time.perf_counter() - t0,
        backend_name=getattr(factory, "__name__", type(factory).__name__),
    )


def backend_configs(config: StudyConfig) -> list[tuple[int, int]]:
    """The distinct (n_disks, links_per_span) the study will build, in order."""
    p = config.params
    combos = [(p.n_disks, config.links_per_span)]
    combos += [(p.n_disks, k) for k in config.links_per_span_values]
    combos += [(n, max(1, config.disk_study_links // n)) for n in config.n_disks_values]
    return list(dict.fromkeys(combos))


def preflight(config: StudyConfig, factory: BackendFactory) -> None:
    """Build (and close) every backend configuration once before any sweep.

    Raises:
        ValueError: the backend's own message, prefixed with the configuration, if it refuses
            one (e.g. more joints than pybullet holds), so the study stops before running.
    """
    for n, k in backend_configs(config):
        try:
            b = factory(
                _with_disks(config.params, n),
                gravity=False,
                links_per_span=k,
                tip_payload=0.0,
                base_orientation=(0.0, 0.0, 0.0, 1.0),
                **config.backend_kwargs,
            )
        except ValueError as exc:
            raise ValueError(f"{n} disks × {k} links per span: {exc}") from exc
        b.close()


def _with_disks(params: RobotParams, n_disks: int) -> RobotParams:
    """The one-section robot ``params`` with ``n_disks`` spacer disks."""
    return replace(params, n_disks=int(n_disks))


def robot_mass(params: RobotParams) -> float:
    """Backbone plus spacer disks (kg); the fixed base disk does not count."""
    return params.backbone_linear_density * params.length + params.n_disks * params.disk_mass
