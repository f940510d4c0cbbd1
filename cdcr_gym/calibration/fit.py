"""The fit: ``scipy.optimize.least_squares`` over the chosen parameters, with confidence
intervals from the Jacobian.

Residuals: for every row the predicted minus the measured tip, divided by the row's ``sigma``
(3 per row), and, where the data hold tip tangents, their difference divided by ``sigma_dir``
(3 more). The parameters are the scaled variables of :mod:`cdcr_gym.calibration.parameters`
within their bounds (trust-region reflective, ``method="trf"``); the Jacobian is by finite
differences (forward, ``diff_step`` relative to the scaled variable: 1e-6 for the analytic model,
1e-3 for a physics backend, whose settled tips carry a small settling error that a tiny step
would amplify).

Confidence intervals: with J the Jacobian of the weighted residuals at the solution (scaled
variables) and s² = Σ r² / (n − p) the residual variance (n residuals, p parameters), the
covariance is C = (JᵀJ)⁻¹·s² (the Gauss–Newton approximation, as ``scipy.optimize.curve_fit``
with ``absolute_sigma=False``: the given σ weight the rows, their overall scale comes from the
residuals); the 95 % interval is ± t₀.₉₇₅(n − p)·√C_kk, mapped to SI units through the
derivative of the scaling. Parameters that the data cannot tell apart (e.g. E and the cable
radius when only the cables bend the robot: the tips depend on r/E alone) show up as a
near-singular JᵀJ; they are reported as not identifiable (infinite interval) with the
correlations.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import t as student_t

from cdcr_gym.calibration.data import Measurements
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.parameters import (
    ParameterSpec,
    check_start,
    drive_only,
    expand_names,
    parameter_specs,
    pin_ill_posed,
    resolve_names,
)
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.simulate import (
    AnalyticReplay,
    BackendReplay,
    DriveReplay,
    Prediction,
    backend_class,
)
from cdcr_gym.model.params import RobotParams

__all__ = ["CalibrationResult", "calibrate", "DEFAULT_START"]

#: Start values (SI) of parameters the robot does not carry, when fitted without a given start.
DEFAULT_START = {"friction_coefficient": 0.1, "tip_payload": 0.01, "backbone_friction": 1e-3}
#: The start of ``drive_softening`` (1/m: pulls saturating towards 100 mm) when the drive has none.
SOFTENING_START = 10.0
#: Condition number of the scaled JᵀJ above which parameters are reported not identifiable.
SINGULAR = 1e12


@dataclass
class CalibrationResult:
    """What a calibration found (SI units).

    Attributes:
        names: the fitted parameters, in order.
        start: their start values; ``values``: the fitted values.
        ci95: half-widths of the 95 % confidence intervals (inf: not identifiable).
        std: standard errors; ``correlation``: (p, p) correlation matrix.
        params: the fitted robot; ``backend_kwargs``: the backend's fitted keyword arguments.
        backend: the backend name; ``data``: the measurements.
        before / after: predictions with the start and the fitted values.
        residual_sigma: s, the residual standard deviation in units of the rows' σ.
        identifiable: False if JᵀJ was (near) singular.
        nfev: model runs (the Jacobian's finite differences included); seconds, message,
            success: from the optimiser.
        unsettled: the largest tip motion (m) in the last control step of any row (physics).
    """

    names: list[str]
    start: dict[str, float]
    values: dict[str, float]
    ci95: dict[str, float]
    std: dict[str, float]
    correlation: np.ndarray
    params: RobotParams
    backend_kwargs: dict[str, Any]
    backend: str
    data: Measurements
    before: Prediction
    after: Prediction
    residual_sigma: float
    identifiable: bool
    nfev: int
    seconds: float
    message: str
    success: bool
    unsettled: float = 0.0
    notes: list[str] = field(default_factory=list)
    drive: TendonDrive | None = None
    validation_data: Measurements | None = None
    validation: Prediction | None = None
    pinned: list[str] = field(default_factory=list)

    @property
    def errors_before(self) -> np.ndarray:
        """Tip errors |predicted − measured| (M,) m with the start values."""
        return np.linalg.norm(self.before.tip - self.data.tip, axis=1)

    @property
    def errors_after(self) -> np.ndarray:
        """Tip errors (M,) m with the fitted values."""
        return np.linalg.norm(self.after.tip - self.data.tip, axis=1)


def _residuals(pred: Prediction, data: Measurements) -> np.ndarray:
    parts = [((pred.tip - data.tip) / data.sigma[:, None]).ravel()]
    if data.tip_direction is not None and data.sigma_dir is not None:
        parts.append(((pred.tip_direction - data.tip_direction) / data.sigma_dir[:, None]).ravel())
    return np.concatenate(parts)


def _fit_base(params: RobotParams, data: Measurements) -> tuple[RobotParams, list[str]]:
    """``params`` checked against the data (cable count), with ``max_tension`` raised to the
    largest measured tension if the data exceed it."""
    if data.n_cables != params.n_cables:
        raise ValueError(
            f"the data have {data.n_cables} cable column(s) but the robot has "
            f"{params.n_cables} cables"
        )
    if data.tensions is None:
        return params, []
    peak = float(data.tensions.max(initial=0.0))
    if peak > params.max_tension:
        return replace(params, max_tension=peak), [
            f"max_tension raised from {params.max_tension:g} N to the largest measured "
            f"tension {peak:g} N"
        ]
    return params, []


def calibrate(
    data: Measurements,
    params: RobotParams,
    fit: str | Sequence[str],
    backend: str = "analytic",
    backend_kwargs: dict[str, Any] | None = None,
    start: dict[str, float] | None = None,
    *,
    ramp_steps: int = 25,
    settle_steps: int = 100,
    max_nfev: int | None = None,
    progress: Callable[[str], None] | None = None,
    drive: TendonDrive | None = None,
    validate: Measurements | None = None,
    slack: bool = True,
    stiffness_scale: float = 1.0,
    replay_options: dict[str, Any] | None = None,
) -> CalibrationResult:
    """Fit the parameters ``fit`` of the robot ``params`` to the measurements ``data``.

    Args:
        data: the measurements (:func:`~cdcr_gym.calibration.data.read_csv`).
        params: the nominal robot, the start of the fit.
        fit: parameter names or aliases (``"E,mu,payload"`` or a list; see
            :mod:`cdcr_gym.calibration.parameters`).
        backend: "analytic" (CCKA/PCC, batched, frictionless, no gravity) or a physics backend
            ("bullet", "mujoco") replayed through the rows in order
            (:class:`~cdcr_gym.calibration.simulate.BackendReplay`).
        backend_kwargs: fixed backend arguments (e.g. ``{"gravity": True}``); values given
            here for fitted parameters (friction_coefficient, tip_payload) are their start.
        start: start values (SI) of fitted parameters; default the robot's, then
            ``backend_kwargs``'s, then :data:`DEFAULT_START` (0 for offsets and tilt).
        ramp_steps, settle_steps: the physics replay's control steps per row.
        max_nfev: limit on least_squares' steps (its nfev: evaluations outside the
            finite-difference Jacobian; default scipy's, 100·p).
        progress: called with a line of text after every evaluation (e.g. ``print``).
        drive: the robot's nominal tendon drive (displacement data; default the one the robot
            carries, :meth:`TendonDrive.of`).
        validate: held-out measurements, replayed with the fitted values after the fit (they
            never enter it).
        slack, stiffness_scale: the drive law's ablations (linear law; k multiplied), for the
            CCKA model and the MuJoCo displacement replay.
        replay_options: the physics displacement replay's timing (``first_hold``,
            ``max_gap``, ``default_gap``, s: :class:`~cdcr_gym.calibration.physics.PhysicsReplay`).

    Physics backends on displacement data: :class:`~cdcr_gym.calibration.physics.PhysicsReplay`
    (the rows in order with their recorded timing); its Jacobian is one batched replay of
    the perturbed robots.

    Backends: "analytic" and "ccka" are the same CCKA model; with displacement data, or any
    name of the drive model (base frame, lengths, tendon drive), it is
    :class:`~cdcr_gym.calibration.simulate.DriveReplay`, whose Jacobian is one batched solve.

    Returns:
        A :class:`CalibrationResult`.

    Raises:
        ValueError: for unknown or duplicate parameter names, parameters the backend does not
            model, fewer measurements than parameters + 1, or a cable-count mismatch.
    """
    base, notes = _fit_base(params, data)
    cls = backend_class(backend)
    physics_drive = cls is not None and data.displacements is not None
    names = resolve_names(
        list(fit) if not isinstance(fit, str) else fit,
        base,
        cls,
        backend,
        displacement=physics_drive,
    )
    names, pin_notes = pin_ill_posed(names, base)
    notes += pin_notes
    for name in ("drive_backlash", "drive_softening"):
        if data.displacements is None and name in names:
            raise ValueError(
                f"parameter {name!r} needs displacement data (the drives' commands in row "
                "order); these data give tensions"
            )
    if drive is None:
        drive = TendonDrive.of(base)
    if physics_drive and drive is None:
        raise ValueError(
            "displacement data need the robot's tendon drive (stiffness, pretension): give a "
            "params YAML with calibration.tendons or a robot with tendon_stiffness"
        )
    if validate is not None and validate.n_cables != data.n_cables:
        raise ValueError(
            f"the validation data have {validate.n_cables} tendon column(s), the training data "
            f"{data.n_cables}"
        )
    if validate is not None and (validate.displacements is None) != (data.displacements is None):
        raise ValueError(
            "the validation and training data must both give displacements or both tensions"
        )
    if len(data) < len(names) + 1:
        raise ValueError(
            f"too few points: {len(data)} measurement(s) for {len(names)} parameter(s) "
            f"{names}; need at least {len(names) + 1}"
        )
    start = {
        canon: float(v) for key, v in (start or {}).items() for canon in expand_names([key], base)
    }
    for key, v in start.items():
        check_start(key, v)
    stray = sorted(set(start) - set(names))
    pinned_here = [n for n in stray if any(n in note for note in pin_notes)]
    stray = [n for n in stray if n not in pinned_here]
    if stray:
        raise ValueError(f"start values given for {stray}, which are not fitted (fitted: {names})")
    owner = np.asarray(base.cable_section)
    fixed = dict(backend_kwargs or {})
    start_values: dict[str, float] = {}
    for n in names:
        if start and n in start:
            start_values[n] = float(start[n])
        elif n == "youngs_modulus":
            start_values[n] = base.youngs_modulus
        elif n == "cable_radius":
            start_values[n] = max(base.cable_radii)
        elif n in fixed:
            start_values[n] = float(fixed.pop(n))
        elif n.startswith("length_s"):
            start_values[n] = base.sections[int(n[8:]) - 1].length
        elif n.startswith("cable_radius_s"):
            start_values[n] = base.sections[int(n[14:]) - 1].cable_radius
        elif n == "base_compliance":
            start_values[n] = drive.base_compliance if drive is not None else 0.0
        elif n == "drive_backlash":
            start_values[n] = drive.backlash if drive is not None else 0.0
        elif n == "drive_softening":  # at σ = 0 the tips do not move to first order in σ
            have = drive.softening if drive is not None else 0.0
            start_values[n] = have if have > 0.0 else SOFTENING_START
        elif n.startswith(("tendon_stiffness", "tendon_pretension")):
            if drive is None:
                raise ValueError(
                    f"parameter {n!r} needs the robot's tendon drive (stiffness, pretension) "
                    "or a --start value"
                )
            arr = np.array(drive.stiffness if "stiffness" in n else drive.pretension)
            tail = n.split("_")[-1]
            if tail.startswith("s") and tail[1:].isdigit():
                arr = arr[owner == int(tail[1:]) - 1]
            elif tail.isdigit():
                arr = arr[int(tail) - 1 : int(tail)]
            start_values[n] = float(arr.mean())
        else:
            start_values[n] = DEFAULT_START.get(n, 0.0)
    use_drive = cls is None and (
        data.displacements is not None
        or backend == "ccka"
        or any(drive_only(n) for n in names)
        or not slack
        or stiffness_scale != 1.0
    )

    def physics_replay(rows: Measurements) -> PhysicsReplay:
        """The in-order physics replay of ``rows`` with this fit's drive and options."""
        assert drive is not None  # checked above
        return PhysicsReplay(
            rows,
            base,
            drive,
            cls,
            fixed,
            slack=slack,
            stiffness_scale=stiffness_scale,
            **(replay_options or {}),
        )

    model: AnalyticReplay | BackendReplay | DriveReplay | PhysicsReplay
    if physics_drive:
        model = physics_replay(data)
        model.name = backend
    elif use_drive:
        if fixed:
            raise ValueError(f"the ccka backend takes no backend arguments, got {sorted(fixed)}")
        model = DriveReplay(data, base, drive, slack=slack, stiffness_scale=stiffness_scale)
    elif cls is None:
        model = AnalyticReplay(data, base, fixed)
    else:
        model = BackendReplay(data, base, cls, fixed, ramp_steps, settle_steps)
        model.name = backend
    specs = parameter_specs(names, base, start_values, bend_limit=not (use_drive or physics_drive))
    x0 = np.array([s.to_x(start_values[s.name]) for s in specs])
    lo, hi = (np.array(b) for b in zip(*(s.bounds_x() for s in specs)))
    x0 = np.clip(x0, lo + 1e-6, hi - 1e-6)  # trf starts strictly inside the bounds

    def values_of(x: np.ndarray) -> dict[str, float]:
        return {s.name: s.from_x(float(v)) for s, v in zip(specs, x)}

    count = [0]

    def residuals(x: np.ndarray) -> np.ndarray:
        count[0] += 1
        r = _residuals(model(values_of(x)), data)
        if progress is not None:
            shown = ", ".join(f"{k}={v:.6g}" for k, v in values_of(x).items())
            progress(f"  eval {count[0]:3d}: cost {0.5 * float(r @ r):.6g}  ({shown})")
        return r

    jac: Any = "2-point"
    if isinstance(model, (PhysicsReplay, DriveReplay)):
        batched_model = model
        # forward differences, every column a robot of one batched evaluation (a physics replay's
        # frame-only columns share the unperturbed robot); relative step 1e-3 for a simulation,
        # 1e-6 for the quasi-static solve
        rel_step = 1e-3 if isinstance(model, PhysicsReplay) else 1e-6

        def jac(x: np.ndarray) -> np.ndarray:
            h = rel_step * np.maximum(1.0, np.abs(x))
            h = np.where(x + h > hi, -h, h)
            batch = [values_of(x)]
            for k in range(len(x)):
                xk = x.copy()
                xk[k] += h[k]
                batch.append(values_of(xk))
            tips, dirs = batched_model.batch(batch)[:2]
            res = [_residuals(Prediction(tips[b], dirs[b]), data) for b in range(len(batch))]
            count[0] += len(x)
            if progress is not None and isinstance(batched_model, PhysicsReplay):
                progress(f"  jacobian: {batched_model.timing.history[-1]}")
            return np.stack([(res[k + 1] - res[0]) / h[k] for k in range(len(x))], axis=1)

    t0 = time.perf_counter()
    before = model(start_values)
    result = least_squares(
        residuals,
        x0,
        jac=jac,
        bounds=(lo, hi),
        method="trf",
        x_scale=1.0,
        diff_step=1e-6 if cls is None else 1e-3,
        max_nfev=max_nfev,
    )
    seconds = time.perf_counter() - t0
    values = values_of(result.x)
    after = model(values)
    validation = None
    if validate is not None:
        replay = (
            DriveReplay(validate, base, drive, slack=slack, stiffness_scale=stiffness_scale)
            if isinstance(model, DriveReplay)
            else physics_replay(validate)
            if isinstance(model, PhysicsReplay) and drive is not None
            else AnalyticReplay(validate, base, fixed)
            if cls is None
            else BackendReplay(validate, base, cls, fixed, ramp_steps, settle_steps)
        )
        validation = replay(values)
        seconds = time.perf_counter() - t0
    n_res, p = result.fun.size, len(specs)
    dof = max(n_res - p, 1)
    s2 = float(result.fun @ result.fun) / dof
    jtj = result.jac.T @ result.jac
    identifiable = bool(np.linalg.cond(jtj) < SINGULAR)
    cov = np.linalg.pinv(jtj) * s2
    sd_x = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    denom = np.outer(sd_x, sd_x)
    corr = np.divide(cov, denom, out=np.full_like(cov, np.nan), where=denom > 0)
    tq = float(student_t.ppf(0.975, dof))
    std, ci = {}, {}
    for k, s in enumerate(specs):
        d = abs(s.derivative(float(result.x[k])))
        std[s.name] = d * sd_x[k] if identifiable else math.inf
        ci[s.name] = tq * std[s.name]
    if not identifiable:
        notes.append(
            "JᵀJ is singular: these data cannot tell some fitted parameters apart (see the "
            "correlations); fix one of them (e.g. keep the cable radius when fitting E without "
            "gravity)"
        )
    at_bound = [s.name for k, s in enumerate(specs) if result.active_mask[k] != 0]
    if at_bound:
        notes.append(f"at a bound of its range: {at_bound}")
    strong = [
        f"{names[i]}/{names[j]} ({corr[i, j]:+.3f})"
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.95
    ]
    if strong:
        notes.append(
            "strongly correlated (|r| > 0.95), traded against each other by the data: "
            + ", ".join(strong)
        )
    fitted_drive = _fitted_drive(base, drive, values)
    fitted_robot = _fitted_robot(base, values)
    if fitted_drive is not None and hasattr(fitted_robot, "tendon_stiffness"):
        try:
            fitted_robot = replace(
                fitted_robot,
                tendon_stiffness=fitted_drive.stiffness,  # type: ignore[call-arg]
                tendon_pretension=fitted_drive.pretension,  # type: ignore[call-arg]
                base_compliance=fitted_drive.base_compliance,  # type: ignore[call-arg]
            )
        except ValueError as exc:
            notes.append(
                "the robot in params.yaml keeps the nominal tendon drive (the fitted one is in "
                f"calibration.tendons): {exc}"
            )
    return CalibrationResult(
        names=names,
        start=start_values,
        values=values,
        ci95=ci,
        std=std,
        correlation=corr,
        params=fitted_robot,
        backend_kwargs=model.backend_kwargs(values),
        backend=backend,
        data=data,
        before=before,
        after=after,
        residual_sigma=math.sqrt(s2),
        identifiable=identifiable,
        nfev=count[0] + 2,  # every model run, finite differences and before/after included
        seconds=seconds,
        message=str(result.message),
        success=bool(result.success),
        unsettled=max(before.unsettled, after.unsettled),
        notes=notes,
        drive=fitted_drive,
        validation_data=validate,
        validation=validation,
        pinned=[n for n in pin_notes],
    )


def _fitted_robot(base: RobotParams, values: dict[str, float]) -> RobotParams:
    """The robot with the fitted geometry (section lengths and radii, angles, pitch, E); if the fitted
    robot's bend limits exceed π at the nominal ``max_tension``, that limit is lowered."""
    sections = []
    owner = np.asarray(base.cable_section)
    k = 0
    common = values.get("cable_radius", max(base.cable_radii)) - max(base.cable_radii)
    for j, sec in enumerate(base.sections):
        angles = []
        for a in sec.cable_angles:
            k += 1
            angles.append(
                a + values.get(f"cable_angle_{k}", 0.0) + values.get(f"section_angle_s{j + 1}", 0.0)
            )
        sections.append(
            replace(
                sec,
                length=values.get(f"length_s{j + 1}", sec.length),
                cable_radius=values.get(f"cable_radius_s{j + 1}", sec.cable_radius + common),
                cable_angles=tuple(angles),
            )
        )
    del owner
    geometry: dict[str, Any] = dict(
        sections=tuple(sections),
        youngs_modulus=values.get("youngs_modulus", base.youngs_modulus),
        cable_pitch=values.get("cable_pitch", base.cable_pitch),
        length=None,
        n_disks=None,
        cable_radius=None,
    )
    try:
        return replace(base, **geometry)
    except ValueError:
        probe = replace(base, **geometry, max_tension=1e-6)
        limit = max(probe.section_bend_limits) / 1e-6
        return replace(probe, max_tension=0.999 * math.pi / limit)


def _fitted_drive(
    base: RobotParams, drive: TendonDrive | None, values: dict[str, float]
) -> TendonDrive | None:
    """The drive with the fitted stiffness and pretension."""
    if drive is None:
        return None
    from cdcr_gym.calibration.simulate import drive_geometry

    g = drive_geometry(base, drive, [values])
    comp = g.base_compliance[0] if g.base_compliance is not None else drive.base_compliance
    return TendonDrive(
        tuple(g.stiffness[0]),
        tuple(g.pretension[0]),
        drive.displacement_range,
        drive.max_tension,
        float(comp),
        float(values.get("drive_backlash", drive.backlash)),
        float(values.get("drive_softening", drive.softening)),
    )


def specs_of(result: CalibrationResult) -> list[ParameterSpec]:
    """The parameter specs of a result (units for reports)."""
    return parameter_specs(result.names, result.params, result.start)
